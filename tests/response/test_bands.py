"""Posterior bands: built per frequency where the draws agree on the stable solutions, unresolved elsewhere."""

from __future__ import annotations

import numpy as np
import pytest

from nlid.errors import InputError
from nlid.response.bands import response_band, stable_amplitudes


class Draws:
    """A posterior stand-in: the truth's coefficients with a spread on the cubic one."""

    def __init__(self, fit, spread: float, n: int = 6):
        self.model, self.mass = fit.model, fit.mass
        rng = np.random.default_rng(3)
        theta = np.tile(fit.theta, (n, 1))
        k = fit.model.index("z^3")
        theta[:, k] *= 1 + spread * rng.standard_normal(n)
        self._theta = theta

    def full_samples(self, draws=None, rng=None):
        return self._theta[: draws or len(self._theta)]


@pytest.fixture(scope="module")
def response(duffing):
    return duffing.frequency_response(1.0, (15, 26), backbone=False, settings=None)


def test_identical_draws_give_a_band_of_no_width_that_covers_the_truth(duffing, response):
    band = response_band(response, Draws(duffing, 0.0, 3), draws=3, jobs=1, grid=60).curves[0]
    assert band.resolved.all()
    ok = np.isfinite(band.low)
    assert np.allclose(band.low[ok], band.high[ok], rtol=1e-6)
    assert response_band(response, Draws(duffing, 0.0, 3), draws=3, jobs=1, grid=60).coverage(response) == [1.0]


def test_draws_that_jump_at_different_frequencies_leave_them_unresolved(duffing, response):
    result = response_band(response, Draws(duffing, 0.05, 6), draws=6, jobs=1, grid=120)
    band = result.curves[0]
    ranges = band.unresolved_ranges()
    assert ranges and not band.resolved.all() and band.resolved.any()
    folds = sorted(e.frequency_hz for e in response.curves[0].folds)
    assert any(lo - 0.5 <= folds[0] <= hi + 0.5 for lo, hi in ranges)  # near the jump down
    assert (band.count[band.resolved] >= 1).all()
    assert np.all(band.low[0][band.resolved] <= band.high[0][band.resolved])


def test_stable_amplitudes_are_multivalued_inside_the_hysteresis(response):
    grid = np.array([16.0, 21.0, 25.9])
    counts = [len(a) for a in stable_amplitudes(response.curves[0], grid, 0)]
    assert counts == [1, 2, 1]


def test_bad_arguments_are_refused(duffing, response):
    with pytest.raises(InputError, match="level="):
        response_band(response, Draws(duffing, 0.0), level=1.5)
    with pytest.raises(InputError, match="posterior="):
        response_band(response, object())
