"""Compliance checks for identifier plugins, one named check per rule of the contract.

Third-party authors run them from their own tests, all at once::

    from nlid.testing import check_identifier
    from my_plugin import MyIdentifier

    def test_contract():
        check_identifier(MyIdentifier)

or one pytest case per check (as scikit-learn's ``parametrize_with_checks``)::

    from nlid.testing import parametrize_with_checks

    @parametrize_with_checks([MyIdentifier])
    def test_contract(check):
        check()

Each check calls the plugin *directly* (``cls(**options).identify(record,
model, mass=...)``), not through :func:`nlid.identify`, so the core's own
checks and repairs cannot hide a broken rule. The records are short,
noise-free simulations of the ``paper-numerical`` preset (Sec. 3 of the
paper), built once per process.

The checks (:data:`CHECKS`):

``check_attributes``
    ``name``, a one-line ``summary``, ``options`` (a tuple of
    :class:`~nlid.contract.identifier.Option`), ``needs_mass`` (bool), ``identify``;
    and, when set, what the core tells users about the method:
    ``preference`` and ``advice_order`` (int or None), ``advice`` and
    ``docs`` (one line), ``refines`` (bool; a refining method declares a
    string option ``init``, the method it starts from).
``check_options_documented``
    Every option has a help text, a unique name and a default that validates.
``check_unknown_option_rejected``
    The constructor refuses an unknown option with :class:`~nlid.errors.OptionError`.
``check_bad_option_value_rejected``
    ... and a value of the wrong type or outside the allowed choices.
``check_known_mass``
    With the mass given: an :class:`~nlid.contract.estimate.Estimate` that passes the
    core's own check (:func:`nlid.contract.estimate.check_estimate`: one finite real
    coefficient per term in any order, no competing mass, standard errors,
    modal parameters and warnings of the right kind...).
``check_estimated_mass``
    Without the mass: a positive finite estimate, or
    :class:`~nlid.errors.InputError` when ``needs_mass`` is set.
``check_px_model``
    A model with a position-dependent friction term ``sign(v)*|px(z)|``
    (Eq. 10-11, 24) with its roots set is identified.
``check_deterministic``
    Two runs give the same coefficients.
``check_diagnostics_jsonable``
    ``diagnostics`` (and ``warnings``) serialise to JSON.
``check_bad_record``
    A record too short to identify anything raises an nlid error
    (:class:`~nlid.errors.InputError`, :class:`~nlid.errors.DataError` or
    :class:`~nlid.errors.IdentificationError`), not a bare Python exception.
``check_core_round_trip``
    Through :func:`nlid.identify`: the :class:`~nlid.identified.model.IdentifiedModel`
    round-trips through JSON.
``check_accuracy`` (only with ``accuracy=``)
    Every coefficient within that relative error of the truth on exact data.
"""

from __future__ import annotations

import functools
import json
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

from .base.jsonable import to_jsonable
from .contract.estimate import Estimate, check_estimate
from .contract.identifier import Identifier, Option
from .data.record import Record
from .errors import IdentificationError, InputError, NlidError, OptionError, PluginError, describe_exception
from .model.terms import Model

__all__ = [
    "CHECKS",
    "Check",
    "identifier_checks",
    "check_identifier",
    "parametrize_with_checks",
    "contract_record",
]


@functools.lru_cache(maxsize=4)
def contract_record(duration: float = 10.0, seed: int = 0, channels: tuple[str, ...] = ("z", "v", "a")) -> Record:
    """A short noise-free ``paper-numerical`` record with exact channels (cached)."""
    from .simulation.presets import get_preset

    record = get_preset("paper-numerical").with_overrides(duration=duration).simulate(seed, channels=channels)
    assert isinstance(record, Record)  # a one-DOF preset
    return record


@dataclass(frozen=True)
class _Setup:
    cls: type[Identifier]
    options: dict[str, Any]
    terms: str
    accuracy: float | None
    record: Record | None

    def instance(self) -> Any:
        return self.cls(**self.options)

    def data(self) -> Record:
        return self.record if self.record is not None else contract_record()

    def model(self) -> Model:
        return Model.from_spec(self.terms)

    def mass(self) -> float:
        mass = self.data().mass
        if mass is None:
            raise AssertionError("the check record has no mass in its metadata")
        return float(mass)

    def run(self, record: Record, model: Model, mass: float | None) -> Any:
        """Call the plugin directly; any exception it raises is the failure of the check that expected success."""
        try:
            return self.instance().identify(record, model, mass=mass)
        except (Exception, SystemExit) as exc:  # noqa: BLE001 - reported as the broken rule (sys.exit too)
            raise _fail(f"{self.cls.name}: identify() {describe_exception(exc)}") from exc

    def call(self, record: Record, model: Model, mass: float | None) -> Any:
        """Call the plugin directly, letting its exception through (for checks that expect one)."""
        return self.instance().identify(record, model, mass=mass)


def _fail(message: str) -> AssertionError:
    return AssertionError(message)


def _check_estimate(estimate: Any, model: Model, who: str, mass: float | None = None) -> Estimate:
    """The core's own check (:func:`nlid.contract.estimate.check_estimate`), its refusal as the failed rule."""
    try:
        return check_estimate(estimate, model, who, mass)
    except (PluginError, IdentificationError) as exc:
        raise _fail(str(exc)) from None


# --------------------------------------------------------------------------- the checks
def check_attributes(s: _Setup) -> None:
    """``name``, ``summary``, ``options``, ``needs_mass``, ``identify`` and the optional ones have the right types."""
    cls = s.cls
    name = getattr(cls, "name", None)
    if not isinstance(name, str) or not name or name != name.strip():
        raise _fail(f"{cls.__name__}: 'name' must be a non-empty string (the entry-point name), got {name!r}")
    summary = getattr(cls, "summary", None)
    if not isinstance(summary, str) or not summary.strip() or "\n" in summary.strip():
        raise _fail(f"{name}: 'summary' must be one non-empty line (nlid methods prints it), got {summary!r}")
    options = getattr(cls, "options", None)
    if not isinstance(options, tuple) or not all(isinstance(o, Option) for o in options):
        raise _fail(f"{name}: 'options' must be a tuple of nlid.plugin.Option")
    if not isinstance(getattr(cls, "needs_mass", None), bool):
        raise _fail(f"{name}: 'needs_mass' must be True or False")
    if not callable(getattr(cls, "identify", None)):
        raise _fail(f"{name}: has no identify() method")
    _check_core_attributes(cls, name, options)


def _check_core_attributes(cls: type, name: str, options: tuple[Option, ...]) -> None:
    """The optional attributes the core reads instead of naming plugins (:mod:`nlid.contract.methods`)."""
    for key in ("preference", "advice_order"):
        value = getattr(cls, key, None)
        if value is not None and (isinstance(value, bool) or not isinstance(value, int)):
            raise _fail(f"{name}: {key!r} must be an int (lower first) or None, got {value!r}")
    for key in ("advice", "docs"):
        value = getattr(cls, key, "")
        if not isinstance(value, str) or "\n" in value.strip() or value != value.strip():
            raise _fail(f"{name}: {key!r} must be one line of text (or empty), got {value!r}")
    refines = getattr(cls, "refines", False)
    if not isinstance(refines, bool):
        raise _fail(f"{name}: 'refines' must be True or False, got {refines!r}")
    if refines and not any(o.name == "init" and o.type == "str" for o in options):
        raise _fail(f"{name}: a refining identifier (refines = True) declares a str option 'init' (the start method)")


def check_options_documented(s: _Setup) -> None:
    """Every option has a help text, a unique name and a default that validates."""
    names = [o.name for o in s.cls.options]
    if len(set(names)) != len(names):
        raise _fail(f"{s.cls.name}: an option is declared twice: {names}")
    for opt in s.cls.options:
        if not opt.help or not opt.help.strip():
            raise _fail(f"{s.cls.name}: option {opt.name!r} has no help text (nlid methods shows it)")
        if opt.default is None:
            if not opt.nullable:
                raise _fail(f"{s.cls.name}: option {opt.name!r} defaults to None but is not nullable ('auto')")
            continue
        try:
            parsed = opt.parse(opt.default)
        except OptionError as exc:
            raise _fail(f"{s.cls.name}: the default of option {opt.name!r} does not validate: {exc}") from None
        if parsed != opt.default:
            raise _fail(f"{s.cls.name}: the default of option {opt.name!r} parses to {parsed!r}, not itself")


def check_unknown_option_rejected(s: _Setup) -> None:
    """An unknown option raises :class:`~nlid.errors.OptionError` in the constructor."""
    try:
        s.cls(**{**s.options, "no_such_option_xyz": 1})
    except OptionError:
        return
    except (Exception, SystemExit) as exc:  # noqa: BLE001 - the wrong kind of error (sys.exit too)
        raise _fail(f"{s.cls.name}: an unknown option must raise OptionError, got {type(exc).__name__}") from None
    raise _fail(f"{s.cls.name}: the constructor accepted an unknown option (it must raise OptionError)")


_BAD_VALUES = {"int": "not-a-number", "float": "not-a-number", "bool": "maybe", "floats": "1,x"}


def check_bad_option_value_rejected(s: _Setup) -> None:
    """A value of the wrong type (or not among the choices) raises :class:`~nlid.errors.OptionError`."""
    for opt in s.cls.options:
        bad: Any = _BAD_VALUES.get(opt.type)
        if opt.type == "str":
            if opt.choices is None:
                continue
            bad = "no-such-choice-xyz"
        try:
            s.cls(**{**s.options, opt.name: bad})
        except OptionError:
            continue
        except (Exception, SystemExit) as exc:  # noqa: BLE001 - sys.exit in a plugin is a broken rule too
            raise _fail(
                f"{s.cls.name}: option {opt.name!r}={bad!r} must raise OptionError, got {type(exc).__name__}"
            ) from None
        raise _fail(f"{s.cls.name}: option {opt.name!r} accepted the invalid value {bad!r}")


def check_known_mass(s: _Setup) -> None:
    """With the mass given: an Estimate with finite coefficients in model order and no competing mass."""
    model, mass = s.model(), s.mass()
    _check_estimate(s.run(s.data(), model, mass), model, f"{s.cls.name} (mass given)", mass)


def check_estimated_mass(s: _Setup) -> None:
    """Without the mass: a positive estimate, or InputError when the method needs the mass."""
    model = s.model()
    if s.cls.needs_mass:
        try:
            s.call(s.data(), model, None)
        except InputError:
            return
        except (Exception, SystemExit) as exc:  # noqa: BLE001 - sys.exit in a plugin is a broken rule too
            raise _fail(
                f"{s.cls.name}: needs_mass is True, so identify(mass=None) must raise InputError, "
                f"got {type(exc).__name__}: {exc}"
            ) from None
        raise _fail(f"{s.cls.name}: needs_mass is True but identify(mass=None) did not raise InputError")
    est = _check_estimate(s.run(s.data(), model, None), model, f"{s.cls.name} (mass estimated)")
    if est.mass is None or not (np.isfinite(est.mass) and est.mass > 0):
        raise _fail(
            f"{s.cls.name}: needs_mass is False, so identify(mass=None) must return a positive mass, got {est.mass!r}"
        )


def check_px_model(s: _Setup) -> None:
    """A model with ``sign(v)*|px(z)|`` (roots set) is identified: one finite coefficient per term."""
    from .model.physics import stiffness_roots

    record = s.data()
    truth = record.meta.get("truth") or {}
    base = s.model()
    z_range = (float(record.z.min()), float(record.z.max()))
    roots = stiffness_roots(base, truth.get("coefficients") or {}, z_range) if truth else None
    if roots is None:
        raise _fail("the check record has no true coefficients to take the px(z) roots from")
    model = base.with_terms(add=["sign(v)*|px(z)|"]).with_px_roots(roots)
    _check_estimate(s.run(record, model, s.mass()), model, f"{s.cls.name} (px model)", s.mass())


def check_deterministic(s: _Setup) -> None:
    """Two runs with the same settings give the same coefficients."""
    model, mass = s.model(), s.mass()
    first = _check_estimate(s.run(s.data(), model, mass), model, s.cls.name, mass)
    second = _check_estimate(s.run(s.data(), model, mass), model, s.cls.name, mass)
    if dict(first.coefficients) != dict(second.coefficients):
        raise _fail(
            f"{s.cls.name}: identification is not deterministic: {dict(first.coefficients)} then "
            f"{dict(second.coefficients)} (seed any randomness from a setting)"
        )


def check_diagnostics_jsonable(s: _Setup) -> None:
    """``diagnostics`` and ``warnings`` serialise to JSON (after :func:`nlid.base.jsonable.to_jsonable`)."""
    model, mass = s.model(), s.mass()
    est = s.run(s.data(), model, mass)
    _check_estimate(est, model, s.cls.name, mass)
    try:
        json.dumps(to_jsonable(dict(est.diagnostics)), allow_nan=False)
    except (TypeError, ValueError) as exc:
        raise _fail(f"{s.cls.name}: diagnostics are not JSON-serialisable: {exc}") from None
    if not all(isinstance(w, str) for w in est.warnings):
        raise _fail(f"{s.cls.name}: warnings must be strings")


def check_bad_record(s: _Setup) -> None:
    """A 40-sample, displacement-only record raises an nlid error of the right kind, not a bare exception."""
    record = s.data().without("v", "a")[:40]
    try:
        s.call(record, s.model(), s.mass())
    except (InputError, IdentificationError):
        return
    except NlidError as exc:
        raise _fail(
            f"{s.cls.name}: an unusable record must raise DataError, InputError or IdentificationError, "
            f"got {type(exc).__name__}"
        ) from None
    except (Exception, SystemExit) as exc:  # noqa: BLE001 - sys.exit in a plugin is a broken rule too
        raise _fail(
            f"{s.cls.name}: an unusable record raised {type(exc).__name__}: {exc} - raise "
            "nlid.plugin.DataError (or InputError/IdentificationError) with a clear message"
        ) from None


def check_core_round_trip(s: _Setup) -> None:
    """Through :func:`nlid.identify`: the identified model's ``to_dict``/``from_dict`` round trip."""
    from .identification.pipeline import identify
    from .identified.model import IdentifiedModel

    try:
        fit = identify(s.data(), s.model(), s.instance(), mass=s.mass())
    except NlidError as exc:
        raise _fail(f"{s.cls.name}: nlid.identify refused the plugin's answer: {exc}") from None
    text = json.dumps(fit.to_dict(), allow_nan=False)
    again = IdentifiedModel.from_dict(json.loads(text))
    if again.to_dict() != fit.to_dict():
        raise _fail(f"{s.cls.name}: the identified model does not round-trip through JSON")


def check_accuracy(s: _Setup) -> None:
    """Every coefficient within ``accuracy`` (relative) of the truth, on exact data."""
    assert s.accuracy is not None
    record, model = s.data(), s.model()
    truth = (record.meta.get("truth") or {}).get("coefficients")
    if not truth:
        raise _fail("the check record has no true coefficients")
    est = _check_estimate(s.run(record, model, s.mass()), model, s.cls.name, s.mass())
    for name, value in est.coefficients.items():
        rel = abs(value / truth[name] - 1.0)
        if not rel <= s.accuracy:
            raise _fail(
                f"{s.cls.name}: {name} = {value:.6g} vs true {truth[name]:.6g} "
                f"({100 * rel:.3g} % > {100 * s.accuracy:g} %)"
            )


#: The checks in the order they run (``check_accuracy`` runs only with ``accuracy=``).
CHECKS: tuple[Callable[[_Setup], None], ...] = (
    check_attributes,
    check_options_documented,
    check_unknown_option_rejected,
    check_bad_option_value_rejected,
    check_known_mass,
    check_estimated_mass,
    check_px_model,
    check_deterministic,
    check_diagnostics_jsonable,
    check_bad_record,
    check_core_round_trip,
    check_accuracy,
)


@dataclass(frozen=True)
class Check:
    """One named check bound to an identifier class; call it to run it.

    Attributes
    ----------
    name
        The check's name (``check_known_mass``...).
    identifier
        The class checked.
    """

    name: str
    identifier: type
    _run: Callable[[], None]

    def __call__(self) -> None:
        """Run the check; raises :class:`AssertionError` naming the broken rule."""
        self._run()

    def __repr__(self) -> str:
        return f"{getattr(self.identifier, 'name', self.identifier.__name__)}-{self.name}"


def identifier_checks(
    cls: type,
    *,
    options: dict[str, Any] | None = None,
    terms: str = "z^3, z^2, v*|v|",
    accuracy: float | None = None,
    record: Record | None = None,
) -> list[Check]:
    """The named checks for an identifier class.

    Parameters
    ----------
    cls
        The identifier class.
    options
        Options to construct it with.
    terms
        Model terms (besides ``1, z, v``) for the checks.
    accuracy
        If given, also check every coefficient within this relative error of
        the truth on exact data (e.g. ``1e-3``).
    record
        Record to use (default :func:`contract_record`, which holds its truth
        in ``meta``).
    """
    if not isinstance(cls, type):
        raise PluginError(f"expected an identifier class, got {cls!r}")
    setup = _Setup(cls, dict(options or {}), terms, accuracy, record)
    out = []
    for check in CHECKS:
        if check is check_accuracy and accuracy is None:
            continue
        out.append(Check(check.__name__, cls, functools.partial(check, setup)))
    return out


def check_identifier(cls: type, **settings: Any) -> None:
    """Run every check of :func:`identifier_checks` on ``cls``; the first failure raises.

    Raises
    ------
    AssertionError
        ``"<check name>: <what is wrong>"``.
    """
    for check in identifier_checks(cls, **settings):
        try:
            check()
        except AssertionError as exc:
            raise AssertionError(f"{check.name}: {exc}") from None


def parametrize_with_checks(classes: Iterable[type], **settings: Any) -> Any:
    """A ``pytest.mark.parametrize("check", ...)`` over every check of every class (ids ``name-check``)."""
    import pytest

    checks = [c for cls in classes for c in identifier_checks(cls, **settings)]
    return pytest.mark.parametrize("check", checks, ids=[repr(c) for c in checks])
