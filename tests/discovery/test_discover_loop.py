"""The loop on simulated data with one undeclared effect (1 % noise), and on complete models.

For each effect of the library, on the double well and on a single-well
Duffing oscillator, with a displacement-only record and with an accelerometer
channel: the first step names the missing effect, epsilon drops on the
estimation and on the held-out data, and nothing else is added. A complete
declared model gives zero steps. Each case uses its own seed.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from nlid.discovery import discover
from nlid.discovery.cases import BOTH_WELLS

CHANNELS = {"displacement": ("z",), "accelerometer": ("z", "a")}
CASES = [
    *itertools.product(("double", "single"), BOTH_WELLS, CHANNELS),
    *itertools.product(("double",), ("position-dependent-friction",), CHANNELS),
]
SEEDS = {case: 100 + i for i, case in enumerate(CASES)}


@pytest.mark.slow
@pytest.mark.parametrize("well, effect, channels", CASES)
def test_the_first_step_names_the_missing_effect(make_case, well, effect, channels):
    record, declared = make_case(well, effect, CHANNELS[channels], SEEDS[(well, effect, channels)])
    result = discover(record, declared, "rfs", simulate=False, views=False)
    out = result.to_dict()
    assert out["declared"] and set(out["declared"]) <= set(out["final_terms"])
    steps = [s["effect"] for s in out["steps"]]
    assert steps == [effect], f"expected exactly [{effect!r}], the loop added {steps}; stopped: {result.stop_reason}"
    step = out["steps"][0]
    assert step["eps_after"] < step["eps_before"] and step["eps_after_holdout"] < step["eps_before_holdout"]
    assert out["eps_final"] < out["eps_initial"] and out["eps_final_holdout"] < out["eps_initial_holdout"]
    assert step["evidence"]["status"] == "accepted"
    assert step["evidence"]["explained_holdout"] >= result.rule.min_explained
    assert step["evidence"]["delta_bic"] <= result.rule.max_delta_bic
    # the final check tested the other candidates and none passed
    assert out["final_check"]["ranking"] and all(e["status"] != "accepted" for e in out["final_check"]["ranking"])


@pytest.mark.slow
@pytest.mark.parametrize("well, channels", list(itertools.product(("double", "single"), CHANNELS)))
def test_a_complete_declared_model_gives_zero_steps(make_case, well, channels):
    record, declared = make_case(well, "none", CHANNELS[channels], 7 if well == "double" else 8)
    result = discover(record, declared, "rfs", simulate=False, views=False)
    assert result.steps == [], [s.effect for s in result.steps]
    assert result.final.model.names == result.initial.model.names
    fitted = [e for e in result.final_ranking if e.explained_holdout is not None]
    assert len(fitted) >= 5 and all(e.status == "rejected" for e in fitted)
    assert result.stop_reason.startswith("no candidate passes")


def test_position_dependent_friction_needs_a_double_well(make_case):
    record, declared = make_case("single", "none", ("z",), 3)
    result = discover(record, declared, "rfs", candidates="position-dependent-friction,offset", simulate=False)
    by_name = {e.effect: e for e in result.final_ranking}
    pdf = by_name["position-dependent-friction"]
    assert pdf.status == "not applicable" and "double well" in pdf.reason
    assert by_name["offset"].status == "not applicable" and "already in the model" in by_name["offset"].reason


def test_a_coulomb_step_smoothed_by_velocity_noise_is_not_taken_for_stribeck(make_case):
    """After Coulomb friction is added, a negative sign(v)*exp(-(v/c)^2) term explains part of what an
    estimated velocity does near v = 0; it is not velocity-weakening friction and must be rejected."""
    record, declared = make_case("single", "coulomb", ("z", "a"), 11)
    result = discover(record, declared, "rfs", candidates="coulomb,stribeck", simulate=False, views=False)
    assert [s.effect for s in result.steps] == ["coulomb"]
    stribeck = {e.effect: e for e in result.final_ranking}["stribeck"]
    assert stribeck.status == "rejected" and stribeck.passes.get("physical") is False
    term = stribeck.terms[0]
    assert stribeck.coefficients[term] < 0


def test_free_run_error_is_reported_and_drops(make_case):
    record, declared = make_case("single", "cubic-stiffness", ("z",), 5)
    result = discover(record, declared, "rfs", candidates="cubic-stiffness,quintic-stiffness", views=False)
    first, last = result.initial.sim_rms_holdout, result.final.sim_rms_holdout
    assert first is not None and last is not None and np.isfinite(first) and last < 0.5 * first


def test_known_mass_is_used_and_held_out_record_may_be_separate(make_case):
    record, declared = make_case("double", "offset", ("z", "a"), 12)
    estimation, held = record.split(0.3)
    result = discover(estimation, declared, "rfs", mass=0.2, holdout=held, candidates="offset,coulomb", views=False)
    assert [s.effect for s in result.steps] == ["offset"]
    assert result.final.mass == 0.2 and not result.final.identified.mass_estimated
    assert result.info["samples_holdout"] == held.n and result.info["samples_estimation"] == estimation.n


def test_max_steps_zero_only_scores_the_declared_model(make_case):
    record, declared = make_case("double", "coulomb", ("z",), 13)
    result = discover(record, declared, "rfs", max_steps=0, simulate=False, views=False)
    assert result.steps == [] and result.stop_reason.startswith("maximum number of steps reached; ")
    assert result.to_dict()["eps_initial"] == result.to_dict()["eps_final"]
