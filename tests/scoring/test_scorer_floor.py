"""The scorer is finer than the models it ranks: the true model of a record scores at the record's noise floor.

The records are driven by a *sampled* band-limited force (``force_hold="sampled"``: a sum of
sines, known at every instant), the case where the free run needs the force between the
samples (:func:`nlid.simulation.fine_force`). The reference response is integrated at
:data:`Q` sub-steps per sample from the sines' exact values, not through ``fine_force``.

The noise floor of a rule is the RMS of the output noise on the samples it scores (all of them
from the first sample and in periodic steady state; those after the window with an
initialisation window). The noise is small, 1e-4 of ``std(z)``, so that the test sees the
scorer's own error: with scipy's default interpolation filter, nlid's before issue 31, the truth
scores 38 to 180 times the floor here; with the midpoint values of the force held over each
sub-step (no compensation for the hold), 3 to 6 times.
"""

from __future__ import annotations

import numpy as np
import pytest

from nlid import scoring
from nlid.data.record import Record
from nlid.identified.model import IdentifiedModel
from nlid.identified.reference import true_model
from nlid.model.terms import Model
from nlid.simulation import fine_force, simulate

FS = 500.0
Q = 64  # sub-steps per sample of the reference response
NOISE = 1e-4  # of std(z) and std(v)
TRUTH = {"z": 2e4, "v": 5.0, "z^3": 2e9, "v*|v|": 0.2}  # fn 32 Hz, zeta 2.5 %: the start-up error fades in 0.2 s
MASS = 0.5
#: Largest departure of the true model's RMSE from the floor: the scorer's own error is at most a fifth of the
#: noise (RMSE^2 = floor^2 + error^2), with room for the chance correlation of the two over the scored samples.
RATIO = 0.02


@pytest.fixture(scope="module")
def truth() -> IdentifiedModel:
    return IdentifiedModel(Model.from_spec(list(TRUTH), defaults=False), TRUTH, MASS, "truth")


def _sines(t: np.ndarray, lines: tuple, hold: int | None = None) -> np.ndarray:
    """The force at times ``t`` (s); with ``hold`` sub-steps per sample, the held values of unit gain."""
    freqs, amps, phases = lines
    gain = amps if hold is None else amps / np.sinc(freqs / (FS * hold))
    return np.cos(2 * np.pi * np.multiply.outer(t, freqs) + phases) @ gain


def _record(lines: tuple, n: int, rng: np.random.Generator, *, fade: float = 0.0, keep: int | None = None) -> tuple:
    """The true response to the sines (faded in over ``fade`` s after 50 samples of rest), its last ``keep``
    samples with noise on z and v, and the RMS of the noise added to z."""
    envelope = (lambda t: 0.5 - 0.5 * np.cos(np.pi * np.clip((t - 50 / FS) / fade, 0.0, 1.0))) if fade else None
    t_mid = (np.arange(n * Q) + 0.5) / (FS * Q)
    held = _sines(t_mid, lines, Q) * (envelope(t_mid) if envelope else 1.0)
    z, v, _ = simulate(Model.from_spec(list(TRUTH), defaults=False), TRUTH, MASS, held, FS * Q)
    t = np.arange(n) / FS
    f = _sines(t, lines) * (envelope(t) if envelope else 1.0)
    keep = keep or n
    z, v, f = z[::Q][-keep:], v[::Q][-keep:], f[-keep:]
    noise = NOISE * np.std(z) * rng.standard_normal(keep)
    record = Record(
        f=f,
        z=z + noise,
        v=v + NOISE * np.std(v) * rng.standard_normal(keep),
        fs=FS,
        meta={"force_hold": "sampled", "mass": MASS},
    )
    return record, noise


def _floor(noise: np.ndarray, first: int = 0) -> float:
    return float(np.sqrt(np.mean(noise[first:] ** 2)))


@pytest.fixture(scope="module")
def from_rest():
    """A record that starts at rest: 60 sines at random frequencies (2-150 Hz, 0.6 Nyquist; not periodic)."""
    rng = np.random.default_rng(31)
    k = 60
    lines = (rng.uniform(2.0, 150.0, k), rng.uniform(0.5, 1.0, k), rng.uniform(0, 2 * np.pi, k))
    return _record(lines, 5000, rng, fade=0.3)


@pytest.fixture(scope="module")
def steady():
    """Two periods of a random-phase odd multisine (period 1000 samples, every other odd line from 2 to 150 Hz)
    after two settled ones (the start-up transient has fallen by e^-20)."""
    rng = np.random.default_rng(32)
    period = 1000
    bins = np.arange(5, int(150 * period / FS) + 1, 4)
    lines = (bins * FS / period, np.full(bins.size, 1.0), rng.uniform(0, 2 * np.pi, bins.size))
    return _record(lines, 4 * period, rng, keep=2 * period)


@pytest.mark.parametrize("rule, first", [("first-sample", 0), ("window:200", 200)])
def test_the_true_model_scores_the_noise_floor_of_a_record_from_rest(truth, from_rest, rule, first):
    record, noise = from_rest
    run = scoring.free_run_error(truth, record, rule)
    assert run.computed and run.scored_samples == record.n - first, run.note
    assert run.rmse / _floor(noise, first) == pytest.approx(1.0, abs=RATIO), run.rule


@pytest.mark.parametrize("keep", [2000, 1500])  # whole periods (interpolated by the FFT), and not
def test_the_true_model_scores_the_noise_floor_in_periodic_steady_state(truth, steady, keep):
    record, noise = steady
    run = scoring.free_run_error(truth, record[-keep:], "periodic:1000")
    assert run.computed and run.scored_samples == keep, run.note
    assert "not settled" not in run.rule
    assert run.rmse / _floor(noise[-keep:]) == pytest.approx(1.0, abs=RATIO), run.rule


def test_the_true_model_of_a_simulated_record_comes_with_it():
    import nlid

    record = nlid.simulate("paper-numerical", seed=2, duration=2.0)
    fit = true_model(record)
    assert fit is not None and fit.method == "true model"
    assert dict(fit.coefficients) == pytest.approx(record.meta["reference"]["coefficients"])
    # noise-free, held force: what is left is the preset's one RK4 step per sample against the scorer's 8
    assert fit.score(record, rule="first-sample").freerun_rmse < 1e-4 * np.std(record.z)
    measured = record.replace(meta={k: v for k, v in record.meta.items() if k != "preset"})
    assert true_model(measured) is None  # a measured record's reference is published values, not its generator


def test_held_values_carry_the_band_with_unit_gain_and_stages_the_force_itself():
    """The interpolator against the sines' exact values, away from the record's ends (2e-6: its ripple)."""
    rng = np.random.default_rng(5)
    lines = (rng.uniform(1.0, 0.4 * FS, 40), rng.uniform(0.5, 1.0, 40), rng.uniform(0, 2 * np.pi, 40))
    n, q = 2000, 8
    f = _sines(np.arange(n) / FS, lines)
    scale = np.abs(lines[1]).sum()
    inner = slice(100 * q, (n - 100) * q)
    held = fine_force(f, "sampled", q)
    assert np.max(np.abs(held - _sines((np.arange(n * q) + 0.5) / (FS * q), lines, q))[inner]) < 1e-5 * scale
    stages = fine_force(f, "sampled", q, stages=True)
    inner = slice(100 * 2 * q, (n - 100) * 2 * q)
    assert np.max(np.abs(stages - _sines(np.arange(2 * n * q) / (2 * q * FS), lines))[inner]) < 1e-5 * scale
    assert np.array_equal(fine_force(f, "zoh", q), np.repeat(f, q))  # a held force stays held


def test_whole_periods_are_interpolated_exactly():
    period, q = 256, 8
    bins = np.arange(1, 100)
    lines = (bins * FS / period, np.ones(bins.size), np.random.default_rng(6).uniform(0, 2 * np.pi, bins.size))
    f = _sines(np.arange(2 * period) / FS, lines)
    held = fine_force(f, "sampled", q, periodic=True)
    exact = _sines((np.arange(2 * period * q) + 0.5) / (FS * q), lines, q)
    assert np.max(np.abs(held - exact)) < 1e-9 * bins.size
    assert np.allclose(fine_force(f[:period], "sampled", q, periodic=True), held[: period * q], atol=1e-9 * bins.size)
