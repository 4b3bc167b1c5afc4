"""The input path (nlid.estimation.inputpath): the force that acts, exactly, and applied the same way everywhere."""

from __future__ import annotations

import numpy as np
import pytest

import nlid
from nlid.errors import InputError
from nlid.estimation.inputpath import InputPath, acting_record, input_path


def _tones(n: int, fs: float, shift: float = 0.0) -> np.ndarray:
    t = np.arange(n) / fs - shift
    return np.sin(2 * np.pi * 3.0 * t) + 0.5 * np.sin(2 * np.pi * 7.0 * t + 1.0)


def test_a_periodic_band_limited_force_is_delayed_and_lagged_exactly():
    fs, n = 100.0, 1000  # whole periods of both tones
    f = _tones(n, fs)
    delayed = InputPath(delay=0.0137).acting_force(f, fs, "sampled", period=n)
    assert np.max(np.abs(delayed - _tones(n, fs, 0.0137))) < 1e-12
    tau = 0.02
    lagged = InputPath(lag=tau).acting_force(f, fs, "sampled", period=n)
    t = np.arange(n) / fs
    expected = np.zeros(n)
    for freq, amp, phase in ((3.0, 1.0, 0.0), (7.0, 0.5, 1.0)):
        h = 1.0 / (1.0 + 2j * np.pi * freq * tau)
        expected += amp * np.abs(h) * np.sin(2 * np.pi * freq * t + phase + np.angle(h))
    assert np.max(np.abs(lagged - expected)) < 1e-12


def test_a_record_that_is_not_periodic_is_delayed_to_its_band_away_from_its_ends():
    fs, n = 100.0, 2000
    got = InputPath(delay=0.0137).acting_force(_tones(n, fs), fs, "sampled")
    error = np.abs(got - _tones(n, fs, 0.0137))
    assert np.max(error[50:-50]) < 1e-4  # the ends are continued by reflection, not known
    assert np.max(error[200:-200]) < 5e-5


def test_a_held_force_keeps_its_staircase():
    rng = np.random.default_rng(3)
    f = rng.normal(size=200)
    assert np.array_equal(InputPath(delay=0.03).acting_force(f, 100.0, "zoh")[3:], f[:-3])
    shared = InputPath(delay=0.025).acting_force(f, 100.0, "zoh")  # half a sample: each interval shared
    assert np.allclose(shared[3:], 0.5 * f[1:-2] + 0.5 * f[:-3])
    # a lag: each interval's mean of the exact first-order response to the staircase (fine integration)
    tau, q = 0.05, 2000
    a = np.exp(-1.0 / (100.0 * q * tau))
    y, state = np.empty(200 * q), f[0]
    for i, u in enumerate(np.repeat(f, q)):
        y[i] = state
        state = a * state + (1 - a) * u
    mean = 0.5 * (y + np.append(y[1:], state)).reshape(200, q).mean(axis=1)
    assert np.max(np.abs(InputPath(lag=tau).acting_force(f, 100.0, "zoh") - mean)) < 1e-6


def test_spellings_dictionaries_and_refusals():
    path = InputPath.from_spec("delay=3ms, lag=2 samples", fs=1000.0)
    assert path == InputPath(delay=0.003, lag=0.002)
    assert InputPath.from_spec(path.to_spec()) == path
    assert InputPath.from_dict(path.to_dict()) == path
    assert input_path(None).identity and input_path({"delay": 0.001}).delay == 0.001
    assert "3 ms" in path.describe() and InputPath().describe() == "as recorded"
    assert "ahead of the force channel" in InputPath(delay=-0.002).describe()  # the force channel is the late one
    for bad in ("lag=-1ms", "delay=abc", "speed=3", "delay=1 parsec", "delay=1ms, delay=2ms", "hold=cubic"):
        with pytest.raises(InputError):
            InputPath.from_spec(bad, fs=1000.0)
    with pytest.raises(InputError, match="samples need the sampling frequency"):
        InputPath.from_spec("delay=2 samples")
    with pytest.raises(InputError, match="at most"):
        InputPath(delay=10.0).acting_force(np.zeros(100), 1000.0, "sampled")


@pytest.fixture(scope="module")
def delayed_case(numerical):
    """paper-numerical (held force) whose force channel leads the acting force by 3 samples."""
    record = numerical.with_overrides(duration=12.0).simulate(2, noise={"z": 0.01, "a": 0.01}, channels=("z", "a"))
    m = 3
    shifted = nlid.Record(f=record.f[m:], z=record.z[:-m], a=record.a[:-m], fs=record.fs, meta=dict(record.meta))
    return record, shifted, m / record.fs


def test_identify_through_the_path_is_identify_of_the_aligned_record(delayed_case):
    record, shifted, delay = delayed_case
    terms = "z^3, z^2, v*|v|"
    aligned = nlid.identify(record[: shifted.n], terms, method="rfs", mass=0.2)
    through = nlid.identify(shifted, terms, method="rfs", mass=0.2, input_path=f"delay={delay}")
    plain = nlid.identify(shifted, terms, method="rfs", mass=0.2)
    assert through.input_path.delay == pytest.approx(delay)
    for name in aligned.terms:
        assert through.coefficients[name] == pytest.approx(aligned.coefficients[name], rel=0.02, abs=1e-9)
    assert through.eps_percent < 0.5 * plain.eps_percent
    # the JSON keeps the path, and every score applies it
    again = nlid.IdentifiedModel.from_dict(through.to_dict())
    assert again.input_path == through.input_path
    assert again.score(shifted, free_run=False).eps_percent == pytest.approx(through.eps_percent, rel=1e-9)


def test_applying_a_path_twice_is_applying_it_once(delayed_case):
    _, shifted, delay = delayed_case
    fit = nlid.identify(shifted, "z^3, z^2, v*|v|", method="rfs", mass=0.2, input_path=f"delay={delay}")
    once = acting_record(fit, shifted)
    assert acting_record(fit, once) is once
    assert acting_record(fit, shifted) is once  # made once per record and path
    assert not np.array_equal(once.f, shifted.f) and np.array_equal(once.z, shifted.z)


def test_discover_finds_an_undeclared_delay_and_the_prediction_improves(delayed_case):
    _, shifted, delay = delayed_case
    found = nlid.discover(shifted, "1, z, z^2, z^3, v, v*|v|", "rfs", mass=0.2, views=False, max_steps=2)
    effects = [s.effect for s in found.steps]
    assert "input-delay" in effects, found.stop_reason
    step = found.steps[effects.index("input-delay")]
    assert step.after.path.delay == pytest.approx(delay, rel=0.1)
    assert step.after.prediction.pooled < step.before.prediction.pooled
    assert found.to_dict()["input_path"]["delay_s"] == pytest.approx(delay, rel=0.1)
