"""Each compliance check of nlid.testing fails on a plugin broken in exactly its way (and passes a good one)."""

from __future__ import annotations

import numpy as np
import pytest

from nlid.plugin import DataError, Estimate, Identifier, InputError, Option, regression_data
from nlid.testing import CHECKS, check_identifier, identifier_checks


class Good(Identifier):
    """Least squares on the force balance: passes every check."""

    name = "good"
    summary = "least squares on the filtered force balance (test plugin)"
    options = (
        Option("decimate", "int", 1, "keep every q-th equation", minimum=1),
        Option("solver", "str", "lstsq", "linear solver", choices=("lstsq",)),
    )
    needs_mass = False

    def identify(self, record, model, *, mass=None):
        if record.n < 200:
            raise DataError(f"{self.name}: {record.n} samples are too few")
        data = regression_data(record, model)
        q = self.settings["decimate"]
        if mass is None:
            X, y = np.column_stack([data.a, data.G])[::q], data.f[::q]
        else:
            X, y = data.G[::q], data.restoring_force(mass)[::q]
        theta = np.linalg.lstsq(X, y, rcond=None)[0]
        if mass is None:
            return Estimate(coefficients=model.as_dict(theta[1:]), mass=float(theta[0]))
        return Estimate(coefficients=model.as_dict(theta), diagnostics={"samples": int(y.size)})


# ---------------------------------------------------------------- one broken plugin per check
class NoSummary(Good):
    name = "no-summary"
    summary = ""


class UndocumentedOption(Good):
    name = "undocumented"
    options = (Option("decimate", "int", 1, ""),)


class SwallowsOptions(Good):
    name = "swallows"

    def __init__(self, **options):
        self.settings = {"decimate": 1, "solver": "lstsq"}  # ignores what it is given


class AcceptsBadValues(Good):
    name = "accepts-bad-values"

    def __init__(self, **options):
        super().__init__()
        self.settings.update(options)  # stores unvalidated values (unknown names are still refused)
        unknown = set(options) - {o.name for o in self.options}
        if unknown:
            from nlid.errors import OptionError

            raise OptionError(f"unknown option {sorted(unknown)[0]!r}")


class BadModal(Good):
    name = "bad-modal"

    def identify(self, record, model, *, mass=None):
        est = super().identify(record, model, mass=mass)
        return Estimate(coefficients=est.coefficients, mass=est.mass, modal=[{"fn_hz": 10.0}])  # no equilibrium


class ReturnsDict(Good):
    name = "returns-dict"

    def identify(self, record, model, *, mass=None):
        return dict(super().identify(record, model, mass=mass).coefficients)


class MissesAMass(Good):
    name = "misses-a-mass"

    def identify(self, record, model, *, mass=None):
        est = super().identify(record, model, mass=mass if mass is not None else record.mass)
        return Estimate(coefficients=est.coefficients)  # never estimates the mass although needs_mass is False


class ClaimsToNeedMass(Good):
    name = "claims-to-need-mass"
    needs_mass = True  # ... but silently runs without it


class NoPx(Good):
    name = "no-px"

    def identify(self, record, model, *, mass=None):
        if model.uses_px:
            raise ZeroDivisionError("px(z) not handled")
        return super().identify(record, model, mass=mass)


class Random(Good):
    name = "random"

    def identify(self, record, model, *, mass=None):
        est = super().identify(record, model, mass=mass)
        noise = np.random.default_rng().normal(size=len(model))
        coefficients = {n: v * (1 + 1e-3 * e) for (n, v), e in zip(est.coefficients.items(), noise, strict=True)}
        return Estimate(coefficients=coefficients, mass=est.mass)


class OpaqueDiagnostics(Good):
    name = "opaque-diagnostics"

    def identify(self, record, model, *, mass=None):
        est = super().identify(record, model, mass=mass)
        return Estimate(coefficients=est.coefficients, mass=est.mass, diagnostics={"solver": object()})


class CrashesOnShort(Good):
    name = "crashes-on-short"

    def identify(self, record, model, *, mass=None):
        if record.n < 200:
            raise IndexError("index 200 is out of bounds")
        return super().identify(record, model, mass=mass)


class WrongKeys(Good):
    name = "wrong-keys"

    def identify(self, record, model, *, mass=None):
        est = super().identify(record, model, mass=mass)
        return Estimate(coefficients=dict(list(est.coefficients.items())[:-1]), mass=est.mass)  # a term missing


class Inaccurate(Good):
    name = "inaccurate"

    def identify(self, record, model, *, mass=None):
        est = super().identify(record, model, mass=mass)
        return Estimate(coefficients={n: 1.1 * v for n, v in est.coefficients.items()}, mass=est.mass)


BROKEN = {
    "check_attributes": NoSummary,
    "check_options_documented": UndocumentedOption,
    "check_unknown_option_rejected": SwallowsOptions,
    "check_bad_option_value_rejected": AcceptsBadValues,
    "check_known_mass": WrongKeys,
    "check_estimated_mass": MissesAMass,
    "check_px_model": NoPx,
    "check_deterministic": Random,
    "check_diagnostics_jsonable": OpaqueDiagnostics,
    "check_bad_record": CrashesOnShort,
    "check_core_round_trip": BadModal,
    "check_accuracy": Inaccurate,
}


def _check(cls, name):
    checks = {c.name: c for c in identifier_checks(cls, accuracy=1e-6)}
    return checks[name]


def test_every_check_has_a_broken_plugin():
    assert set(BROKEN) == {c.__name__ for c in CHECKS}


def test_the_good_plugin_passes_every_check():
    check_identifier(Good, accuracy=1e-6)


@pytest.mark.parametrize("name", sorted(BROKEN))
def test_each_check_fails_on_its_broken_plugin(name):
    with pytest.raises(AssertionError):
        _check(BROKEN[name], name)()


def test_claimed_mass_need_is_checked():
    with pytest.raises(AssertionError, match="did not raise InputError"):
        _check(ClaimsToNeedMass, "check_estimated_mass")()


def test_an_answer_that_is_not_an_estimate_fails():
    with pytest.raises(AssertionError, match="must return nlid.plugin.Estimate"):
        _check(ReturnsDict, "check_known_mass")()


def test_check_identifier_names_the_failing_check():
    with pytest.raises(AssertionError, match=r"^check_deterministic: random: identification is not deterministic"):
        check_identifier(Random)


def test_refusing_without_mass_with_input_error_passes():
    class Needs(Good):
        name = "needs"
        needs_mass = True

        def identify(self, record, model, *, mass=None):
            if mass is None:
                raise InputError("needs: give mass=")
            return super().identify(record, model, mass=mass)

    _check(Needs, "check_estimated_mass")()


# ---------------------------------------------------------------- the attributes the core reads instead of names
class Refiner(Good):
    name = "refiner"
    refines = True
    options = (*Good.options, Option("init", "str", None, "method whose estimate starts the fit", nullable=True))


def _attributes(cls, **attributes):
    return type(cls.__name__, (cls,), attributes)


def test_the_optional_attributes_are_accepted_when_well_typed():
    ranked = _attributes(Good, preference=5, advice_order=None, advice="when the data are exact", docs="docs/x.md")
    _check(ranked, "check_attributes")()
    _check(Refiner, "check_attributes")()


@pytest.mark.parametrize(
    "attributes, message",
    [
        ({"preference": "1"}, "'preference' must be an int"),
        ({"preference": True}, "'preference' must be an int"),
        ({"advice_order": 1.5}, "'advice_order' must be an int"),
        ({"advice": "two\nlines"}, "'advice' must be one line"),
        ({"docs": None}, "'docs' must be one line"),
        ({"refines": 1}, "'refines' must be True or False"),
        ({"refines": True}, "declares a str option 'init'"),
    ],
)
def test_each_optional_attribute_is_checked(attributes, message):
    with pytest.raises(AssertionError, match=message):
        _check(_attributes(Good, **attributes), "check_attributes")()
