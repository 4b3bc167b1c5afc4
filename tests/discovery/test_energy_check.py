"""The energy check of discover (``injects_energy``): dissipative laws pass, a law that turns over just beyond the data
does not."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from nlid.discovery import trials
from nlid.model.terms import Model


def _stage(coefficients: dict[str, float]) -> SimpleNamespace:
    """What ``injects_energy`` reads of a fitted stage: the model and its coefficients (in the model's order)."""
    model = Model.from_spec(", ".join(coefficients), defaults=False)
    theta = np.array([coefficients[t.name] for t in model.terms])
    return SimpleNamespace(model=model, identified=SimpleNamespace(theta=theta))


def _trajectory() -> tuple[np.ndarray, np.ndarray]:
    """A noisy two-tone motion around an offset equilibrium (the samples the check widens)."""
    rng = np.random.default_rng(3)
    t = np.linspace(0.0, 2.0, 4001)
    z = -0.001 + 0.006 * np.sin(2 * np.pi * 15 * t) + 0.002 * np.sin(2 * np.pi * 41 * t + 1.0)
    v = np.gradient(z, t) + 0.01 * rng.standard_normal(t.size)
    return z, v


DECLARED = {"1": 1.96, "z": 2000.0, "z^3": 5e6, "v": 2.0}


@pytest.mark.parametrize(
    "law", [{"v*|v|": 3.0}, {"sign(v)": 2.0}, {"z^2*v": 5e4}, {"v^3": 1.0, "|z|*sign(v)": 300.0}], ids=str
)
def test_a_dissipative_law_with_a_positive_coefficient_is_never_refused(law):
    z, v = _trajectory()
    assert trials.injects_energy(_stage({**DECLARED, **law}), _stage(DECLARED), z, v) == ""


def test_a_law_that_turns_over_just_beyond_the_data_is_refused(monkeypatch):
    """``c v - d v^3`` dissipates up to ``sqrt(c / d)``: placed between the data's top speed and the widened one."""
    z, v = _trajectory()
    top = float(np.max(np.abs(v)))
    turn = 0.5 * (1.0 + trials.INJECTING_RANGE) * top  # beyond every sample, within the widened ones
    c = 2.0
    fit = _stage({**DECLARED, "v": c, "v^3": -c / turn**2})
    assert trials._injecting_share(fit, z, v) == 0.0  # dissipates on every estimation sample
    assert "feeds energy into the motion" in trials.injects_energy(fit, _stage(DECLARED), z, v)
    monkeypatch.setattr(trials, "INJECTING_RANGE", 1.0)  # unwidened, the same law passes
    assert trials.injects_energy(fit, _stage(DECLARED), z, v) == ""


@pytest.mark.parametrize("law", [{"v*|v|": -3.0}, {"sign(v)": -2.0}, {"z^2*v": -5e4}], ids=str)
def test_the_same_law_with_the_wrong_sign_is_refused(law):
    z, v = _trajectory()
    assert "feeds energy into the motion" in trials.injects_energy(_stage({**DECLARED, **law}), _stage(DECLARED), z, v)
