"""Fixtures shared by the identifier plugins' tests."""

from __future__ import annotations

import numpy as np
import pytest

from nlid import Record

#: The noise case of the issue: 2 % of each signal's standard deviation on z and a, velocity estimated.
NOISE = {"z": 0.02, "a": 0.02}


@pytest.fixture(scope="session")
def noisy_records(numerical):
    """paper-numerical, seeds 0-4, 2 % noise on z and a (no velocity channel)."""
    return [numerical.simulate(seed, noise=NOISE, channels=("z", "a")) for seed in range(5)]


@pytest.fixture(scope="session")
def constant_speed_record():
    """A positioning-stage-like record whose speed is almost always 0.1 m/s.

    The velocity is a smoothed square wave, so sign(v), v and v*|v| are nearly
    proportional (the near-collinear case of the issue). Channels are exact:
    ``f = 95 a + 200 v + 20 sign(v) + 50 v|v|``.
    """
    fs = 1000.0
    t = np.arange(0.0, 20.0, 1.0 / fs)
    v = 0.1 * np.tanh(np.sin(2 * np.pi * 0.5 * t) / 0.02)
    z = np.cumsum(v) / fs
    a = np.gradient(v, 1.0 / fs)
    f = 95.0 * a + 200.0 * v + 20.0 * np.sign(v) + 50.0 * v * np.abs(v)
    return Record(f=f, z=z, v=v, a=a, fs=fs)
