"""Duffing (hardening): the textbook backbone, harmonic convergence, folds, stability and jumps, in time too."""

from __future__ import annotations

import numpy as np
import pytest

from nlid.response import backbone
from nlid.response.backbone import duffing_exact, duffing_frequency

OMEGA0, BETA = 100.0, 5e9  # rad/s, k3/m


def test_one_harmonic_reproduces_the_textbook_backbone(duffing):
    b = backbone(duffing, 2e-3, harmonics=1)[0]
    w = 2 * np.pi * b.frequency_hz
    assert b.amplitude().max() >= 2e-3
    assert np.max(np.abs(w - duffing_frequency(OMEGA0, BETA, b.amplitude())) / w) < 1e-12


def test_more_harmonics_converge_to_the_exact_backbone(duffing):
    errors = []
    for h in (1, 3, 5, 7):
        b = backbone(duffing, 2e-3, harmonics=h, truncation=None)[0]
        w = 2 * np.pi * b.frequency_hz
        errors.append(np.max(np.abs(w - duffing_exact(OMEGA0, BETA, b.peak())) / w))
    assert errors[0] > 1e-3  # one harmonic is off by its known O(eps) amount at this amplitude
    assert all(b < a / 10 for a, b in zip(errors, errors[1:], strict=False))
    assert errors[-1] < 1e-5


@pytest.fixture(scope="module")
def response(duffing):
    return duffing.frequency_response(1.0, (12, 28), harmonics=7, backbone=False)


def test_two_folds_and_unstable_between_them(response):
    (curve,) = response.curves
    folds = curve.folds
    assert [e.kind for e in folds] == ["fold", "fold"]
    high, low = sorted(folds, key=lambda e: -e.frequency_hz)
    assert 22 < high.frequency_hz < 25 and 17 < low.frequency_hz < 19
    inside = np.arange(len(curve))[(np.arange(len(curve)) > high.index) & (np.arange(len(curve)) < low.index)]
    assert inside.size and not curve.stable[inside].any()
    outside = np.r_[np.arange(high.index), np.arange(low.index + 1, len(curve))]
    assert curve.stable[outside].all()
    # a slow sweep up leaves the upper branch at the upper fold; down, the lower one at the lower fold
    up, down = curve.sweep("up"), curve.sweep("down")
    assert curve.frequency_hz[up[np.argmax(np.diff(up))]] == pytest.approx(high.frequency_hz)
    assert curve.frequency_hz[down[np.argmax(np.abs(np.diff(down)))]] == pytest.approx(low.frequency_hz)


def test_stable_points_agree_with_time_integration_and_unstable_ones_are_left(response):
    checked = response.verify(points=4, unstable=2)
    assert checked.max_error_percent < 0.5
    assert checked.unstable_reached == 0 and all(c.settled for c in checked.checks)


@pytest.mark.slow
def test_swept_sines_jump_at_the_folds(response):
    checked = response.verify(points=1, unstable=0, sweep_rate=0.05)
    assert {s.direction for s in checked.sweeps} == {"up", "down"}
    for s in checked.sweeps:
        assert abs(s.difference_percent) < 1.0, s
