"""Open-world discovery: effects outside the first ten candidates are found, or the right probe says so (issue 13)."""

from __future__ import annotations

import pytest

import nlid
from nlid.discovery import INPUT_PATH, library_names
from nlid.discovery.cases import OPEN_WORLD, SKEW_SAMPLES, build_case, build_open_case

pytestmark = pytest.mark.slow


@pytest.mark.parametrize("effect", sorted(OPEN_WORLD))
def test_the_right_effect_first_or_the_right_probe(effect):
    expected = OPEN_WORLD[effect][2]
    for seed in (0, 1):
        record, declared, mass = build_open_case(effect, seed)
        result = nlid.discover(record, declared, "rfs", mass=mass, simulate=False, views=False)
        effects = [s.effect for s in result.steps]
        if effect == "product-friction":
            # named candidates come first: a Stribeck law may stand in for the product until the dictionary
            # finds it, and is then removed as redundant (prune); the final model holds the product alone
            # found by the dictionary as |z|*sign(v) or (one seed in two since issue 31: the dictionary then runs on
            # the residual of the Stribeck stand-in) as a polynomial in |z| times sign(v): friction proportional to a
            # function of the position either way
            assert expected in effects, (seed, effects)
            step = result.steps[effects.index(expected)]
            position_friction = [t for t in step.terms if t.endswith("*sign(v)") and "z" in t]
            assert position_friction and all(t in result.final.identified.terms for t in position_friction), step.terms
            assert not any(t.startswith("sign(v)*exp") for t in result.final.identified.terms)
        else:
            assert effects and effects[0] == expected, (seed, effects)
            step = result.steps[0]
        assert step.after.scores.eps_holdout < step.before.scores.eps_holdout
        if effect == "time-skew":  # the recorded force is late by SKEW_SAMPLES: the force acts that much ahead
            delay = result.steps[0].after.path.delay * record.fs
            assert delay == pytest.approx(-SKEW_SAMPLES, abs=0.25), delay
        if effect == "wrong-mass":
            note = result.steps[0].notes[0]
            assert note.startswith("the given mass looks wrong: the data say m = ")
            assert abs(result.final.mass / 0.2 - 1) < 0.02


@pytest.mark.parametrize("noise", [0.01, 0.02, 0.05])
def test_complete_models_take_zero_steps_and_are_clean(noise):
    preset, declared = build_case("single", "none")
    record = preset.simulate(7, noise={"z": noise}, channels=("z",))
    result = nlid.discover(record, declared, "rfs", mass=preset.mass, simulate=False, views=False)
    assert result.steps == [], [s.effect for s in result.steps]
    out = result.to_dict()
    assert out["remaining"]["structured"] is False and "the final model is clean" in out["final_check"]["stop_reason"]


def test_the_report_shows_what_remains(tmp_path):
    record, declared, mass = build_open_case("time-skew", 2)
    # without the input-path candidates nothing can express the skew: the probe must say what remains
    names = [n for n in library_names() if n not in {c.name for c in INPUT_PATH}]
    result = nlid.discover(record, declared, "rfs", mass=mass, simulate=False, candidates=names)
    text = result.summary()
    assert "remains predictable from the force's rate of change" in text
    paths = result.write_report(tmp_path)
    assert (tmp_path / "figures" / "remaining.png").is_file() and tmp_path / "report.html" in paths
    html = (tmp_path / "report.html").read_text()
    assert "What remains" in html and "force-rate" in html


def test_a_displacement_in_millimetres_is_named_as_such():
    """z written in mm but read as m makes the given mass look 1000 times too large: the note names the unit
    slip, not only the mass (issue 31's probe)."""
    record, declared, _ = build_open_case("wrong-mass", 0)
    mm = nlid.Record(f=record.f, z=1e3 * record.z, fs=record.fs, meta=dict(record.meta))
    result = nlid.discover(mm, declared, "rfs", mass=0.2, simulate=False, views=False)
    assert result.steps and result.steps[0].effect == "mass"
    note = result.steps[0].notes[0]
    assert "units='z=mm'" in note and "(not g)" in note


def test_a_declared_model_without_its_spring_gets_it_back():
    """``z^3, z^2`` declared on the double well without its quadratic damping: the linear spring (negative), the
    viscous damping and the offset are found, where a gap, two stops and z^5 piled up without the candidate."""
    import dataclasses

    from nlid.simulation.presets import get_preset

    preset = get_preset("paper-numerical")
    truth = {k: v for k, v in preset.coefficients.items() if k != "v*|v|"}
    without = dataclasses.replace(preset, duration=20.0, terms="z^3, z^2", coefficients=truth)
    record = without.simulate(1, noise=0.01)
    result = nlid.discover(record, "z^3, z^2", "rfs", mass=preset.mass, simulate=False, views=False)
    assert [s.effect for s in result.steps][:1] == ["linear-stiffness"]
    found = result.final.coefficients
    assert set(found) == set(truth)
    assert all(found[k] == pytest.approx(truth[k], rel=0.02) for k in truth), found


@pytest.mark.parametrize(
    "delay_samples, meta, noted",
    [(0.5, {}, True), (0.42, {}, True), (2.0, {}, False), (0.5, {"force_hold": "sampled"}, False)],
)
def test_half_a_sample_on_a_record_silent_about_its_hold_is_said_to_look_like_a_held_force(delay_samples, meta, noted):
    """Issue 31's probe: a z-only record of a held force, read without its sidecar, was given a lag of 0.51
    samples and no word about the hold."""
    from nlid.discovery.paths import held_force_note
    from nlid.estimation.inputpath import InputPath

    record = nlid.simulate("paper-numerical", seed=1, duration=1.0)
    record = nlid.Record(f=record.f, z=record.z, fs=record.fs, meta=meta)
    note = held_force_note(InputPath(delay=delay_samples / record.fs), record)
    assert bool(note) is noted and (not noted or "force_hold='zoh'" in note)
    lag = held_force_note(InputPath(lag=delay_samples / record.fs), record)
    assert bool(lag) is noted
