"""Restoring-force-surface least squares on a structure of several DOFs.

Every DOF ``k`` contributes its force balance at every sample,

    ``f_k - (M a)_k = (K z)_k + (C v)_k + s_k + sum_e B_ke theta_e g_e(x_e, x_e')``,

and the equations of all DOFs are solved as **one** least squares,
nlid's joint least squares of a structure (:func:`nlid.plugin.joint_least_squares`,
which ``discover`` on a structure uses too): an element's coefficient
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
    Record,
    StructureEstimate,
    check_elements_nonlinear,
    collinearity_warnings,
    joint_least_squares,
    structure_regression_data,
)

__all__ = ["identify_structure"]


def identify_structure(
    record: Record, elements: ElementSet, mass: np.ndarray | None, settings: Mapping[str, Any]
) -> StructureEstimate:
    """rfs on a structure record (module docstring)."""
    check_elements_nonlinear(elements, "rfs: ")
    data = structure_regression_data(record, elements, cutoff=settings["cutoff"])
    q = int(settings["decimate"])
    corr = 1.0 if data.filtered_at is None else record.fs / data.filtered_at / q
    sol = joint_least_squares(data, elements, mass, step=q, correlation=corr, context="rfs: ")
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
