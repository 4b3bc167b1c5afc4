"""Glitches (nlid.signal.glitches): clipped channels found where a range cut them, not where a record merely
peaks; isolated spikes found where a sample leaves its path and comes back, not at kinks, steps or noise."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import nlid
from nlid.data.record import Record
from nlid.discovery.report import write_report
from nlid.discovery.structure import discover_structure
from nlid.signal.glitches import despike, find_clipping, find_glitches, find_spikes
from nlid.simulation.presets import PRESETS, get_preset


def _clip(x: np.ndarray, fraction: float) -> np.ndarray:
    limit = fraction * np.max(np.abs(x))
    return np.clip(x, -limit, limit)


@pytest.fixture(scope="module")
def noisy(numerical):
    """10 s of paper-numerical at 1 % noise (z, v, a measured)."""
    return numerical.with_overrides(duration=10.0).simulate(3, noise=0.01)


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_no_preset_has_a_glitch(name, request):  # one DOF and structures
    preset = get_preset(name)
    if (getattr(preset, "multisine", None) or {}).get("phases") == "benchmark":
        request.getfixturevalue("data_dir")  # its phases are read from the benchmark's file (skips without it)
    if getattr(preset, "multisine", None) is None:  # a multisine's length is its periods'
        preset = preset.with_overrides(duration=min(preset.duration, 20.0))
    assert find_glitches(preset.simulate(1, noise=0.01)) == ()
    assert find_glitches(preset.simulate(1)) == ()  # noise-free: sines hit at their crests are not cuts


def test_no_measured_benchmark_has_a_glitch(data_dir):
    for name in ("dataset:emps", "dataset:silverbox", "dataset:bouc-wen"):  # EMPS: an encoder at rest for long
        assert find_glitches(nlid.load(name)) == (), name


def test_a_clipped_displacement_is_found_on_the_side_it_was_cut(noisy):
    z = _clip(noisy.z, 0.9)  # the double well swings further to one side: only that side reaches the cut
    found = find_clipping(dataclasses.replace(noisy, z=z))
    assert found, "a displacement cut at 90 % of its peak"
    assert {c.channel for c in found} == {"z"}
    for c in found:
        level = z.max() if c.side == "maximum" else z.min()
        assert c.level == level and c.unit == "m"
        assert c.samples <= int(np.sum(z == level)) and c.visits >= 3
        assert c.share == pytest.approx(c.samples / z.size)
        assert "looks clipped" in c.describe() and f"{c.samples} samples" in c.describe()


def test_a_clipped_broadband_force_is_found_on_both_sides(noisy):
    found = find_clipping(dataclasses.replace(noisy, f=_clip(noisy.f, 0.85)))
    assert {(c.channel, c.side) for c in found} == {("f", "maximum"), ("f", "minimum")}


def test_an_uncut_channel_beside_a_cut_one_is_not_named(noisy):
    found = find_clipping(dataclasses.replace(noisy, v=_clip(noisy.v, 0.8)))
    assert {c.channel for c in found} == {"v"}


def test_a_stage_resting_at_the_ends_of_its_travel_is_not_clipped():
    fs, t = 1000.0, np.arange(20_000) / 1000.0
    z = np.empty_like(t)
    for k in range(10):  # moves smoothly between -1 and +1 mm and rests a second at each end
        span = (t >= 2 * k) & (t < 2 * k + 1)
        z[span] = (-1) ** k * np.cos(np.pi * (t[span] - 2 * k)) * -1e-3
        z[(t >= 2 * k + 1) & (t < 2 * k + 2)] = (-1) ** k * 1e-3
    z = 1e-6 * np.round(z / 1e-6)  # an encoder of 1 um: the rests sit exactly at the extremes
    force = np.random.default_rng(0).normal(size=t.size)
    assert find_clipping(Record(f=force, z=z, fs=fs)) == ()


def test_a_force_held_over_several_samples_is_not_clipped():
    rng = np.random.default_rng(1)
    force = np.repeat(rng.normal(size=4000), 5)  # every value repeats five times, the extremes too
    record = Record(f=force, z=np.sin(np.arange(force.size) / 50.0), fs=1000.0)
    assert find_clipping(record) == ()
    held = np.repeat(_clip(rng.normal(size=4000), 0.6), 5)  # the same, cut: each cut value is held too
    assert find_clipping(Record(f=held, z=record.z, fs=1000.0))


def test_a_square_wave_and_a_sine_hit_at_its_crest_are_not_clipped():
    n = np.arange(8000)
    square = np.where((n // 100) % 2 == 0, 1.0, -1.0)
    crest = np.sin(2 * np.pi * n / 40)  # a period of 40 samples: the crest is sampled exactly, 200 times
    assert find_clipping(Record(f=square, z=crest, fs=1000.0)) == ()


def test_an_estimated_channel_is_not_read(noisy):
    record = Record(f=noisy.f, z=noisy.z, fs=noisy.fs).with_derivatives()  # v and a estimated
    cut = dataclasses.replace(record, v=_clip(record.v, 0.5))
    assert find_clipping(cut) == ()


def test_a_structure_names_the_dof(chain_record):
    z = np.array(chain_record.z, copy=True)
    z[:, 1] = _clip(z[:, 1], 0.8)
    found = find_clipping(dataclasses.replace(chain_record, z=z))
    assert {c.channel for c in found} == {"z2"} and {c.unit for c in found} == {"m"}


def test_identify_and_discover_say_so(noisy, tmp_path):
    cut = dataclasses.replace(noisy, z=_clip(noisy.z, 0.85))
    fit = nlid.identify(cut, "z, z^2, z^3, v, v*|v|", "rfs", mass=noisy.mass)
    assert any("channel z looks clipped" in w for w in fit.warnings)
    assert not any("clipped" in w for w in nlid.identify(noisy, "z, z^2, z^3, v, v*|v|", "rfs").warnings)
    result = nlid.discover(cut, ["z", "z^2", "z^3", "v", "v*|v|"], mass=noisy.mass, simulate=False, views=False)
    assert "; but channel z looks clipped at its" in result.stop_reason and "fitting them" in result.stop_reason
    assert result.info["data_warnings"] and "data: channel z looks clipped" in str(result.summary())
    written = write_report(result, tmp_path / "report")
    assert "channel z looks clipped" in next(p for p in written if p.suffix == ".md").read_text(encoding="utf-8")


def test_discover_structure_says_so(chain):
    record = chain.simulate(0, noise=0.01)
    z = np.array(record.z, copy=True)
    z[:, 1] = _clip(z[:, 1], 0.8)
    result = discover_structure(dataclasses.replace(record, z=z), "z3^3", max_steps=1)
    assert "; but channel z2 looks clipped at its" in result.stop_reason
    assert "data: channel z2 looks clipped" in result.summary() and result.info["data_warnings"]


# ------------------------------------------------------------------------------------------------------------ spikes
def _spiked(record, channel: str, where: np.ndarray, size: float, seed: int = 7):
    x = np.array(getattr(record, channel), copy=True)
    x[where] += size * np.std(x) * np.random.default_rng(seed).choice([-1.0, 1.0], where.size)
    return dataclasses.replace(record, **{channel: x})


def test_spikes_in_the_displacement_are_found_where_they_are(noisy):
    where = np.sort(np.random.default_rng(3).choice(np.arange(10, noisy.n - 10), 12, replace=False))
    (found,) = find_spikes(_spiked(noisy, "z", where, 1.0))
    assert found.channel == "z" and found.count == 12 and found.unit == "m"
    assert found.samples == tuple(int(i) for i in where[:5])
    assert found.largest == pytest.approx(np.std(noisy.z), rel=0.1)  # each spike is 1 std, less the noise
    assert "channel z has 12 isolated spikes" in found.describe()


def test_a_spike_in_a_measured_velocity_is_found_and_one_in_the_force_is_not(noisy):
    where = np.array([1000, 5000, 9000])
    # a velocity is rougher than a displacement (its misses: 0.25 std(v) here, 0.024 std(z) for z): a spike must
    # stand out of that, and one of 10 std(v) does
    assert [s.channel for s in find_spikes(_spiked(noisy, "v", where, 10.0))] == ["v"]
    assert find_spikes(_spiked(noisy, "f", where, 10.0)) == ()  # a blow is a real one-sample pulse of force


def test_small_spikes_kinks_and_steps_are_not_spikes(noisy):
    assert find_spikes(_spiked(noisy, "z", np.array([1000, 5000, 9000]), 0.1)) == ()  # within the noise's reach
    t = np.arange(4000) / 1000.0
    kinks = np.abs(np.sin(2 * np.pi * 3 * t))  # an impact reversing the velocity at every zero
    steps = np.where(np.sin(2 * np.pi * 3 * t) > 0, 1.0, -1.0) + 0.01 * t  # a velocity that jumps
    assert find_spikes(Record(f=np.sin(t), z=kinks, v=steps, fs=1000.0)) == ()


def test_a_structure_names_the_dof_of_a_spike(chain_record):
    z = np.array(chain_record.z, copy=True)
    z[[500, 2500], 2] += 2 * np.std(z[:, 2])
    (found,) = find_spikes(dataclasses.replace(chain_record, z=z))
    assert found.channel == "z3" and found.count == 2


def test_identify_and_discover_say_a_spike(noisy):
    spiked = _spiked(noisy, "z", np.array([1000, 3000, 5000, 7000, 9000]), 2.0)
    fit = nlid.identify(spiked, "z, z^2, z^3, v, v*|v|", "rfs", mass=noisy.mass)
    assert any("channel z has 5 isolated spikes" in w for w in fit.warnings)
    result = nlid.discover(spiked, ["z", "z^2", "z^3", "v", "v*|v|"], mass=noisy.mass, simulate=False, views=False)
    assert "; but channel z has 5 isolated spikes" in result.stop_reason


def test_despike_repairs_what_the_spikes_biased_and_says_so(noisy, chain_record):
    assert despike(noisy) is noisy
    where = np.array([1000, 3000, 5000, 7000, 9000])
    spiked = _spiked(noisy, "z", where, 2.0)
    repaired = despike(spiked)
    assert find_spikes(repaired) == () and repaired.meta["despiked"] == {"z": [int(i) for i in where]}
    terms = "z, z^2, z^3, v, v*|v|"
    clean, hit, mended = (
        nlid.identify(r, terms, "rfs", mass=noisy.mass).coefficients for r in (noisy, spiked, repaired)
    )
    for term in ("z^2", "z^3"):  # back to the clean record's fit, from an error several times larger
        assert abs(mended[term] - clean[term]) < 0.1 * abs(hit[term] - clean[term])
    z = np.array(chain_record.z, copy=True)
    z[[500, 2500], 2] += 2 * np.std(z[:, 2])
    repaired = despike(dataclasses.replace(chain_record, z=z))
    assert repaired.meta["despiked"] == {"z3": [500, 2500]}
    assert np.max(np.abs(repaired.z - chain_record.z)) < 0.1 * np.std(chain_record.z[:, 2])


def _quantised(record, fraction: float):
    """Every channel rounded to ``fraction`` of the std of its group (a coarse converter, a CSV of few digits)."""
    rounded = {}
    for group in record.groups:
        x = np.asarray(getattr(record, group))
        quantum = fraction * np.std(x)
        rounded[group] = quantum * np.round(x / quantum)
    return dataclasses.replace(record, **rounded)


@pytest.mark.parametrize("fraction", [0.1, 0.01, 0.001])
def test_quantised_records_have_no_glitch(noisy, well_record, fraction):
    # a one-quantum toggle is not a spike; the extreme level of a coarse converter is not a cut
    assert find_glitches(_quantised(noisy, fraction)) == ()
    assert find_glitches(_quantised(well_record, fraction)) == ()


def _periodic(seed: int, band: int, noise: float, quantum: float) -> Record:
    """Six periods of 1024 samples of a random-phase multisine (lines 5 to ``band``), noisy and quantised."""
    rng = np.random.default_rng(seed)
    spectrum = np.zeros(513, complex)
    spectrum[5:band] = np.exp(2j * np.pi * rng.random(band - 5))
    one = np.fft.irfft(spectrum, 1024)
    x = np.tile(one / np.std(one), 6) + noise * rng.normal(size=6 * 1024)
    return Record(f=x, z=quantum * np.round(x / quantum), fs=1000.0, meta={"periodic": 1024})


def test_a_periodic_crest_is_one_visit_but_a_cut_period_is_not():
    # a crest that every period repeats at the channel's extreme level: three visits in motion, but at one
    # place of the period (found on one of ten seeds when the record does not say it is periodic)
    record = _periodic(1, 200, 0.01, 0.03)
    assert [c.side for c in find_clipping(dataclasses.replace(record, meta={}))] == ["minimum"]
    assert find_clipping(record) == ()
    smooth = _periodic(5, 50, 0.0, 0.01)  # sampled ten times its band
    assert find_clipping(smooth) == ()
    cut = dataclasses.replace(smooth, z=_clip(smooth.z, 0.6))  # several crests of each period cut
    assert {c.side for c in find_clipping(cut)} == {"maximum", "minimum"}


def test_a_search_checks_the_record_once(noisy, monkeypatch):
    # discover fits its parts hundreds of times; none of those fits checks its part again (the search checks
    # the whole record once, by its own call)
    from nlid.signal import glitches

    calls = []
    real = glitches.find_glitches
    monkeypatch.setattr(glitches, "find_glitches", lambda record: calls.append(record.n) or real(record))
    nlid.discover(noisy, ["z", "z^2", "z^3", "v", "v*|v|"], mass=noisy.mass, simulate=False, views=False)
    assert calls == []
    with glitches.reported_by_caller():
        assert glitches.glitch_warnings(dataclasses.replace(noisy, z=_clip(noisy.z, 0.8))) == []
    assert glitches.glitch_warnings(dataclasses.replace(noisy, z=_clip(noisy.z, 0.8)))
