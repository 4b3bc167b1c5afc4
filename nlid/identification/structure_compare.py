""":func:`nlid.compare` on a structure record: several methods, one tidy table of elements and linear modes.

The rows have the columns of :data:`nlid.identified.reference.FRAME_COLUMNS`: per method each element's coefficient
(``quantity = "coefficient"``, its canonical name), the underlying linear system's natural frequencies and
damping ratios (``fn_hz``, ``zeta``, named ``m1``, ``m2``...), the residual of each DOF
(``eps_percent``, named ``z1``...) and the time. The reference is the record's ``meta["reference"]``
(a simulated structure carries its truth: the coefficients and the linear modes), an
:class:`~nlid.identified.structure.IdentifiedStructure`, or a mapping ``{"coefficients": {element: value},
"linear_modes": {"fn_hz": [...], "zeta": [...]}}`` (or a bare ``{element: value}``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any, cast

import numpy as np

from ..data.record import Record
from ..errors import InputError, NlidError, brief
from ..identified.reference import frame_row
from ..identified.result import Identified
from ..identified.structure import IdentifiedStructure
from .structure_fit import as_elements

__all__ = ["structure_reference", "structure_rows", "compare_structure"]

NAN = float("nan")


def _number(value: Any, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(float(value)):
        raise InputError(f"reference {what} must be a finite number, got {brief(value, 60)}")
    return float(value)


def _numbers(value: Any, what: str) -> list[float]:
    if not isinstance(value, Sequence) or isinstance(value, str):
        raise InputError(f"reference {what} must be a list of numbers, got {brief(value, 60)}")
    return [_number(x, what) for x in value]


def structure_reference(record: Record, reference: Any) -> dict[str, Any]:
    """``{"coefficients": {element: value}, "linear_modes": {"fn_hz": [...], "zeta": [...]}}`` (either may be empty).

    Raises
    ------
    InputError
        A reference of another type, a coefficient or mode that is not a finite number, or an element that is
        not on the record's DOFs.
    """
    if reference is None:
        reference = record.meta.get("reference") or {}
    if isinstance(reference, Identified) and reference.indexed:  # a structure's fit, whatever its class
        reference = cast(IdentifiedStructure, reference)
        lm = reference.linear_modes
        modes = {} if lm is None else {"fn_hz": list(lm.fn_hz), "zeta": list(lm.zeta)}
        return {"coefficients": dict(reference.coefficients), "linear_modes": modes}
    if not isinstance(reference, Mapping):
        raise InputError(
            f"reference must be a dict or an IdentifiedStructure for a structure, got {type(reference).__name__}"
        )
    structured = {"coefficients", "linear_modes", "structure", "M", "elements"} & set(reference)
    raw = reference.get("coefficients") if structured else reference
    if raw is None and isinstance(reference.get("structure"), Mapping):
        raw = reference["structure"].get("coefficients")
    if raw is not None and not isinstance(raw, Mapping):
        raise InputError(f"reference coefficients must map elements to values, got {type(raw).__name__}")
    coefficients = {}
    for name, value in dict(raw or {}).items():
        element = as_elements(str(name), record.n_dofs).names[-1]  # its canonical name (raises if not an element)
        coefficients[element] = _number(value, f"coefficient {brief(str(name), 40)}")
    modes = reference.get("linear_modes") if structured else None
    linear = {}
    if modes is not None:
        if not isinstance(modes, Mapping):
            raise InputError(f"reference linear_modes must be {{fn_hz: [...], zeta: [...]}}, got {brief(modes, 60)}")
        linear = {k: _numbers(modes.get(k, []), f"linear_modes.{k}") for k in ("fn_hz", "zeta")}
    return {"coefficients": coefficients, "linear_modes": linear}


def structure_rows(fit: IdentifiedStructure, reference: Mapping[str, Any]) -> list[dict[str, Any]]:
    """The rows of one identified structure against a reference (:func:`structure_reference`)."""
    se = fit.standard_errors or {}
    ref_coef = reference.get("coefficients") or {}
    rows = [
        frame_row(
            "coefficient",
            e.name,
            fit.coefficients[e.name],
            e.coefficient_unit,
            ref_coef.get(e.name),
            se.get(e.name, NAN),
        )
        for e in fit.elements
    ]
    lm = fit.linear_modes
    ref_modes = reference.get("linear_modes") or {}
    if lm is not None:
        for quantity, values, unit in (("fn_hz", lm.fn_hz, "Hz"), ("zeta", lm.zeta, "1")):
            refs = list(ref_modes.get(quantity) or [])
            for k, value in enumerate(np.asarray(values, dtype=float)):
                rows.append(frame_row(quantity, f"m{k + 1}", value, unit, refs[k] if k < len(refs) else None))
    rows += [frame_row("eps_percent", f"z{k + 1}", eps, "%") for k, eps in enumerate(fit.eps_percent or ())]
    rows.append(frame_row("seconds", "identification", NAN if fit.seconds is None else fit.seconds, "s"))
    return [{"note": "", **r} for r in rows]


def compare_structure(
    record: Record,
    terms: Any,
    names: Sequence[str],
    *,
    mass: Any = None,
    reference: Any = None,
    options: Mapping[str, Mapping[str, Any]] | None = None,
    without: Any = (),
    errors: str = "record",
) -> tuple[list[dict[str, Any]], dict[str, IdentifiedStructure]]:
    """The rows of :func:`nlid.compare` for a structure, and the fitted structures by method.

    The elements and the reference are checked before any method runs (:class:`~nlid.errors.InputError`).
    """
    from .pipeline import identify

    as_elements(terms, record.n_dofs, without=without)  # "z^3" on a structure is refused here, not per method
    ref = structure_reference(record, reference)
    rows: list[dict[str, Any]] = []
    fits: dict[str, IdentifiedStructure] = {}
    for name in names:
        try:
            fit = identify(record, terms, name, mass=mass, options=(options or {}).get(name), without=without)
        except NlidError as exc:
            if errors == "raise":
                raise
            rows.append({"method": name, "quantity": "failed", "name": "", "value": NAN, "note": str(exc)})
            continue
        fits[name] = fit
        rows += [{"method": name, **r} for r in structure_rows(fit, ref)]
    return rows, fits
