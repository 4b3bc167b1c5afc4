"""Tables of one identified model: the summary ``nlid identify`` prints and the coefficient DataFrame.

Used by :meth:`nlid.identified.model.IdentifiedModel.summary` and
:meth:`~nlid.identified.model.IdentifiedModel.to_frame`, which pass themselves; like
:mod:`nlid.identified.plots`, this module does not import the identified model.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import TYPE_CHECKING, Any

from ..base.dimensions import mass_unit
from ..data.forcehold import describe_force_hold
from ..data.units import Unit, coefficient_conversion, display_units
from ..errors import InputError
from ..report.summary import Column, Summary

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

    from .model import IdentifiedModel

__all__ = ["shown_units", "record_units", "coefficient_frame", "coefficient_table", "model_summary"]


def record_units(fit: Any) -> tuple[str, str]:
    """``(force, displacement)``: the units the model's record was in (``("N", "m")``, or ``("V", "V")`` for a
    record in volts such as Silverbox), from its provenance; SI when it has none.

    Every unit a model shows (coefficients, mass, equilibria, axes) is derived from these
    (:mod:`nlid.base.dimensions`), so a record in volts shows ``s^2`` for its mass, not ``kg``.
    """
    data = (getattr(fit, "provenance", None) or {}).get("data") or {}
    units = data.get("units") or {}
    force = (units.get("f") or {}).get("si") or "N"
    length = (units.get("z") or {}).get("si") or "m"
    return str(force), str(length)


def shown_units(fit: IdentifiedModel, units: str | Mapping[str, str] | None) -> dict[str, Unit] | None:
    """The units the coefficients of ``fit`` are shown in; ``None`` for SI as computed.

    Parameters
    ----------
    fit
        The identified model.
    units
        ``None`` or ``"si"`` (SI), ``"input"`` (the units its data were given in, from its
        provenance) or the units to show (:func:`nlid.data.units.display_units`).

    Raises
    ------
    InputError
        ``"input"`` for a model that does not record the units of its data, or units outside the vocabulary.
    """
    if units is None or (isinstance(units, str) and units.strip().lower() == "si"):
        return None
    if isinstance(units, str) and units.strip().lower() == "input":
        data = fit.provenance.get("data") if fit.provenance else None
        if not data or "units" not in data:
            raise InputError(
                "units='input': this model does not record the units of its data (it was not made by "
                "nlid.identify); name them, e.g. units={'z': 'mm'}"
            )
        return display_units("input", data["units"])
    return display_units(units)


def coefficient_frame(fit: IdentifiedModel, units: str | Mapping[str, str] | None = None) -> pd.DataFrame:
    """:meth:`nlid.identified.model.IdentifiedModel.to_frame`: one row per term (index: the term).

    Parameters
    ----------
    fit
        The identified model.
    units
        As for :func:`shown_units`.
    """
    import pandas as pd

    se = fit.standard_errors or {}
    shown = shown_units(fit, units)
    force, length = record_units(fit)
    rows = []
    for n, t in zip(fit.terms, fit.model.terms, strict=True):
        factor, unit = (
            (1.0, t.coefficient_unit_in(force, length)) if shown is None else coefficient_conversion(t, shown)
        )
        value, error = fit.coefficients[n], se.get(n, float("nan"))
        if shown is not None:
            value, error = value * factor, error * factor
        rows.append({"term": n, "coefficient": value, "std_error": error, "unit": unit, "family": t.family})
    return pd.DataFrame(rows).set_index("term")


def model_summary(fit: IdentifiedModel, units: str | Mapping[str, str] | None = None) -> Summary:
    """:meth:`nlid.identified.model.IdentifiedModel.summary`: coefficients, equilibria, modes, residuals.

    Parameters
    ----------
    fit
        The identified model.
    units
        As for :func:`shown_units` (the mass stays in kg).
    """
    shown = shown_units(fit, units)
    force, length = record_units(fit)
    zu = length if shown is None else shown["z"].symbol
    zf = 1.0 if shown is None else shown["z"].factor  # the SI value of one displayed length unit
    out = Summary()
    head = [("method", fit.method)]
    if fit.mass is not None:
        how = "estimated" if fit.mass_estimated else "given"
        se = f" +/- {fit.mass_standard_error:.3g}" if fit.mass_standard_error else ""
        head.append(("mass", f"{fit.mass:.6g}{se} {mass_unit(force, length)} ({how})"))
    if shown is not None:
        head.append(("units", ", ".join(f"{c} in {shown[c].symbol}" for c in ("f", "z", "v"))))
    data = (fit.provenance or {}).get("data") or {}
    if data.get("force_hold"):  # the assumption about the force between samples, and where it came from
        head.append(
            ("force between samples", describe_force_hold(data["force_hold"], data.get("force_hold_source", "default")))
        )
    path = getattr(fit, "input_path", None)
    if path is not None and not path.identity:  # said only when the force does not act as recorded
        head.append(("input path", path.describe()))
    out.add_fields(head)
    se = fit.standard_errors or {}
    rows = []
    for name, term in zip(fit.terms, fit.model.terms, strict=True):
        factor, unit = (
            (1.0, term.coefficient_unit_in(force, length)) if shown is None else coefficient_conversion(term, shown)
        )
        error = se.get(name)
        rows.append((name, fit.coefficients[name] * factor, None if error is None else error * factor, unit))
    coefficient_table(out, "term", rows)
    if fit.px_roots:
        zm, zp = fit.px_roots[0] / zf, fit.px_roots[1] / zf
        out.add_fields([("px(z) roots", f"z- = {zm:.6g} {zu}, z+ = {zp:.6g} {zu}")])
    if fit.equilibria is not None:
        st = ", ".join(f"{z / zf:.6g}" for z in fit.equilibria.stable) or "none"
        un = ", ".join(f"{z / zf:.6g}" for z in fit.equilibria.unstable) or "none"
        out.add_fields([(f"equilibria ({zu})", f"stable {st}; unstable {un}")], gap=True)
    out.add_text(
        *(
            f"at z* = {m.equilibrium / zf:.6g} {zu}: fn = {m.fn_hz:.4g} Hz, zeta = {100 * m.zeta:.3g} %"
            for m in fit.modal
        ),
        indent="  ",
    )
    scores = []
    if fit.scores is not None:
        scores = [
            ("epsilon (Eq. 26)", f"{fit.scores.eps_percent:.3g} %"),
            ("force residual", f"{fit.scores.force_residual_percent:.3g} %"),
        ]
    out.add_fields(scores, separator="   ", gap=True)  # the blank line stays when there are no scores
    return fit._summary_tail(out)


def coefficient_table(out: Summary, label: str, rows: Iterable[tuple[str, float, float | None, str]]) -> None:
    """Add the table of coefficients to a summary, one DOF's (``label`` ``"term"``) or a structure's (``"element"``).

    Each row is ``(name, coefficient, standard error or None, unit)``, shown to 6 and 3 significant digits.
    """
    out.add_table(
        [Column(label), Column("coefficient", "right", 14), Column("std. error", "right", 11), Column("unit")],
        [[name, f"{value:.6g}", "" if error is None else f"{error:.3g}", unit] for name, value, error, unit in rows],
    )
