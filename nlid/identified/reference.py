"""A fit against a reference: the :class:`Reference` (truth, published values, another fit) and :func:`compare`.

Every layer that scores an identified model against known values goes
through here: :func:`nlid.compare` (a tidy frame,
:meth:`Comparison.to_frame`), the study runner (typed values,
:meth:`Comparison.coefficients` and :meth:`Comparison.equilibria`, which
:mod:`nlid.study.row` flattens into its columns) and the posterior's coverage
(:func:`nlid.bayes.posterior_metrics`, through :meth:`Reference.from_mapping`).

A :class:`Reference` is built once, whatever it came from:

* :meth:`Reference.from_truth`: a simulation's truth, with the stable
  equilibria and modal parameters of the true model (Eq. 8, 22);
* :meth:`Reference.from_meta`: what a record carries in
  ``meta["reference"]`` (simulated records: their truth; measured
  benchmarks: published values); ``meta["truth"]``, the name simulated
  records used before, is read too;
* :meth:`Reference.from_fit`: another identified model;
* :meth:`Reference.from_mapping`: ``{"coefficients": ..., "mass": ...,
  "equilibria": [...], "modal": [...]}`` or a bare ``{term: value}``;
* :meth:`Reference.of`: whichever of these fits what was given.

The two views of a :class:`Comparison` pair equilibria and modes
differently, on purpose, and each keeps the numbers its output always had:

* :meth:`Comparison.to_frame` walks the **identified** stable equilibria
  (the rows a user reads for one fit) and labels each by the reference
  equilibrium it is nearest to; the mode reported is the one at that
  equilibrium (else the nearest); a reference without equilibria gets them
  solved from its coefficients over the fit's displacement range.
* :meth:`Comparison.equilibria` walks the **reference** stable equilibria (the
  fixed columns ``eq:sK`` a study aggregates over repetitions) and matches
  the modes to them on their own, by position: a method may linearise at its
  own reference point (``nsi-shift``: each well's shifted zero) rather than
  at an equilibrium of the combined model. Nothing is solved: a study gives a
  simulated reference its equilibria when it builds it
  (:meth:`Reference.from_truth`).
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from ..base.dimensions import mass_unit
from ..base.frozen import FrozenDict
from ..data.record import Record
from ..errors import InputError, NlidError, brief
from ..model import physics
from ..model.terms import Model
from .compared import CoefficientComparison, EquilibriumComparison, WellComparison, equilibrium_label
from .model import IdentifiedModel
from .tables import record_units

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

__all__ = [
    "Reference",
    "Comparison",
    "compare",
    "true_model",
    "match_equilibria",
    "frame_row",
    "FRAME_COLUMNS",
    "META_KEY",
    "TRUE_MODEL",
]

#: The key of ``Record.meta`` that holds a record's reference values.
META_KEY = "reference"
#: The ``method`` of the model :func:`true_model` builds (the system that generated the data).
TRUE_MODEL = "true model"
#: Earlier name of :data:`META_KEY` (simulated records before issue 22), still read.
META_ALIASES = ("truth",)
#: Columns of :meth:`Comparison.to_frame` (and of :func:`nlid.compare`).
FRAME_COLUMNS = ["method", "quantity", "name", "value", "std_error", "unit", "reference", "error_pct", "note"]
#: Keys of a structured reference mapping (anything else is a bare ``{term: value}``).
_STRUCTURE = ("coefficients", "mass", "equilibria", "modal", "modes", "terms", "px_roots")

NAN = float("nan")


def _finite(value: Any, what: str, unit: str = "") -> float:
    """``value`` as a finite float; a NaN, an infinity, a bool, text or a list is refused naming ``what``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise InputError(f"reference {what} must be a number{unit}, got {brief(value, 60)}")
    try:
        out = float(value)
    except OverflowError:
        out = math.inf
    if not math.isfinite(out):
        raise InputError(f"reference {what} must be a finite number{unit}, got {brief(value, 60)}")
    return out


def _canonical(coefficients: Mapping[str, Any]) -> dict[str, float]:
    """Coefficients by canonical term name; names that are not terms are left out."""
    out: dict[str, float] = {}
    for k, v in coefficients.items():
        try:
            name = Model.from_spec([k], defaults=False).names[0]
        except NlidError:
            continue
        out[name] = _finite(v, f"coefficient {brief(str(k), 40)}")
    return out


def _floats(values: Any, what: str) -> tuple[float, ...] | None:
    if values is None:
        return None
    values = list(values) if isinstance(values, Iterable) and not isinstance(values, (str, Mapping)) else values
    if not isinstance(values, list) or not all(
        isinstance(x, numbers.Real) and not isinstance(x, (bool, np.bool_)) for x in values
    ):
        raise InputError(f"reference {what} must be a list of numbers, got {brief(values, 60)}")
    out = []
    for x in values:
        try:
            out.append(float(x))
        except OverflowError:
            out.append(math.inf)
        if not math.isfinite(out[-1]):
            raise InputError(f"reference {what} must be a list of finite numbers, got {brief(x, 60)}")
    return tuple(out)


@dataclass(frozen=True)
class Reference:
    """Known values an identified model is compared with; any of them may be unknown (``None``).

    Attributes
    ----------
    coefficients
        ``{canonical term: value}`` (names that are not terms are dropped).
    mass
        Mass (kg).
    equilibria
        Stable equilibria (m).
    modes
        Modal parameters at each of them: mappings with ``fn_hz`` and
        ``zeta`` (and whatever else the source gave, e.g. a fit's
        ``equilibrium``), in the order of :attr:`equilibria`.
    terms
        The true model's terms (simulations), for drawing the true ``K(z)``.
    px_roots
        Its ``px(z)`` roots.
    """

    coefficients: Mapping[str, float] | None = None
    mass: float | None = None
    equilibria: tuple[float, ...] | None = None
    modes: tuple[Mapping[str, Any], ...] | None = None
    terms: tuple[str, ...] | None = None
    px_roots: tuple[float, ...] | None = None

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        if self.coefficients is not None:
            if not isinstance(self.coefficients, Mapping):
                raise InputError(
                    f"reference coefficients must map term names to values, got {type(self.coefficients).__name__}"
                )
            set_(self, "coefficients", FrozenDict(_canonical(self.coefficients)))
        if self.mass is not None:
            set_(self, "mass", _finite(self.mass, "mass", " of kg"))
        set_(self, "equilibria", _floats(self.equilibria, "equilibria"))
        if self.modes is not None:
            if (
                isinstance(self.modes, (str, Mapping))
                or not isinstance(self.modes, Iterable)
                or not all(isinstance(m, Mapping) for m in self.modes)
            ):
                raise InputError("reference modes must be a list of {fn_hz, zeta} mappings")
            for m in self.modes:  # numbers (NaN: not known), never text or lists
                for key in ("fn_hz", "zeta"):
                    value = m.get(key)
                    if value is not None and not (isinstance(value, numbers.Real) and not isinstance(value, bool)):
                        raise InputError(f"reference modes' {key} must be a number, got {brief(value, 60)}")
            set_(self, "modes", tuple(FrozenDict(m) for m in self.modes))
        if self.terms is not None:
            if isinstance(self.terms, str) or not all(isinstance(t, str) for t in self.terms):
                raise InputError(f"reference terms must be a list of terms, got {brief(self.terms, 60)}")
            set_(self, "terms", tuple(self.terms))
        set_(self, "px_roots", _floats(self.px_roots, "px_roots"))

    # ------------------------------------------------------------------ constructors
    @classmethod
    def from_mapping(cls, mapping: Mapping[str, Any]) -> Reference:
        """From ``{"coefficients", "mass", "equilibria", "modal" (or "modes"), "terms", "px_roots"}`` or ``{term: x}``.

        Other keys (a preset's ``g``, a benchmark's published scores) are ignored.
        """
        if not isinstance(mapping, Mapping):
            raise InputError(f"a reference mapping must be a dict, got {type(mapping).__name__}")
        if not set(_STRUCTURE) & set(mapping):
            return cls(coefficients=mapping)  # a bare {term: value}
        return cls(**_fields(mapping))

    @classmethod
    def from_meta(cls, meta: Mapping[str, Any]) -> Reference:
        """What a record's metadata holds: ``meta["reference"]`` (or ``meta["truth"]``, its earlier name).

        Nothing is solved: see :meth:`from_truth` for a simulation's equilibria and modes.
        """
        for key in (META_KEY, *META_ALIASES):
            value = meta.get(key)
            if isinstance(value, Mapping):
                return cls(**_fields(value))
        return cls()

    @classmethod
    def from_truth(
        cls,
        truth: Mapping[str, Any] | Reference,
        *,
        model: Model | None = None,
        z_range: Sequence[float] | None = None,
    ) -> Reference:
        """A simulation's truth with the stable equilibria and modal parameters of the true model.

        Parameters
        ----------
        truth
            ``{"coefficients", "mass", "px_roots"}`` (a preset's
            :meth:`~nlid.simulation.presets.Preset.truth`, a simulated record's
            ``meta["reference"]``) or a :class:`Reference` with them.
        model
            The true model (default: built from the coefficients' terms and ``px_roots``).
        z_range
            ``(z_min, z_max)`` of the record: equilibria far outside it are dropped
            (:func:`nlid.model.physics.equilibria`).
        """
        ref = truth if isinstance(truth, Reference) else cls.from_mapping(truth)
        if not ref.coefficients or ref.mass is None:
            raise InputError("a simulation's truth needs its coefficients and mass")
        coefficients = dict(ref.coefficients)
        if model is None:
            model = Model.from_spec(list(coefficients), defaults=False, px_roots=ref.px_roots)
        eq = physics.equilibria(model, coefficients, z_range)
        modal = physics.modal(model, coefficients, ref.mass, z_range=z_range)
        return replace(
            ref,
            equilibria=tuple(eq.stable),
            modes=tuple({"fn_hz": m.fn_hz, "zeta": m.zeta} for m in modal),
            terms=model.names,
        )

    @classmethod
    def from_fit(cls, fit: IdentifiedModel) -> Reference:
        """Another identified model's coefficients, mass, stable equilibria and modes."""
        eq = fit.equilibria
        return cls(
            coefficients=dict(fit.coefficients),
            mass=fit.mass,
            equilibria=None if eq is None else tuple(eq.stable),
            modes=tuple(m.to_dict() for m in fit.modal),
            terms=fit.terms,
            px_roots=fit.px_roots,
        )

    @classmethod
    def of(cls, record: Record | None, reference: Any = None) -> Reference:
        """The reference ``reference`` names, or, when it is ``None``, the one ``record`` carries.

        Parameters
        ----------
        record
            Its ``meta["reference"]`` is used when ``reference`` is ``None``.
        reference
            A :class:`Reference`, an :class:`~nlid.identified.model.IdentifiedModel`, a mapping
            (:meth:`from_mapping`) or ``None``.

        Raises
        ------
        InputError
            For anything else.
        """
        if reference is None:
            return cls() if record is None else cls.from_meta(record.meta)
        if isinstance(reference, Reference):
            return reference
        if isinstance(reference, IdentifiedModel):
            return cls.from_fit(reference)
        if isinstance(reference, Mapping):
            return cls.from_mapping(reference)
        raise InputError(
            f"reference must be a dict, a Reference, an IdentifiedModel or None, got {type(reference).__name__}"
        )

    # ------------------------------------------------------------------ views
    @property
    def empty(self) -> bool:
        """True when nothing is known."""
        return all(
            getattr(self, f) is None for f in ("coefficients", "mass", "equilibria", "modes", "terms", "px_roots")
        )

    def updated(self, values: Mapping[str, Any]) -> Reference:
        """A copy with the entries ``values`` gives replaced (e.g. a study's ``[datasets.reference]`` table)."""
        return replace(self, **_fields(values))

    def model(self) -> Model | None:
        """The reference's model: its :attr:`terms`, else its coefficients' terms (``None`` when neither is known)."""
        names = self.terms or (list(self.coefficients) if self.coefficients else None)
        return None if not names else Model.from_spec(list(names), defaults=False, px_roots=self.px_roots)

    def true_model(self, source: str = "the reference") -> IdentifiedModel:
        """The reference as a model the scores read like any fit (``fit.score(record, rule=...)``).

        For a reference that is the system which generated the data (a simulation's truth, a simulated
        benchmark's published system): scored under a rule, it gives the figure a perfect model reaches
        with nlid's scorer (:func:`true_model`).

        Raises
        ------
        InputError
            No coefficients or no mass.
        """
        model = self.model()
        if model is None or not self.coefficients or self.mass is None:
            raise InputError(f"{source} needs its coefficients and mass to be run as a model")
        return IdentifiedModel(model, dict(self.coefficients), self.mass, TRUE_MODEL)

    def solved(self, z_range: Sequence[float] | None) -> Reference:
        """With stable equilibria and modes solved from the coefficients when the reference gives no equilibria.

        The equilibria are those of ``K(z)`` over ``z_range`` (a fit's
        displacement range); the modes need the mass. A model the physics
        cannot solve leaves both empty.
        """
        if self.equilibria or not self.coefficients or z_range is None:
            return self
        coefficients = dict(self.coefficients)
        modes = list(self.modes or [])
        try:
            true_model = Model.from_spec(list(coefficients), defaults=False, px_roots=self.px_roots)
            eq = list(physics.equilibria(true_model, coefficients, z_range).stable)
            if self.mass:
                modes = [m.to_dict() for m in physics.modal(true_model, coefficients, float(self.mass), eq)]
        except NlidError:
            eq, modes = [], []
        return replace(self, equilibria=tuple(eq), modes=tuple(modes))

    def to_dict(self) -> dict[str, Any]:
        """Plain data: ``{"coefficients", "mass", "equilibria", "modal", "terms", "px_roots"}`` (``None`` unknown)."""
        return {
            "coefficients": None if self.coefficients is None else dict(self.coefficients),
            "mass": self.mass,
            "equilibria": None if self.equilibria is None else list(self.equilibria),
            "modal": None if self.modes is None else [dict(m) for m in self.modes],
            "terms": None if self.terms is None else list(self.terms),
            "px_roots": None if self.px_roots is None else list(self.px_roots),
        }


def _fields(mapping: Mapping[str, Any]) -> dict[str, Any]:
    """The :class:`Reference` fields a structured mapping gives (``modal`` is the plain-data name of ``modes``)."""
    out: dict[str, Any] = {}
    for key in ("coefficients", "mass", "equilibria", "terms", "px_roots"):
        if key in mapping:
            out[key] = mapping[key]
    for key in ("modal", "modes"):
        if key in mapping:
            out["modes"] = mapping[key]
    return out


def match_equilibria(expected: Sequence[float], found: Sequence[float]) -> dict[int, int]:
    """Pair reference and identified equilibria, nearest first, each used once.

    Returns
    -------
    dict
        ``{index in expected: index in found}``; unmatched expected ones are absent.
    """
    pairs = sorted((abs(e - f), i, j) for i, e in enumerate(expected) for j, f in enumerate(found))
    used_i: set[int] = set()
    used_j: set[int] = set()
    out = {}
    for _, i, j in pairs:
        if i in used_i or j in used_j:
            continue
        out[i] = j
        used_i.add(i)
        used_j.add(j)
    return out


def _pct(value: float, ref: float) -> float:
    """Signed relative error in % (the study row's rule: NaN for a zero or missing reference)."""
    return 100.0 * (value - ref) / abs(ref) if ref else NAN


def _error_pct(value: float, ref: float | None) -> float:
    """Signed relative error in % (the frame's rule: NaN also for a non-finite value)."""
    if ref is None or not ref or not math.isfinite(value):
        return NAN
    return 100.0 * (value - ref) / abs(ref)


def frame_row(
    quantity: str, name: str, value: float, unit: str, ref: float | None = None, std: float = NAN
) -> dict[str, Any]:
    """One tidy row of :data:`FRAME_COLUMNS` without ``method`` and ``note``, one DOF's or a structure's.

    ``error_pct`` is the signed error in % of ``|ref|``; NaN without a reference, for a zero one or for a
    value that is not finite.
    """
    return {
        "quantity": quantity,
        "name": name,
        "value": float(value),
        "std_error": float(std),
        "unit": unit,
        "reference": NAN if ref is None else float(ref),
        "error_pct": _error_pct(float(value), ref),
    }


@dataclass(frozen=True)
class Comparison:
    """An identified model against a :class:`Reference`, with an optional held-out record.

    Two views (the module documentation says why they pair modes differently): typed values for a study row
    (:meth:`coefficients`, :meth:`equilibria`; :mod:`nlid.study` flattens them into its columns) and
    :meth:`to_frame` for :func:`nlid.compare`.
    """

    fit: IdentifiedModel
    reference: Reference
    holdout: Record | None = None
    rule: Any = None  # the held-out free run's transient rule (nlid.scoring.rule_from_spec); None: the record's

    # ------------------------------------------------------------------ the study's values
    def coefficients(self) -> CoefficientComparison:
        """The coefficients and the mass against the reference (:class:`CoefficientComparison`)."""
        result, ref = self.fit, self.reference
        known = ref.coefficients or {}
        values = {name: float(value) for name, value in result.coefficients.items()}
        errors = {name: _pct(value, known[name]) for name, value in result.coefficients.items() if known.get(name)}
        mass = NAN if result.mass is None else float(result.mass)
        mass_error = None
        if result.mass_estimated and result.mass is not None and ref.mass:
            mass_error = _pct(result.mass, ref.mass)
        return CoefficientComparison(values, errors, mass, mass_error)

    def equilibria(self) -> EquilibriumComparison:
        """The stable equilibria, and the modes matched to each reference one (:class:`EquilibriumComparison`)."""
        result = self.fit
        found = sorted(result.equilibria.stable) if result.equilibria is not None else []
        modal = tuple(result.modal)
        expected = self.reference.equilibria
        if not expected:
            return EquilibriumComparison(len(found), (), modal)
        ref_modes = self.reference.modes or ()
        match = match_equilibria(list(expected), found)
        # modes are matched on their own (see the module documentation)
        modal_match = match_equilibria(list(expected), [m.equilibrium for m in modal])
        wells = []
        for i, z_ref in enumerate(expected):
            if i not in match:
                wells.append(WellComparison())
                continue
            z = found[match[i]]
            err = 100.0 * abs(z - z_ref) / abs(z_ref) if z_ref else NAN
            m = modal[modal_match[i]] if i in modal_match else None
            fn_error = zeta_error = None
            if m is not None and i < len(ref_modes):
                fn_error, zeta_error = _pct(m.fn_hz, ref_modes[i]["fn_hz"]), _pct(m.zeta, ref_modes[i]["zeta"])
            wells.append(WellComparison(z, err, m, fn_error, zeta_error))
        return EquilibriumComparison(len(found), tuple(wells), modal)

    # ------------------------------------------------------------------ the tidy frame
    def records(self) -> list[dict[str, Any]]:
        """The tidy rows of :meth:`to_frame`, without ``note``."""
        fit = self.fit
        ref_coeffs = dict(self.reference.coefficients or {})
        se = fit.standard_errors or {}
        rows: list[dict[str, Any]] = []

        def add(quantity: str, name: str, value: float, unit: str, ref: float | None = None, std: float = NAN):
            rows.append({"method": fit.method, **frame_row(quantity, name, value, unit, ref, std)})

        force, length = record_units(fit)  # every unit derived from the record's (SI, or volts for an analogue)
        for name, term in zip(fit.terms, fit.model.terms, strict=True):
            value, unit = fit.coefficients[name], term.coefficient_unit_in(force, length)
            add("coefficient", name, value, unit, ref_coeffs.get(name), se.get(name, NAN))
        if fit.mass is not None:
            ref_mass = self.reference.mass if fit.mass_estimated else None
            add("mass", "mass", fit.mass, mass_unit(force, length), ref_mass, fit.mass_standard_error or NAN)
        # the identified stable equilibria, each labelled by the reference equilibrium it is nearest to
        solved = self.reference.solved(fit.z_range)
        ref_eq = list(solved.equilibria or [])
        ref_modes = list(solved.modes or [])
        stable = sorted(fit.equilibria.stable) if fit.equilibria is not None else []
        match = match_equilibria(ref_eq, stable) if ref_eq else {}
        inverse = {j: i for i, j in match.items()}
        modal_by_eq = {m.equilibrium: m for m in fit.modal}
        for j, z in enumerate(stable):
            i = inverse.get(j)
            label = equilibrium_label(j if i is None else i)
            add("equilibrium", label, z, length, ref_eq[i] if i is not None else None)
            m = modal_by_eq.get(z) or min(fit.modal, key=lambda mm: abs(mm.equilibrium - z), default=None)
            if m is None:
                continue
            ref_m = ref_modes[i] if i is not None and i < len(ref_modes) else {}
            add("fn_hz", label, m.fn_hz, "Hz", ref_m.get("fn_hz"))
            add("zeta", label, m.zeta, "1", ref_m.get("zeta"))
        if fit.scores is not None:
            add("eps_percent", "estimation", fit.scores.eps_percent, "%")
            add("force_residual_percent", "estimation", fit.scores.force_residual_percent, "%")
        if self.holdout is not None and fit.mass is not None:
            held = fit.score(self.holdout, rule=self.rule)
            add("eps_percent", "holdout", held.eps_percent, "%")
            add("force_residual_percent", "holdout", held.force_residual_percent, "%")
            add("freerun_rmse", "holdout", held.freerun_rmse, self.holdout.units.get("z", "m"))
            if held.freerun_rule:  # every free-run figure states its rule
                rows[-1]["note"] = f"free run: {held.freerun_rule}"
        if fit.seconds is not None:
            add("seconds", "identification", fit.seconds, "s")
        return rows

    def to_frame(self) -> pd.DataFrame:
        """One tidy row per quantity (the columns of :data:`FRAME_COLUMNS`), as :func:`nlid.compare` gives them."""
        import pandas as pd

        return pd.DataFrame([{"note": "", **r} for r in self.records()], columns=FRAME_COLUMNS)


def true_model(record: Record, truth: Reference | Mapping[str, Any] | None = None) -> IdentifiedModel | None:
    """The system that generated a record, as a model (``method`` :data:`TRUE_MODEL`), when it is known.

    Parameters
    ----------
    record
        A simulated record carries its truth (``meta["reference"]`` of a record whose ``meta["preset"]`` names
        the preset that made it); a measured record's reference holds published estimates, not the truth.
    truth
        The true system when the caller knows it (a simulated benchmark's declared system:
        :attr:`nlid.benchmarking.Protocol.truth`); it takes precedence over the record's.

    Returns
    -------
    IdentifiedModel or None
        ``None`` when the truth is not known. Score it as any fit: ``true_model(record).score(record,
        rule=...)`` is the figure a perfect model reaches under that rule with nlid's scorer.
    """
    if truth is not None:
        ref = truth if isinstance(truth, Reference) else Reference.from_mapping(truth)
        return ref.true_model("the declared truth")
    if not record.meta.get("preset"):
        return None
    ref = Reference.from_meta(record.meta)
    if not ref.coefficients or ref.mass is None:
        return None
    return ref.true_model(f"the truth of {record.meta.get('source') or 'the record'}")


def compare(
    fit: IdentifiedModel,
    reference: Reference | Mapping[str, Any] | IdentifiedModel | None,
    holdout: Record | None = None,
    rule: Any = None,
) -> Comparison:
    """An identified model against a reference (:meth:`Reference.of`; ``None``: nothing known).

    ``rule`` is the held-out free run's transient rule (:func:`nlid.scoring.rule_from_spec`; ``None``: the
    held-out record's own).

    Returns
    -------
    Comparison
        ``.coefficients()`` and ``.equilibria()`` (typed values: a study row's) and ``.to_frame()`` (tidy rows).
    """
    if not isinstance(fit, IdentifiedModel):
        raise InputError(f"compare needs an IdentifiedModel, got {type(fit).__name__}")
    return Comparison(fit, Reference.of(None, reference), holdout, rule)
