"""A 3-DOF chain with an undeclared Coulomb friction on connection 1-2 and a declared ``(z2-z3)^3`` (issue 31, item 4).

Only the displacements are recorded (velocities and accelerations estimated), as on the reviewer's hidden
record. The joint least squares behind ``discover`` is ``rfs``'s: its cubic is within 1 % where the old
copy (elements evaluated on the motion already low-passed, the held force without its hold) was 25 % low;
``discover`` names connection 1-2 with a dissipative friction law of positive coefficient and refuses the
negative damping laws that would feed energy in. Several seeds and noise levels:
``benchmarks/accuracy_mdof_friction.py``.
"""

from __future__ import annotations

import numpy as np
import pytest

from nlid.discovery.structure import discover_structure
from nlid.estimation.joint import NormalEquations, fit_linear_elements, joint_least_squares
from nlid.estimation.structure_regression import structure_regression_data
from nlid.model.elements import ElementSet
from nlid.simulation.presets import get_preset

CUBIC, FRICTION = "(z2-z3)^3", "sign(v1-v2)"
TRUTH = {CUBIC: 5e9, FRICTION: 2.0}


def _chain(duration: float):
    return get_preset("3dof-cubic").with_overrides(
        duration=duration, elements=f"{CUBIC}, {FRICTION}", coefficients=TRUTH
    )


@pytest.fixture(scope="module")
def long_record():
    """30 s, displacements only, 0.5 % noise on them."""
    return _chain(30.0).simulate(2, noise={"z": 0.005}, channels=("z",))


@pytest.fixture(scope="module")
def short_record():
    """10 s, displacements only, 0.2 % noise on them."""
    return _chain(10.0).simulate(1, noise={"z": 0.002}, channels=("z",))


def test_joint_least_squares_with_the_true_model_is_unbiased(long_record):
    model = fit_linear_elements(long_record, f"{CUBIC}, {FRICTION}")
    assert model.coefficient(CUBIC) == pytest.approx(TRUTH[CUBIC], rel=0.01)
    assert model.coefficient(FRICTION) > 0
    np.testing.assert_allclose(model.K, long_record.meta["reference"]["K"], rtol=0.01, atol=1e3)


def test_normal_equations_solve_the_same_least_squares(short_record):
    """discover scores candidates through normal equations: the same data and weights give the same fit."""
    elements = ElementSet.from_spec(f"{CUBIC}, {FRICTION}", 3)
    data = structure_regression_data(short_record, elements)
    solution = joint_least_squares(data, elements, short_record.mass)
    fit = NormalEquations(data, short_record.mass, elements).solve(solution.weights**2)
    np.testing.assert_allclose(fit.theta, solution.theta, rtol=1e-7)
    np.testing.assert_allclose(fit.K, solution.K, rtol=1e-7, atol=1e-9 * np.abs(solution.K).max())
    # a candidate's columns are built on the elements' footing: the same element gives the same regressors
    again = data.regressors(elements.evaluate)
    np.testing.assert_array_equal(again, data.G)


@pytest.fixture(scope="module")
def found(short_record):
    return discover_structure(
        short_record,
        CUBIC,
        candidates="coulomb, quadratic-damping, cubic-damping, stribeck, cubic-stiffness",
        plugins=False,
        max_steps=1,
        simulate=False,
        refine=False,
    )


def test_discover_names_the_connection_and_a_dissipative_friction_law(found):
    assert found.located == (1, 2)
    step = found.steps[0]
    assert step.evidence.effect in ("coulomb", "stribeck")
    assert all(value > 0 for value in step.evidence.coefficients.values())
    assert found.final.model.coefficient(CUBIC) == pytest.approx(TRUTH[CUBIC], rel=0.01)


def test_a_law_that_would_feed_energy_in_is_refused_and_said(found):
    ranking = {(e.effect, e.where): e for e in found.steps[0].ranking}
    quadratic = ranking[("quadratic-damping", "1-2")]
    assert quadratic.coefficients["(v1-v2)*|v1-v2|"] < 0  # what the data alone would have given
    assert quadratic.status == "rejected" and "feed energy into the structure" in quadratic.reason
    assert quadratic in found.refused
    assert "refused: quadratic-damping on connection 1-2" in found.summary()
    assert "Refused for their sign" in found.report()
    assert found.to_dict()["refused"][0]["status"] == "rejected"


def test_without_refine_the_summary_says_the_coefficients_are_biased(found):
    assert found.refined is None and found.to_dict()["refined"] is None
    assert found.model is found.final.model and found.to_dict()["model"] == found.final.label
    assert "refining (refine=True) refits the final elements by output error" in found.summary()


@pytest.fixture(scope="module")
def refined():
    """10 s at 1 % noise: the equation error's cubic is about 1.2 % low here, its Coulomb force 14 % low.

    ``refine`` is left at its default: the velocities and accelerations are estimated, so the search refines.
    """
    record = _chain(10.0).simulate(1, noise={"z": 0.01}, channels=("z",))
    return discover_structure(
        record,
        CUBIC,
        candidates="coulomb, quadratic-damping, cubic-damping, stribeck, cubic-stiffness",
        plugins=False,
        max_steps=1,
        simulate=False,
    )


def test_by_default_the_chosen_elements_are_refitted_by_output_error_without_their_bias(refined):
    assert refined.located == (1, 2)
    assert refined.refined is not None and refined.refined.elements == refined.final.elements
    search, refit = refined.final.model, refined.refined.model
    assert search.coefficient(FRICTION) < 0.92 * TRUTH[FRICTION]  # the filter's smoothing of the step
    assert refit.coefficient(FRICTION) == pytest.approx(TRUTH[FRICTION], rel=0.03)
    assert refit.coefficient(CUBIC) == pytest.approx(TRUTH[CUBIC], rel=0.005)
    # the refit is the structure model the result reports
    assert refined.model is refit and refined.to_dict()["model"] == "refined (oe)"
    assert "refined (oe), fitted on the selection record" in refined.summary()
    assert "## Refined (oe)" in refined.report()
    assert refined.to_dict()["refined"]["coefficients"][FRICTION] == refit.coefficient(FRICTION)
    assert "refining (refine=True)" not in refined.summary()


def test_with_measured_derivatives_or_no_refiner_the_default_does_not_refine(short_record, monkeypatch):
    """The search's fits are unbiased when v and a are measured; without an installed refiner there is none."""
    import nlid.discovery.structure as structure

    called = []
    monkeypatch.setattr(structure, "_refine", lambda *args: called.append(args))
    measured = _chain(10.0).simulate(1, noise={"z": 0.002})
    assert measured.is_measured("v1") and measured.is_measured("a3")
    found = discover_structure(measured, CUBIC, plugins=False, candidates="coulomb", max_steps=0, simulate=False)
    assert found.refined is None and not called and found.model is found.final.model
    monkeypatch.setattr(structure, "_refiner", lambda: None)
    found = discover_structure(short_record, CUBIC, plugins=False, candidates="coulomb", max_steps=0, simulate=False)
    assert found.refined is None and not called
    assert found.info["derivatives_measured"] is False


def _evidence(explained: float, dbic: float = -100.0, status: str = "below threshold", connection=(1, 2)):
    from nlid.discovery.structure_result import ConnectionEvidence

    return ConnectionEvidence(
        "coulomb", connection, ("sign(v1-v2)",), {"sign(v1-v2)": 1.0}, explained=explained, delta_bic=dbic,
        parameters=1, status=status, reason="below",
    )  # fmt: skip


def _probes(found: float, connection=(1, 2)):
    from nlid.discovery.probes import MIN_STRUCTURE
    from nlid.discovery.structure_result import ConnectionProbe, StructureRemaining

    probes = (
        ConnectionProbe(connection, "velocity", found, found, found, 6),
        ConnectionProbe((2, 3), "z", 0.001, 0, 0, 6),
    )
    return StructureRemaining(probes, MIN_STRUCTURE)


@pytest.mark.parametrize(
    ("explained", "found", "dbic", "passes"),
    [
        (0.065, 0.066, -300.0, True),  # captures what the connection's probes find: the residual is noise
        (0.045, 0.046, -300.0, False),  # below the probes' own threshold (5 %)
        (0.055, 0.080, -300.0, False),  # a law that explains 69 % of the structure there, not 80 %
        (0.055, 0.045, -300.0, False),  # the connection's probes find no structure
        (0.065, 0.066, -5.0, False),  # the BIC does not support it
    ],
)
def test_a_candidate_below_the_threshold_passes_only_when_it_captures_its_connections_structure(
    explained, found, dbic, passes
):
    from nlid.discovery.evidence import AcceptanceRule
    from nlid.discovery.structure_accept import rank

    ranked, accepted = rank([_evidence(explained, dbic)], AcceptanceRule(), _probes(found))
    assert (accepted is not None) is passes
    if passes:
        assert "its connection's probes find predictable" in accepted.reason
    assert rank([_evidence(explained, dbic)], AcceptanceRule())[1] is None  # without probes: the plain rule


@pytest.fixture(scope="module")
def noisy_record():
    """15 s at 2 % noise: Coulomb explains 7 % of a residual that is mostly noise, below the 10 % rule."""
    return _chain(15.0).simulate(1, noise={"z": 0.02}, channels=("z",))


def _discover_noisy(record):
    return discover_structure(
        record, CUBIC, candidates="coulomb, quadratic-damping, cubic-damping, stribeck", plugins=False,
        max_steps=1, simulate=False, refine=False,
    )  # fmt: skip


def test_a_noisy_record_still_names_the_friction_when_it_is_all_the_structure_left(noisy_record):
    """Coulomb explains 95 % of what the flexible probes on connection 1-2 find predictable, and the held-out
    free run confirms it (on 30-s records: 5/5 seeds named, and nothing on the chain without friction at 0, 1
    and 2 %: ``benchmarks/accuracy_mdof_friction.py``)."""
    found = _discover_noisy(noisy_record)
    assert found.located == (1, 2)
    evidence = found.steps[0].evidence
    assert evidence.effect == "coulomb" and evidence.explained < 0.10
    assert evidence.coefficients[FRICTION] > 0
    assert "held-out free run" in evidence.reason


def test_below_the_threshold_a_candidate_the_free_run_does_not_confirm_is_not_accepted(noisy_record, monkeypatch):
    import nlid.discovery.structure_accept as accept

    def flat(model, record):  # every model predicts the held-out part equally well
        n = model.n_dofs
        return (1.0,) * n, (5.0,) * n, "flat"

    monkeypatch.setattr(accept, "free_run_error", flat)
    found = _discover_noisy(noisy_record)
    assert found.steps == ()
    refused = [e for e in found.ranking if e.status == "not confirmed"]
    assert refused and "held-out free run does not improve" in refused[0].reason
    assert "does not improve" in found.stop_reason


@pytest.mark.parametrize("noise", [0.01, 0.02])
def test_without_the_friction_a_noisy_record_names_nothing(noise):
    record = (
        get_preset("3dof-cubic")
        .with_overrides(duration=15.0, elements=CUBIC, coefficients={CUBIC: TRUTH[CUBIC]})
        .simulate(1, noise={"z": noise}, channels=("z",))
    )
    found = discover_structure(record, CUBIC, plugins=False, max_steps=1, simulate=False, refine=False)
    assert found.steps == ()
