"""Open-world discovery: effects outside the first ten candidates are found, or the right probe says so (issue 13)."""

from __future__ import annotations

import pytest

import nlid
from nlid.discovery.cases import OPEN_WORLD, build_case, build_open_case

pytestmark = pytest.mark.slow


@pytest.mark.parametrize("effect", sorted(OPEN_WORLD))
def test_the_right_effect_first_or_the_right_probe(effect):
    expected = OPEN_WORLD[effect][2]
    for seed in (0, 1):
        record, declared, mass = build_open_case(effect, seed)
        result = nlid.discover(record, declared, "rfs", mass=mass, simulate=False, views=False)
        if expected in ("force-rate",):  # no candidate can express a time skew: the probe must say it
            assert not result.steps, [s.effect for s in result.steps]
            assert result.remaining.structured and result.remaining.dominant == expected
            assert "skewed in time" in result.stop_reason
        else:
            assert result.steps and result.steps[0].effect == expected, (seed, [s.effect for s in result.steps])
            before, after = result.steps[0].before.scores, result.steps[0].after.scores
            assert after.eps_holdout < before.eps_holdout
        if effect == "wrong-mass":
            note = result.steps[0].notes[0]
            assert note.startswith("the given mass looks wrong: the data say m = ")
            assert abs(result.final.mass / 0.2 - 1) < 0.02
        if effect == "product-friction":
            assert "|z|*sign(v)" in result.steps[0].terms


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
    result = nlid.discover(record, declared, "rfs", mass=mass, simulate=False)
    text = result.summary()
    assert "remains predictable from the force's rate of change" in text
    paths = result.write_report(tmp_path)
    assert (tmp_path / "figures" / "remaining.png").is_file() and tmp_path / "report.html" in paths
    html = (tmp_path / "report.html").read_text()
    assert "What remains" in html and "force-rate" in html
