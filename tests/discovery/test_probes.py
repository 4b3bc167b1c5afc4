"""Remaining-structure probes: complete models are clean, each kind of missing effect is named (issue 13)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import nlid
from nlid.discovery.cases import build_case, build_open_case
from nlid.discovery.probes import MIN_STRUCTURE, PROBES, describe_remaining, probe_residual, resonance
from nlid.signal import derivatives


def _probe(record, declared, mass):
    est, held = record.split(0.25)
    fc = derivatives.suggest_cutoff(est.z, est.fs)
    fit = nlid.identify(est, nlid.Model.from_spec(declared, defaults=False), "rfs", mass=mass, cutoff=fc)
    return probe_residual(fit.residual(est, cutoff=fc), fit.residual(held, cutoff=fc))


@pytest.mark.slow
@pytest.mark.parametrize("well", ["double", "single"])
@pytest.mark.parametrize("noise", [0.01, 0.02, 0.05])
def test_complete_models_are_clean(well, noise):
    # (benchmarks/calibration_probes.py runs many more seeds: the largest fraction stays below 1 %)
    preset, declared = build_case(well, "none")
    for seed in (3, 4):
        remaining = _probe(preset.simulate(seed, noise={"z": noise}, channels=("z",)), declared, preset.mass)
        assert not remaining.structured, {k: p.explained for k, p in remaining.probes.items()}
        assert remaining.dominant is None and describe_remaining(remaining).startswith("clean")


@pytest.mark.slow
@pytest.mark.parametrize(
    "case, probe",
    [
        (("open", "hysteresis"), "memory"),
        (("open", "wrong-mass"), "acceleration"),
        (("open", "time-skew"), "force-rate"),
        (("open", "gap"), "z"),
        (("open", "product-friction"), "z,v"),
        (("library", "coulomb"), "v"),
    ],
)
def test_each_probe_names_its_kind_of_missing_effect(case, probe):
    for seed in (5, 6):
        if case[0] == "open":
            record, declared, mass = build_open_case(case[1], seed)
        else:
            preset, declared = build_case("single", case[1])
            record, mass = preset.simulate(seed, noise={"z": 0.02}, channels=("z",)), preset.mass
        remaining = _probe(record, declared, mass)
        assert remaining.structured and remaining.dominant == probe, (
            seed,
            remaining.dominant,
            {k: round(p.explained, 3) for k, p in remaining.probes.items()},
        )
        assert remaining.probes[probe].explained >= MIN_STRUCTURE


@pytest.mark.slow
@pytest.mark.parametrize("well", ["double", "single"])
def test_a_drifting_displacement_sensor_is_named_by_the_time_probe(well):
    """z drifting by 10 % of its standard deviation over the record (issue 31's probe: called clean before):
    no function of (z, v) predicts it, a function of time does."""
    preset, declared = build_case(well, "none")
    for seed in (5, 6):
        record = preset.simulate(seed, noise={"z": 0.02}, channels=("z",))
        drift = 0.1 * np.std(record.z) * np.linspace(0.0, 1.0, record.z.size)
        remaining = _probe(record.replace(z=record.z + drift), declared, preset.mass)
        assert remaining.dominant == "time", {k: round(p.explained, 3) for k, p in remaining.probes.items()}
        assert remaining.probes["time"].explained >= MIN_STRUCTURE and "drift" in describe_remaining(remaining)


def test_the_json_object_and_the_sentence():
    record, declared, mass = build_open_case("time-skew", 1)
    remaining = _probe(record, declared, mass)
    out = remaining.to_dict()
    assert {"structured", "explained_holdout", "dominant", "probes", "text"} <= set(out)
    assert set(out["probes"]) == set(PROBES) and out["structured"] is True and out["dominant"] == "force-rate"
    assert "force's rate of change" in out["text"] and "% of the force's RMS" in out["text"]
    assert out["explained_holdout"] >= out["probes"]["force-rate"]["explained"]


def test_a_short_held_out_record_gets_the_same_lagged_features_as_the_estimation_record():
    """A lag kept for the long record but too long for the short one gave mismatched design matrices."""
    record = nlid.simulate("paper-numerical", seed=1, noise={"z": 0.01}, channels="z", duration=2, fs=1024)
    remaining = _probe(record, "1, z, z^3, v", 0.2)  # 1.5 s to fit on, 0.5 s held out
    assert set(remaining.probes) == set(PROBES)
    assert all(math.isfinite(p.explained) and p.explained <= 1.0 for p in remaining.probes.values())


def _appended(seed: int, ratio: float, m2: float) -> nlid.Record:
    """DOF 1 of a Duffing oscillator (1 kg, 1e5 N/m, 5e9 N/m^3) carrying a hidden appendage of mass ``m2`` tuned
    to ``ratio`` times its 50.3 Hz: the record a one-DOF user takes, the force and DOF 1's motion."""
    import dataclasses

    from nlid.simulation.presets import get_preset

    k2 = m2 * (2 * np.pi * 50.33 * ratio) ** 2
    c2 = 2 * 0.02 * np.sqrt(k2 * m2)
    preset = dataclasses.replace(
        get_preset("3dof-cubic"), elements="z1^3", coefficients={"z1^3": 5e9}, M=((1.0, 0.0), (0.0, m2)),
        C=((20.0 + c2, -c2), (-c2, c2)), K=((1e5 + k2, -k2), (-k2, k2)), force_dofs=(1,), duration=20.0,
    )  # fmt: skip
    record = preset.simulate(seed, noise=0.01)
    return nlid.Record(f=record.f[:, 0], z=record.z[:, 0], v=record.v[:, 0], a=record.a[:, 0], fs=record.fs)


@pytest.mark.parametrize("ratio, m2", [(0.6, 0.05), (1.6, 0.1)])
def test_a_hidden_mode_is_named_with_its_frequency(ratio, m2):
    record = _appended(1, ratio, m2)
    result = nlid.discover(record, ["z", "v", "z^3"], mass=1.0, simulate=False, views=False, max_steps=0)
    remaining = result.states[-1].remaining
    assert remaining.dominant == "memory"
    assert remaining.resonance_hz == pytest.approx(50.33 * ratio, rel=0.05)
    assert f"a resonance near {remaining.resonance_hz:.3g} Hz" in result.stop_reason


@pytest.mark.parametrize("effect", ["hysteresis", "pre-sliding"])
def test_hysteresis_is_not_taken_for_a_mode(effect):
    record, declared, mass = build_open_case(effect, 1)
    result = nlid.discover(record, declared, mass=mass, simulate=False, views=False, max_steps=0)
    remaining = result.states[-1].remaining
    assert remaining.dominant == ("memory" if effect == "hysteresis" else "z,v")  # Dahl reads as a (z, v) law
    assert remaining.resonance_hz is None and "resonance" not in result.stop_reason


def test_a_gain_rising_to_the_band_edge_is_no_resonance(data_dir):
    # Silverbox's final model (discover-refine's terms): its residual's gain rises to the band's edge, as the w^2
    # of a mass error does; it is coherent there, but it is no mode
    record = nlid.load("dataset:silverbox")[40650:105712]
    fit = nlid.identify(record, "1, z, z^2, z^3, v, z^2*v, z*v^2, v*|v|, v^3", "rfs")
    residual = fit.residual(record)
    assert resonance(residual, residual.band_hz) is None
