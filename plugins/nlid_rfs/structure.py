"""Restoring-force-surface least squares on a structure of several DOFs.

Every DOF ``k`` contributes its force balance at every sample,

    ``f_k - (M a)_k = (K z)_k + (C v)_k + s_k + sum_e B_ke theta_e g_e(x_e, x_e')``,

and the equations of all DOFs are solved as **one** least squares
(:func:`nlid.plugin.structure_linear_design`): an element's coefficient
``theta_e`` is one unknown shared by the two DOFs it connects (``+`` at
``i``, ``-`` at ``j``), and the underlying linear ``K`` and ``C`` are
estimated with it, symmetric (reciprocity: ``n (n + 1) / 2`` entries each),
with the constant force per DOF when the element set has it.

Mass
    Given: ``M a`` moves to the left-hand side. Not given: the lumped
    (diagonal) masses are unknowns too, ``f = M a + ...``. A DOF without a
    force has a homogeneous equation, whose scale is fixed only through what
    it shares with a driven DOF (the symmetric coupling entries of ``K`` and
    ``C``, the shared element coefficients): the estimate needs a connected
    structure with at least one driven DOF.

Weighting
    The DOFs' equations have different scales (a driven DOF carries the
    force). A first, unweighted solution gives each DOF's residual RMS; the
    reported solution weights each DOF's equations by its inverse
    (feasible weighted least squares), so that each DOF counts by its own
    noise. Standard errors are the batch-means sandwich errors of the
    weighted problem (:func:`nlid.plugin.least_squares`), the DOFs' equations
    interleaved sample by sample.

Derivatives and filtering are those of the one-DOF method, per DOF, with one
cut-off for every DOF (:func:`nlid.plugin.structure_regression_data`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from nlid.plugin import (
    ElementSet,
    IdentificationError,
    StructureEstimate,
    StructureRecord,
    check_elements_nonlinear,
    collinearity_warnings,
    dof_weights,
    least_squares,
    structure_linear_design,
    structure_regression_data,
)

__all__ = ["identify_structure", "solve_structure", "StructureSolution"]


class StructureSolution:
    """The weighted joint least squares of a structure (what :func:`solve_structure` returns).

    Attributes
    ----------
    theta, K, C, M, s
        Element coefficients, matrices (``M`` ``None`` when given) and static force per DOF (or ``None``).
    fit
        The :class:`nlid.regression.LeastSquaresFit` of the weighted problem.
    design
        The :class:`~nlid.mdof.regression.LinearDesign`.
    weights
        The weight of each DOF's equations (1 / its first-pass residual RMS).
    """

    def __init__(self, parts: Mapping[str, Any], fit: Any, design: Any, weights: np.ndarray) -> None:
        self.theta = parts["theta"]
        self.K, self.C, self.M, self.s = parts["K"], parts["C"], parts["M"], parts["s"]
        self.fit = fit
        self.design = design
        self.weights = weights


def solve_structure(
    data: Any, elements: ElementSet, mass: np.ndarray | None, *, step: int = 1, correlation: float = 1.0
) -> StructureSolution:
    """Solve the joint force balance of every DOF (module docstring) on prepared balance samples.

    Raises
    ------
    IdentificationError
        A rank-deficient problem (e.g. a mass matrix that cannot be estimated
        because no DOF is driven), or an estimated mass that is not positive.
    """
    design = structure_linear_design(data, elements, mass=mass, step=step)
    n = data.n_dofs
    X, y = design.X, design.y
    if y.size <= X.shape[1]:
        raise IdentificationError(f"rfs: {y.size} equations for {X.shape[1]} unknowns; lower 'decimate'")
    if not np.any(y):
        raise IdentificationError("rfs: no force acts on the structure; its mass and stiffness cannot be scaled")
    first = least_squares(X, y, design.names, correlation_length=correlation * n, context="rfs: ")
    weights = dof_weights(first.residual, y, n)
    w = np.tile(weights, X.shape[0] // n)
    fit = least_squares(X * w[:, None], y * w, design.names, correlation_length=correlation * n, context="rfs: ")
    parts = design.split(fit.coefficients)
    if parts["M"] is not None and not np.all(np.diag(parts["M"]) > 0):
        bad = [f"{m:.4g}" for m in np.diag(parts["M"])]
        raise IdentificationError(
            f"rfs: the estimated masses are not all positive ({', '.join(bad)} kg); give mass= "
            "(a structure needs a driven DOF connected to every other for its mass to be estimated)"
        )
    return StructureSolution(parts, fit, design, weights)


def identify_structure(
    record: StructureRecord, elements: ElementSet, mass: np.ndarray | None, settings: Mapping[str, Any]
) -> StructureEstimate:
    """rfs on a structure record (module docstring)."""
    check_elements_nonlinear(elements, "rfs: ")
    data = structure_regression_data(record, elements, cutoff=settings["cutoff"])
    q = int(settings["decimate"])
    corr = 1.0 if data.filtered_at is None else record.fs / data.filtered_at / q
    sol = solve_structure(data, elements, mass, step=q, correlation=corr)
    fit, design = sol.fit, sol.design
    se = np.sqrt(np.clip(np.diag(fit.covariance), 0.0, None))
    se_iid = np.sqrt(np.clip(np.diag(fit.covariance_iid), 0.0, None))
    theta_se = se[design.parts["theta"]]
    warnings = collinearity_warnings(design.X[:, design.parts["theta"]], list(elements.names)) if len(elements) else []
    return StructureEstimate(
        coefficients=elements.as_dict(sol.theta),
        K=sol.K,
        C=sol.C,
        static=sol.s,
        M=sol.M,
        standard_errors=elements.as_dict(theta_se) if len(elements) else {},
        warnings=warnings,
        diagnostics={
            "condition_number": fit.condition_number,
            "samples_used": int(design.y.size // record.n_dofs),
            "equations": int(design.y.size),
            "decimate": q,
            "filtered_at_hz": data.filtered_at,
            "channels": data.provenance,
            "dof_weights": sol.weights.tolist(),
            "unknowns": list(design.names),
            "standard_errors_all": dict(zip(design.names, se.tolist(), strict=True)),
            "standard_errors_iid": elements.as_dict(se_iid[design.parts["theta"]]) if len(elements) else {},
            "standard_error_batches": fit.batches,
            "stiffness_form": "symmetric",
            "mass_form": None if mass is not None else "diagonal",
        },
    )
