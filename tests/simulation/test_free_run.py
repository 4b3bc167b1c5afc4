"""simulate.free_run: the response to a measured (sampled) force between the samples."""

from __future__ import annotations

import numpy as np
import pytest

from nlid.errors import InputError
from nlid.model.terms import Model
from nlid.simulation import free_run, simulate


def test_a_held_force_matches_simulate():
    model = Model.from_spec("z^3", defaults=True)
    coeffs = {"z": 2000.0, "z^3": 1e6, "v": 2.0, "1": 0.0}
    force = np.random.default_rng(0).standard_normal(2048) * 10
    z1, _, _ = simulate(model, coeffs, 0.2, force, 1024.0)
    z2, _, _ = free_run(model, coeffs, 0.2, force, 1024.0, force_hold="zoh", oversample=1)
    z3, _, _ = free_run(model, coeffs, 0.2, force, 1024.0, force_hold="zoh", oversample=8)
    assert np.array_equal(z1, z2)
    assert np.max(np.abs(z3 - z1)) < 1e-3 * np.max(np.abs(z1))  # RK4 with finer steps, same held force


def test_a_sampled_sine_gives_the_analytical_steady_state():
    m, k, c, fs, f0 = 0.2, 2000.0, 2.0, 200.0, 20.0  # 10 samples per period, fn = 15.9 Hz
    model = Model.from_spec("z, v", defaults=False)
    t = np.arange(int(20 * fs)) / fs
    force = np.sin(2 * np.pi * f0 * t)
    w = 2 * np.pi * f0
    h = 1.0 / (k - m * w**2 + 1j * c * w)
    steady = np.abs(h) * np.sin(w * t + np.angle(h))
    late = t > 10.0  # the transient (time constant m / c = 0.1 s) has died away
    z, _, _ = free_run(model, {"z": k, "v": c}, m, force, fs)
    err = np.max(np.abs(z[late] - steady[late])) / np.abs(h)
    held, _, _ = simulate(model, {"z": k, "v": c}, m, force, fs)
    err_held = np.max(np.abs(held[late] - steady[late])) / np.abs(h)
    assert err < 2e-3 < 0.1 < err_held  # holding each sample delays the force by half a sample


def test_bad_arguments():
    model = Model.from_spec("z", defaults=False)
    with pytest.raises(InputError, match="oversample"):
        free_run(model, {"z": 1.0}, 1.0, np.ones(64), 100.0, oversample=0)
    with pytest.raises(InputError, match="force_hold"):
        free_run(model, {"z": 1.0}, 1.0, np.ones(64), 100.0, force_hold="foh")
