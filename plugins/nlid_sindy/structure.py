"""Sparse identification of a structure of several DOFs over the relative-coordinate library.

The library
    Every candidate is an element: a term of the one-DOF library evaluated on
    the relative coordinate of a connection (:mod:`nlid.model.elements`).
    ``library = "terms"``: the elements given. ``library = "automatic"``: the
    elements given plus, on **every** connection (every pair ``(i, j)`` and
    every DOF to the ground), ``x^2 .. x^degree``, ``x'|x'|``, ``x'^3``,
    ``sign(x')``, ``x x'`` and ``x^2 x'`` (:func:`structure_candidates`).
    The linear part (``x`` and ``x'`` on every connection) is the underlying
    linear ``K`` and ``C``, estimated in full with the elements.

The regression: one sparse equation with shared coefficients
    An element's force enters both DOFs it connects with opposite signs, so
    a per-DOF SINDy (one equation per DOF, each with its own coefficient for
    the same element) would estimate each element twice and could keep it in
    one DOF's equation and drop it in the other's. This plugin instead stacks
    every DOF's force balance into **one** equation (the same design as
    ``rfs``: :func:`nlid.plugin.structure_linear_design`, symmetric ``K`` and
    ``C``, the DOFs' equations weighted by their first-pass residual RMS) and
    runs pysindy's STLSQ optimizer on it: each element has one coefficient
    and is kept or dropped as a whole; entries of ``K`` and ``C`` are
    candidates too (a chain's zero ``K[1,3]`` may be dropped); an estimated
    mass is never dropped. The threshold is relative (a column is kept when
    its RMS contribution reaches that fraction of the RMS of the stacked
    left-hand side) and chosen, by default, by contiguous K-fold
    cross-validation with the one-standard-error rule
    (:mod:`nlid_sindy.threshold`), as for one DOF.

    pysindy's state-space ``SINDy`` object is not used here: its equations
    (one per state) cannot share a coefficient; its optimizer is.

Kept candidates that are not among the elements given are reported
(warnings and ``diagnostics["extra_elements"]``), not returned as coefficients.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from nlid.plugin import (
    EDGE_PERIODS,
    ElementSet,
    IdentificationError,
    Record,
    StructureEstimate,
    check_elements_nonlinear,
    dof_weights,
    least_squares,
    structure_linear_design,
    structure_regression_data,
)

from .threshold import choose_threshold, stlsq

__all__ = ["identify_structure", "structure_candidates"]

_DAMPING = ("{v}*|{v}|", "{v}^3", "sign({v})", "{x}*{v}", "{x}^2*{v}")


def structure_candidates(n_dofs: int, degree: int) -> list[str]:
    """The automatic candidates on every connection of ``n_dofs`` DOFs (module docstring)."""
    out = []
    pairs = [(i, j) for i in range(1, n_dofs + 1) for j in range(i + 1, n_dofs + 1)]
    for i, j in [*pairs, *[(k, 0) for k in range(1, n_dofs + 1)]]:
        x, v = (f"(z{i}-z{j})", f"(v{i}-v{j})") if j else (f"z{i}", f"v{i}")
        out += [f"{x}^{p}" for p in range(2, degree + 1)]
        out += [t.format(x=x, v=v) for t in _DAMPING]
    return out


def _library(elements: ElementSet, settings: Mapping[str, Any]) -> ElementSet:
    if settings["library"] != "automatic":
        return elements
    given = set(elements.elements)
    candidates = ElementSet.from_spec(structure_candidates(elements.n_dofs, settings["degree"]), elements.n_dofs)
    extra = [e for e in candidates if e not in given]
    return ElementSet((*elements.elements, *extra), elements.n_dofs, elements.static, elements.px_roots)


def identify_structure(
    record: Record, elements: ElementSet, mass: np.ndarray | None, settings: Mapping[str, Any]
) -> StructureEstimate:
    """sindy on a structure record (module docstring)."""
    if settings["differentiation"] != "nlid":
        raise IdentificationError(
            "sindy: a structure's derivatives come from nlid's shared filters; differentiation='pysindy' is for one DOF"
        )
    check_elements_nonlinear(elements, "sindy: ")
    library = _library(elements, settings)
    data = structure_regression_data(record, library, cutoff=settings["cutoff"])
    n = record.n_dofs
    design = structure_linear_design(data, library, mass=mass)
    X, y, names = design.X, design.y, list(design.names)
    if not np.any(y):
        raise IdentificationError("sindy: no force acts on the structure; its mass and stiffness cannot be scaled")
    corr = 1.0 if data.filtered_at is None else record.fs / data.filtered_at
    first = least_squares(X, y, names, correlation_length=corr * n, context="sindy: ")
    weights = dof_weights(first.residual, y, n)
    w = np.tile(weights, X.shape[0] // n)
    Xw, yw = X * w[:, None], y * w
    scale = float(np.sqrt(np.mean(yw**2)))
    protected = tuple(range(design.parts["M"].start, design.parts["M"].stop)) if "M" in design.parts else ()
    choice = None
    if settings["threshold"] is None:
        gap = int(np.ceil(EDGE_PERIODS * corr * n)) if data.filtered_at else 0
        choice = choose_threshold(Xw, yw / scale, names, folds=settings["folds"], gap=gap, protected=protected)
        threshold = choice.threshold
    else:
        threshold = float(settings["threshold"])
    opt = stlsq(threshold, yw.size)
    try:
        opt.fit(Xw, yw / scale)
    except Exception as exc:  # noqa: BLE001 - whatever pysindy raises is reported as the plugin's
        raise IdentificationError(f"sindy: pysindy's STLSQ failed: {type(exc).__name__}: {exc}") from exc
    support = np.flatnonzero(np.asarray(opt.coef_).reshape(-1))
    missing = [names[j] for j in protected if j not in support]
    if missing:
        raise IdentificationError(f"sindy: the threshold {threshold:g} dropped the mass ({', '.join(missing)})")
    if support.size == 0:
        raise IdentificationError(f"sindy: the threshold {threshold:g} dropped every column; lower 'threshold'")
    fit = least_squares(Xw[:, support], yw, [names[j] for j in support], correlation_length=corr * n, context="sindy: ")
    p = np.zeros(X.shape[1])
    p[support] = fit.coefficients
    se_all = np.zeros(X.shape[1])
    se_all[support] = np.sqrt(np.clip(np.diag(fit.covariance), 0.0, None))
    parts = design.split(p)
    if parts["M"] is not None and not np.all(np.diag(parts["M"]) > 0):
        raise IdentificationError(
            "sindy: the estimated masses are not all positive "
            f"({', '.join(f'{m:.4g}' for m in np.diag(parts['M']))} kg); give mass="
        )
    theta = parts["theta"]
    se_theta = se_all[design.parts["theta"]]
    lib_names = library.names
    coefficients = {name: float(theta[lib_names.index(name)]) for name in elements.names}
    standard_errors = {
        name: float(se_theta[lib_names.index(name)]) for name in elements.names if coefficients[name] != 0.0
    }
    extra = {nm: float(c) for nm, c in zip(lib_names, theta, strict=True) if nm not in coefficients and c != 0.0}
    notes = []
    if extra:
        notes.append(
            "the automatic library kept elements that are not in the model: "
            + ", ".join(f"{k} = {c:.4g}" for k, c in extra.items())
            + " (coefficients in R; see diagnostics['extra_elements']); consider adding them"
        )
    dropped = [nm for nm in elements.names if coefficients[nm] == 0.0]
    if dropped:
        notes.append(f"sindy dropped elements of the model (coefficient 0): {', '.join(dropped)}")
    rule = "given" if choice is None else f"{choice.folds}-fold contiguous cross-validation, one-standard-error rule"
    return StructureEstimate(
        coefficients=coefficients,
        K=parts["K"],
        C=parts["C"],
        static=parts["s"],
        M=parts["M"],
        standard_errors=standard_errors,
        warnings=notes,
        diagnostics={
            "threshold": threshold,
            "threshold_rule": rule,
            "threshold_table": None if choice is None else choice.table,
            "library": list(lib_names),
            "kept": [names[j] for j in support],
            "dropped": [names[j] for j in range(len(names)) if j not in set(support.tolist())],
            "extra_elements": extra,
            "dof_weights": weights.tolist(),
            "condition_number": fit.condition_number,
            "samples_used": int(data.n),
            "filtered_at_hz": data.filtered_at,
            "channels": data.provenance,
            "regression": "one stacked equation of every DOF, shared element coefficients (pysindy STLSQ)",
        },
    )
