"""The simulator's force hold: zero-order hold, or linear interpolation for a sampled continuous force."""

import numpy as np
import pytest

from nlid import InputError
from nlid.simulate import simulate
from nlid.terms import Model


def test_linear_hold_follows_a_sampled_continuous_force():
    """A sampled sine drives a linear oscillator: linear interpolation tracks the continuous answer, a hold lags."""
    model = Model.from_spec("", without="1")
    coeffs = {"z": 400.0, "v": 2.0}
    fs, fine = 200.0, 20
    t = np.arange(4000) / fs
    t_fine = np.arange(4000 * fine) / (fs * fine)
    force = lambda tt: np.sin(2 * np.pi * 3.0 * tt) + 0.5 * np.sin(2 * np.pi * 7.0 * tt)  # noqa: E731
    reference, _, _ = simulate(model, coeffs, 1.0, force(t_fine), fs * fine, hold="linear")
    reference = reference[::fine]
    errors = {}
    for hold in ("zoh", "linear"):
        z, _, _ = simulate(model, coeffs, 1.0, force(t), fs, hold=hold)
        errors[hold] = np.sqrt(np.mean((z - reference) ** 2)) / reference.std()
    assert errors["linear"] < 1e-3 < errors["zoh"]
    with pytest.raises(InputError, match="hold must be"):
        simulate(model, coeffs, 1.0, force(t), fs, hold="cubic")
