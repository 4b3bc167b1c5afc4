"""What physics forbids: the checks an identified model must pass before it is trusted.

A model whose every figure is finite can still be impossible: a passive
structure with a negative damping ratio, a mode damped beyond critical, a force
residual larger than the force, a friction law that feeds energy in, or a mass
that the record's own force balance contradicts. Each is almost always a
mistake of the input (the mass in g for kg, the displacement in mm read as m),
not of the method. :func:`check` finds them; :func:`nlid.identify` stores what
it finds as :class:`Flag` objects on the model
(:attr:`IdentifiedModel.flags <nlid.identified.model.IdentifiedModel.flags>`),
its summary and JSON show them, and the command line exits with status 1 and
one line naming the likely cause (:func:`headline`).

The rules and their limits are the constants below, each with the
measurement that chose it (``python benchmarks/plausibility_margins.py``
prints every checked figure on every preset and measured benchmark).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..base import numerics
from ..base.dimensions import mass_unit
from ..data.record import Record
from ..errors import IdentificationError, NlidError
from ..estimation.balance import regression_data
from ..estimation.inputpath import acting_record
from ..model.terms import Model
from .tables import record_units

if TYPE_CHECKING:  # pragma: no cover
    from .model import IdentifiedModel
    from .structure import IdentifiedStructure

__all__ = [
    "Flag",
    "ImpliedMass",
    "check",
    "check_structure",
    "headline",
    "implied_mass",
    "mass_cause",
    "mass_hint",
    "trusted",
    "ZETA_MIN",
    "ZETA_MAX",
    "FORCE_RESIDUAL_MAX_PERCENT",
    "SIGN_STANDARD_ERRORS",
    "MASS_RATIO_MAX",
    "MASS_DETERMINED_WITHIN",
]

#: A damping ratio below this at a stable equilibrium is flagged: a passive structure cannot feed energy
#: in. Measured (``python benchmarks/plausibility_margins.py --seeds 3 --methods rfs,nsi-ip,sindy``: 49 fits
#: on the four one-DOF presets at their study noise and on EMPS, Silverbox and Bouc-Wen): the lowest
#: is +1.1 % (Bouc-Wen with its hysteretic term); the mass in g for kg of issue 35 gives -2.3 %.
ZETA_MIN = 0.0
#: A damping ratio above this (critical damping) is flagged: such a record shows no resonance to identify
#: one from. Measured as above: the highest is 14.9 % (paper-experimental); a mass 1000 times too small
#: gives 598 %.
ZETA_MAX = 1.0
#: A force residual above this many percent is flagged: the model explains the force worse than no
#: model (``R = 0``) would. Measured as above: the highest is 33 % (Bouc-Wen with a linear model, no
#: hysteresis); a mass 1000 times too large gives 9e4 %.
FORCE_RESIDUAL_MAX_PERCENT = 100.0
#: A friction or damping law of the velocity alone (:attr:`nlid.model.terms.Term.dissipative`, no factor
#: of ``z`` or ``px(z)``) whose coefficient is negative by more than this many standard errors is flagged
#: (any negative one when the method gives no standard error): it feeds energy in at low velocities.
#: Measured as above: no such coefficient is negative on any healthy record. Position-dependent laws are
#: not judged alone: paper-experimental's true ``v*|px(z)|`` and ``v*|v|*|px(z)|`` are negative
#: corrections to a positive total (identified at up to -121 standard errors).
SIGN_STANDARD_ERRORS = 3.0
#: A given mass more than this factor from the mass the record's force balance implies
#: (:func:`implied_mass`) is flagged. Measured as above: within 0.5 % on the presets and EMPS; 14.5 %
#: on Bouc-Wen with a model that lacks its hysteresis (the missing force leaks into the mass); a unit
#: slip is a factor of 10 or more (1000 for g or mm).
MASS_RATIO_MAX = 2.0
#: The implied mass is used only when its relative standard error is below this: a record whose
#: acceleration is nearly proportional to the displacement (a slow sine) cannot tell mass from stiffness.
#: Measured as above: at most 0.42 % on the healthy records.
MASS_DETERMINED_WITHIN = 0.1


@dataclass(frozen=True)
class Flag:
    """One check an identified model failed.

    Attributes
    ----------
    code
        Which rule: ``"negative-damping"``, ``"overdamped"``, ``"force-residual"``,
        ``"dissipative-sign"`` or ``"mass"``.
    message
        What was found, with the figures.
    cause
        The likely cause and what to check.
    """

    code: str
    message: str
    cause: str

    def __str__(self) -> str:
        return f"{self.message}: {self.cause}"

    def to_dict(self) -> dict[str, str]:
        """``{"code", "message", "cause"}``."""
        return {"code": self.code, "message": self.message, "cause": self.cause}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any] | Flag) -> Flag:
        """Rebuild from :meth:`to_dict`."""
        if isinstance(data, Flag):
            return data
        return cls(str(data.get("code", "")), str(data.get("message", "")), str(data.get("cause", "")))


@dataclass(frozen=True)
class ImpliedMass:
    """The mass the record's own force balance implies: ``f = G theta + m a`` with ``m`` free.

    Attributes
    ----------
    value
        The mass (kg, or the record's unit of force per unit of acceleration).
    standard_error
        Its standard error (:func:`implied_mass` says how).
    """

    value: float
    standard_error: float

    @property
    def determined(self) -> bool:
        """True when the record pins the mass down (:data:`MASS_DETERMINED_WITHIN`)."""
        return (
            numerics.is_finite(self.value)
            and self.value > 0
            and self.standard_error < MASS_DETERMINED_WITHIN * self.value
        )


def implied_mass(record: Record, model: Model, *, cutoff: float | None = None) -> ImpliedMass | None:
    """The mass the force balance of ``record`` implies for the terms of ``model`` (``None``: not estimable).

    The least squares of ``f = G theta + m a`` on the band-limited force balance every identifier and score
    uses (:func:`nlid.estimation.balance.regression_data`): what a mass-estimating identifier finds, computed
    by the core, whatever method made the model. Solved from the normal equations of the RMS-scaled
    columns (one pass over the samples: it runs on every identification); the standard error is the
    independent-error one times the square root of the equation error's correlation length (``fs / fc``
    samples after the low-pass at ``fc``), enough to tell a determined mass from an undetermined one.
    """
    try:
        data = regression_data(record, model, cutoff=cutoff)
    except NlidError:
        return None
    X = np.column_stack([data.G, data.a])
    n, p = X.shape
    scale = np.sqrt(np.einsum("ij,ij->j", X, X) / max(n, 1))
    if n <= p or not np.all(np.isfinite(scale)) or np.any(scale == 0):
        return None
    Xs = X / scale
    gram, rhs = Xs.T @ Xs, Xs.T @ data.f
    try:
        inverse = np.linalg.inv(gram)
    except np.linalg.LinAlgError:
        return None
    theta = inverse @ rhs
    resid = data.f - Xs @ theta
    corr = 1.0 if data.filtered_at is None else max(1.0, record.fs / data.filtered_at)
    variance = float(resid @ resid) / (n - p) * inverse[-1, -1] * corr
    value, se = float(theta[-1] / scale[-1]), math.sqrt(max(variance, 0.0)) / float(scale[-1])
    if not (numerics.is_finite(value) and numerics.is_finite(se)):
        return None
    return ImpliedMass(value, se)


def mass_cause(given: float, implied: float, unit: str = "kg") -> str:
    """The likely unit slip behind a given mass ``given`` where the data imply ``implied`` (both in ``unit``)."""
    return f"the data suggest m ≈ {implied:.2g} {unit}: {mass_hint(given, implied, unit)}"


def mass_hint(given: float, implied: float, unit: str = "kg") -> str:
    """What to check when a given mass ``given`` is far from the ``implied`` one (both in ``unit``): the question
    of :func:`mass_cause`."""
    if not implied > 0:
        return "is the force's sign reversed against z?"
    if unit != "kg":  # a record in other units (volts): its mass is force per unit of acceleration
        return f"is mass= in {unit}, the force per unit of acceleration?"
    decade = round(math.log10(given / implied) / 3) * 3
    if decade >= 3:  # a mass in g, a displacement in mm read as m, or a force in kN read as N
        return "is mass= in kg (not g)? is z in m (units='z=mm' when it is in mm)? is f in N (units='f=kN')?"
    if decade <= -3:  # a mass in t, or a force in mN read as N
        return "is mass= in kg (not t)? is f in N (units='f=mN' when it is in mN)? is z in m?"
    return (
        "is mass= the moving mass, in kg? is z in m and f in N (units= when they are not)? is fs right (a "
        f"sampling rate {math.sqrt(given / implied):.3g} times the true one gives this: the implied mass scales "
        "with its square)?"
    )


def check(fit: IdentifiedModel, record: Record | None = None, *, cutoff: float | None = None) -> tuple[Flag, ...]:
    """The rules ``fit`` breaks, most telling first (empty when it passes them all).

    Parameters
    ----------
    fit
        The identified model.
    record
        Its estimation record: needed for the mass rule (the force balance's own mass); without it only the
        model's own figures are checked.
    cutoff
        The equation band (Hz) of the force balance, as identified.
    """
    flags: list[Flag] = []
    force, length = record_units(fit)  # the record's units: SI, or volts for an electrical analogue
    if record is not None:
        force, length = str(record.units.get("f", force)), str(record.units.get("z", length))
    mass = mass_unit(force, length)
    if record is not None and fit.mass is not None and not fit.mass_estimated:
        implied = implied_mass(acting_record(fit, record), fit.model, cutoff=cutoff)
        if implied is not None and _negative(implied.value, implied.standard_error):
            flags.append(
                _reversed_flag(f"the record's force balance implies a negative mass ({implied.value:.3g} {mass})")
            )
        elif implied is not None and implied.determined:
            ratio = fit.mass / implied.value
            if ratio > MASS_RATIO_MAX or ratio < 1 / MASS_RATIO_MAX:
                flags.append(
                    Flag(
                        "mass",
                        f"the given mass {fit.mass:.4g} {mass} is {ratio:.3g} times the {implied.value:.3g} {mass} "
                        "the record's force balance implies",
                        mass_cause(fit.mass, implied.value, mass),
                    )
                )
    if fit.mass is not None and fit.mass_estimated and fit.mass < 0:
        flags.append(_reversed_flag(f"the estimated mass is negative ({fit.mass:.3g} {mass})"))
    unit_slip = "a wrong mass or a unit slip (mass in g, z in mm)"
    flags += _zeta_flags([(f"at z* = {m.equilibrium:.4g} {length}", m.zeta) for m in fit.modal], unit_slip)
    residual = None if fit.scores is None else fit.scores.force_residual_percent
    if residual is not None and numerics.is_finite(residual) and residual > FORCE_RESIDUAL_MAX_PERCENT:
        flags.append(_residual_flag(f"{residual:.3g} %", unit_slip))
    se = dict(fit.standard_errors or {})
    wrong = _wrong_signs(
        (name, term, fit.coefficients[name], se.get(name), term.coefficient_unit_in(force, length))
        for name, term in zip(fit.terms, fit.model.terms, strict=True)
    )
    if wrong:
        flags.append(
            _sign_flag(
                wrong,
                "check the sign of f against z (a force pushing z up must be positive), the mass, or drop the term",
            )
        )
    return tuple(flags)


def _negative(value: float, standard_error: float) -> bool:
    """A mass the record determines (:data:`MASS_DETERMINED_WITHIN`) and negative."""
    return numerics.is_finite(value) and value < 0 and standard_error < MASS_DETERMINED_WITHIN * -value


def _reversed_flag(found: str) -> Flag:
    """A negative mass: the force pushes against the motion it causes, so its sign is likely reversed."""
    return Flag(
        "mass",
        found,
        "the force's sign is likely reversed against z (a force pushing z up must be positive), or the force and "
        "displacement channels do not belong together",
    )


def _zeta_flags(points: Sequence[tuple[str, float]], unit_slip: str) -> list[Flag]:
    """The damping-ratio rules on ``(where, zeta)`` pairs."""
    flags = []
    low = [(where, z) for where, z in points if numerics.is_finite(z) and z < ZETA_MIN]
    if low:
        shown = ", ".join(f"{100 * z:.3g} % {where}" for where, z in low)
        flags.append(
            Flag("negative-damping", f"negative damping ratio ({shown})", f"a passive structure cannot: {unit_slip}")
        )
    high = [(where, z) for where, z in points if numerics.is_finite(z) and z > ZETA_MAX]
    if high:
        shown = ", ".join(f"{100 * z:.3g} % {where}" for where, z in high)
        flags.append(Flag("overdamped", f"damping ratio above {100 * ZETA_MAX:g} % ({shown})", f"likely {unit_slip}"))
    return flags


def _residual_flag(shown: str, unit_slip: str) -> Flag:
    """The flag of a force residual above :data:`FORCE_RESIDUAL_MAX_PERCENT` (``shown``: the residual(s) in words)."""
    return Flag(
        "force-residual",
        f"force residual {shown} (the model explains the force worse than no model)",
        f"likely {unit_slip}, or channels that do not belong together",
    )


def _wrong_signs(entries: Iterable[tuple[str, Any, float, float | None, str]]) -> list[str]:
    """``"name value unit"`` of each friction or damping law of the velocity alone whose coefficient is negative by
    more than ``SIGN_STANDARD_ERRORS`` standard errors (any negative one without a standard error).

    ``entries``: ``(name, term, coefficient, standard error or None, unit)``.
    """
    wrong = []
    for name, term, value, error, unit in entries:
        if term.dissipative and term.z == (0, 0) and term.px == (0, 0) and value < 0:
            if error is None or not numerics.is_finite(error) or -value > SIGN_STANDARD_ERRORS * error:
                wrong.append(f"{name} {value:.3g} {unit}")
    return wrong


def _sign_flag(wrong: Sequence[str], cause: str) -> Flag:
    """The flag of the friction or damping laws :func:`_wrong_signs` found."""
    return Flag(
        "dissipative-sign",
        f"a friction or damping law with a negative coefficient ({', '.join(wrong)}): it feeds energy in",
        cause,
    )


def check_structure(result: IdentifiedStructure) -> tuple[Flag, ...]:
    """The rules an identified structure breaks (the same rules and limits as :func:`check`, per mode and DOF).

    Checked: the damping ratio of every linearised mode at each stable equilibrium and of the underlying
    linear system (``ZETA_MIN``, ``ZETA_MAX``), the force residual of every DOF
    (``FORCE_RESIDUAL_MAX_PERCENT``), and the sign of every element that is a friction or damping law of
    its connection's velocity alone (``SIGN_STANDARD_ERRORS``). The mass rule is not applied to a mass
    matrix: a structure's force balance does not determine one mass per DOF as well as one DOF's does.
    """
    unit_slip = "a wrong mass matrix or a unit slip (mass in g, z in mm)"
    points = []
    for modes in result.modes:
        at = "(" + ", ".join(f"{x:.4g}" for x in modes.equilibrium) + ")"
        points += [(f"mode {k + 1} at z* = {at} m", float(z)) for k, z in enumerate(modes.zeta)]
    if result.linear_modes is not None:
        points += [(f"underlying linear mode {k + 1}", float(z)) for k, z in enumerate(result.linear_modes.zeta)]
    flags = _zeta_flags(points, unit_slip)
    residuals = list(result.force_residual_percent or ())
    over = [(i + 1, r) for i, r in enumerate(residuals) if numerics.is_finite(r) and r > FORCE_RESIDUAL_MAX_PERCENT]
    if over:
        flags.append(_residual_flag(", ".join(f"{r:.3g} % on z{i}" for i, r in over), unit_slip))
    se = dict(result.standard_errors or {})
    wrong = _wrong_signs(
        (e.name, e.term, result.coefficients[e.name], se.get(e.name), e.coefficient_unit) for e in result.elements
    )
    if wrong:
        flags.append(
            _sign_flag(
                wrong, "check the sign of each force against its displacement, the mass matrix, or drop the element"
            )
        )
    return tuple(flags)


def trusted(draft: Any, method: str, found: Sequence[str], flags: Callable[[Any], tuple[Flag, ...]]) -> Any:
    """A fit the core drafted (one DOF or a structure), checked: refused when a reported figure is not finite
    (its ``problems()``), the numerical warnings ``found`` while identifying added as a warning, and its ``flags``.

    Raises
    ------
    IdentificationError
        A reported figure that is not finite, with the numerical warnings found on the way.
    """
    problems = draft.problems()
    if problems:
        why = f" (numpy: {numerics.describe_warnings(found)}){numerics.overflow_hint(found)}" if found else ""
        raise IdentificationError(f"the identification by {method!r} cannot be trusted: {'; '.join(problems)}{why}")
    if found:
        note = f"numerical warnings while identifying (the figures are finite): {numerics.describe_warnings(found)}"
        draft = dataclasses.replace(draft, warnings=(*draft.warnings, note))
    return dataclasses.replace(draft, flags=flags(draft))


def headline(flags: Sequence[Flag]) -> str:
    """One line: the most telling flag with its likely cause, then what else was found."""
    if not flags:
        return ""
    first, rest = flags[0], flags[1:]
    also = f" (also: {'; '.join(f.message for f in rest)})" if rest else ""
    return f"the result cannot be trusted: {first.message}; {first.cause}{also}"
