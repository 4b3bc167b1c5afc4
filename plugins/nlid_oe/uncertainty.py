"""Standard errors of an output-error fit: from the Jacobian at the optimum, segment states profiled out.

Each segment's initial-state columns are projected out of the global ones (the continuity rows are left out,
which makes the errors slightly conservative with several segments), then the batch-means sandwich of
:func:`nlid.plugin.least_squares` accounts for the residual's correlation (batches from its integrated
autocorrelation time).
"""

from __future__ import annotations

import numpy as np

from nlid.plugin import IdentificationError, least_squares

from .problem import Problem


def standard_errors(problem: Problem, residual: np.ndarray, u: np.ndarray):
    """Batch-means sandwich standard errors of the global parameters (scaled), segments profiled out."""
    import emcee

    G = problem.G
    rows = problem.rows_data
    Jg, Jl, _ = problem.blocks(u)
    Xg = Jg.copy()
    edges = np.append(problem.starts, problem.record.n) * problem.C
    for k in range(problem.K):
        a, b = edges[k], edges[k + 1]
        coef, *_ = np.linalg.lstsq(Jl[a:b], Xg[a:b], rcond=None)
        Xg[a:b] -= Jl[a:b] @ coef
    r = residual[:rows]
    try:
        tau = float(emcee.autocorr.integrated_time(r, tol=0, quiet=True)[0])
    except Exception:  # noqa: BLE001 - a residual too short for the estimate: independent errors
        tau = 1.0
    tau = max(tau, 1.0)
    ug = u[:G]
    names = [p.name for p in problem.params]
    try:
        fit = least_squares(Xg, Xg @ ug - r, names, correlation_length=tau, coefficients=ug, context="oe: ")
    except IdentificationError as exc:
        raise IdentificationError(
            f"{exc}: the Gauss-Newton Hessian of the free-run error is singular, so some parameters are not "
            "determined by this record (fix them: fewer shape parameters, the mass given, or fewer terms)"
        ) from None
    return fit.standard_errors, fit.standard_errors_iid, tau, fit.batches
