"""A study's ``[response]`` table: parsed and checked up front, carried by each run, scored against the truth."""

from __future__ import annotations

import pytest

import nlid
from nlid.identified.reference import Reference
from nlid.study import ConfigError, parse_study, plan_study
from nlid.study import columns as col
from nlid.study.metrics import response_metrics

STUDY = """
[study]
name = "resp"
identifiers = ["rfs"]

[[datasets]]
name = "num"
preset = "paper-numerical"
terms = "z^3, z^2, v*|v|"
mass = "known"
"""


def test_the_response_table_is_parsed_and_written_back():
    config = parse_study(STUDY + '\n[response]\nforce = [0.5, 1.5]\nband = "2:20"\n')
    assert config.response == {"force": [0.5, 1.5], "band": [2.0, 20.0], "harmonics": 7}
    assert parse_study(config.to_toml()).response == config.response
    (run,) = plan_study(config)
    assert dict(run.spec.response) == config.response


def test_a_study_without_response_keeps_its_run_digests():
    """The spec adds ``response`` only when asked: stored runs of older studies are reused on resume."""
    (run,) = plan_study(parse_study(STUDY))
    assert "response" not in run.spec.to_dict()
    (asked,) = plan_study(parse_study(STUDY + "\n[response]\nforce = 1.0\nband = [2, 20]\n"))
    assert asked.digest != run.digest


@pytest.mark.parametrize(
    ("table", "key", "message"),
    [
        ("band = [2, 20]", "response.force", "needs force"),
        ("force = 1.0", "response.band", "needs band"),
        ("force = [1.0, -2.0]\nband = [2, 20]", "response.force", "positive numbers of N"),
        ("force = 1.0\nband = [20, 2]", "response.band", "0 < low < high"),
        ("force = 1.0\nband = [2, 20]\nharmonics = 0", "response.harmonics", ""),
        ("force = 1.0\nband = [2, 20]\nharmonic = 3", "response", "harmonic"),
    ],
)
def test_a_bad_response_table_names_its_key(table, key, message):
    with pytest.raises(ConfigError) as info:
        parse_study(STUDY + "\n[response]\n" + table + "\n")
    assert key in str(info.value) and message in str(info.value)


def test_the_response_of_the_truth_scores_zero_and_a_wrong_stiffness_does_not():
    record = nlid.simulate("paper-numerical", duration=10.0)
    reference = Reference.of(record, None)
    truth = reference.true_model()
    settings = {"force": [0.5, 1.5], "band": [2.0, 20.0], "harmonics": 3}
    same = response_metrics(truth, reference, **settings)
    assert same[col.RESPONSE_PEAK_HZ_ERROR.key()] == pytest.approx(0.0, abs=1e-9)
    assert same[col.RESPONSE_PEAK_M_ERROR.key()] == pytest.approx(0.0, abs=1e-9)
    assert 2.0 <= same[col.RESPONSE_PEAK_HZ.key()] <= 20.0 and same[col.RESPONSE_PEAK_M.key()] > 0
    coefficients = dict(truth.coefficients)
    coefficients["z^3"] *= 1.2  # a stiffer spring: the peak moves
    stiffer = nlid.IdentifiedModel(truth.model, coefficients, truth.mass, "probe")
    moved = response_metrics(stiffer, reference, **settings)
    assert moved[col.RESPONSE_PEAK_HZ_ERROR.key()] > 0.1 or moved[col.RESPONSE_PEAK_M_ERROR.key()] > 1.0
