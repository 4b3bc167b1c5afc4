"""The verdict reads where a method's velocity came from as typed diagnostics, and never parses prose."""

from __future__ import annotations

import pandas as pd
import pytest

from nlid import identify
from nlid.plugin import CHANNEL_SOURCES, ChannelSource, derivatives, source_entries
from nlid.study.report.section import Section
from nlid.study.report.verdict import build_verdict


def _why(diagnostics: dict) -> str:
    """The verdict's reasons for one method ``p`` whose runs reported ``diagnostics``."""
    frame = pd.DataFrame(
        [
            {"method": "p", "repetition": r, "status": "ok", "coef_error_pct:v": 1.0 + r, "seconds": 1.0}
            for r in range(2)
        ]
    )
    section = Section("d", "m", "", ["v"], ["p"], frame, None, diagnostics={"p": [diagnostics] * 2})
    return "; ".join(build_verdict(section).reasons["p"])


def test_a_plugin_giving_the_typed_source_gets_its_cutoff_in_the_verdict():
    used = derivatives.DerivativeFilter(cutoff=123.4)
    why = _why({CHANNEL_SOURCES: source_entries({"v": ChannelSource.differentiated(used, "z")})})
    assert "velocity from a low-passed derivative of z (fc 123.4 Hz)" in why
    assert "velocity measured" in _why({CHANNEL_SOURCES: source_entries({"v": ChannelSource(True)})})


@pytest.mark.parametrize("key", ["velocity", "channels"])
def test_a_plugin_giving_prose_has_it_quoted_not_parsed(key):
    prose = "estimated from z: zero-phase low-pass (fc=57 Hz) + spectral differentiation"
    why = _why({key: prose} if key == "velocity" else {key: {"v": prose}})
    assert f"velocity: {prose}" in why
    assert "(fc 57 Hz)" not in why and "low-passed derivative" not in why
    assert "velocity: measured" in _why({"velocity": "measured"})  # even this is not read as the typed flag


def test_a_structure_s_velocities_are_read_together():
    sources = {
        f"v{k}": ChannelSource.differentiated(derivatives.DerivativeFilter(cutoff=fc), f"z{k}")
        for k, fc in ((1, 40.0), (2, 60.0))
    }
    assert "velocity from a low-passed derivative of z (fc 40 to 60 Hz)" in _why(
        {CHANNEL_SOURCES: source_entries(sources)}
    )


def test_the_k_tilde_count_comes_from_the_accepted_members_not_from_the_text():
    members = [{"k_tilde": k, "accepted": k < 3} for k in range(5)]
    why = _why({"k_tilde": 1.0, "k_tilde_ensemble": members, "reported_fit": "the mean over the 7 k~1"})
    assert "coefficients averaged over 3 values of k~1" in why
    assert "averaged over" not in _why({"k_tilde": 1.0, "reported_fit": "the mean over the 7 k~1"})


@pytest.mark.parametrize("method", ["rfs", "nsi-ip"])
def test_the_built_in_identifiers_report_the_typed_source_their_text_says(numerical, method):
    record = numerical.with_overrides(duration=8.0).simulate(0, noise={"z": 0.02}, channels=("z",))
    fit = identify(record, "z^3, z^2, v*|v|", method)
    source = ChannelSource.from_dict(fit.diagnostics[CHANNEL_SOURCES]["v"])
    text = fit.diagnostics["velocity"] if method == "nsi-ip" else fit.diagnostics["channels"]["v"]
    assert source is not None and source.text == text and not source.measured
    assert source.derived_from == "z" and source.cutoff_hz is not None and f"fc={source.cutoff_hz:.4g} Hz" in text
