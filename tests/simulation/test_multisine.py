"""The Bouc-Wen benchmark's training test regenerated in Python (issue 35, item 5): multisine, system, record."""

from __future__ import annotations

import numpy as np
import pytest

import nlid
from nlid.errors import InputError
from nlid.simulation.multisine import multisine_period
from nlid.simulation.presets import get_preset


def test_a_multisine_period_is_flat_over_its_lines_with_its_rms_and_phases():
    rng = np.random.default_rng(7)
    phases = rng.uniform(0, 2 * np.pi, 100)
    x = multisine_period(1024, (20, 119), 3.0, phases)
    spectrum = np.fft.rfft(x)
    amplitude = np.abs(spectrum)
    lines = np.arange(20, 120)
    assert np.std(x) == pytest.approx(3.0, rel=1e-12)
    np.testing.assert_allclose(amplitude[lines], amplitude[lines][0], rtol=1e-9)
    assert np.delete(amplitude, lines).max() < 1e-9 * amplitude[lines][0]
    np.testing.assert_allclose(np.angle(spectrum[lines] * np.exp(-1j * phases)), 0.0, atol=1e-9)
    with pytest.raises(InputError, match="one phase per line"):
        multisine_period(1024, (20, 119), 3.0, phases[:10])


@pytest.fixture(scope="module")
def realisation():
    return get_preset("bouc-wen-multisine").simulate(3, channels=("z",))


def test_the_multisine_preset_is_the_benchmark_excitation_in_periodic_steady_state(realisation):
    record = realisation
    spec = get_preset("bouc-wen-multisine").multisine
    period = spec["period"]
    assert record.n == period * spec["periods"] and record.fs == 750.0 and record.meta["periodic"] == period
    assert record.force_hold == "sampled" and np.std(record.f) == pytest.approx(50.0, rel=1e-9)
    first, last = np.fft.rfftfreq(period, 1 / 750.0)[list(spec["lines"])]
    assert 4.9 < first < 5.0 and 150.0 < last < 150.1  # the benchmark's 5-150 Hz
    z = record.z.reshape(spec["periods"], period)
    # the transient is gone: every period repeats the last to a small fraction of the response
    assert np.max(np.abs(z - z[-1])) < 1e-3 * np.std(record.z)
    other = get_preset("bouc-wen-multisine").force(4)
    assert not np.allclose(other, record.f)  # another seed, another realisation


def test_the_preset_regenerates_train_multisine_to_its_noise(data_dir):
    """The published system and excitation (the file's phases) give the file's displacement to its own noise."""
    measured = nlid.load("dataset:bouc-wen")
    generated = get_preset("bouc-wen-train").simulate(0, channels=("z",))
    # the file's force is the flat multisine to about 1e-5 of its RMS (a few samples off by 5e-4 N)
    np.testing.assert_allclose(generated.f, measured.f, atol=2e-5 * np.std(measured.f))
    periods = measured.z.reshape(5, -1)
    noise = np.std(periods[1:] - periods[:-1]) / np.sqrt(2)  # the record's output noise, from its periods
    error = np.sqrt(np.mean((generated.z - measured.z) ** 2))
    assert error < 1.2 * noise, (error, noise)


def test_the_length_of_a_multisine_preset_is_its_periods():
    with pytest.raises(InputError, match="a multisine record is 5 periods of 8192 samples"):
        get_preset("bouc-wen-multisine").with_overrides(duration=10.0)
