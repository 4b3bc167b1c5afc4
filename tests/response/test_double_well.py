"""The paper's double well: a curve per well, in-well and cross-well motion labelled, stability checked in time."""

from __future__ import annotations

import numpy as np
import pytest


@pytest.fixture(scope="module")
def strong(double_well):
    """8 N from 8 to 30 Hz: in-well in each well, cross-well from the right one, folds and period doublings."""
    return double_well.frequency_response(8.0, (8, 30), harmonics=15)


def test_a_curve_per_stable_equilibrium(double_well, strong):
    starts = sorted(c.start[0] for c in strong.curves)
    assert starts == pytest.approx(sorted(double_well.equilibria.stable))


def test_in_well_and_cross_well_motion_is_labelled(strong, double_well):
    saddle = double_well.equilibria.unstable[0]
    seen = set()
    for c in strong.curves:
        lo, hi = c.extremes()
        for label, a, b in zip(c.labels, lo, hi, strict=True):
            seen.add(label.split(" ")[0])
            assert (label == "cross-well") == (a < saddle < b)
    assert seen == {"in-well", "cross-well"}
    right = next(c for c in strong.curves if c.start[0] > saddle)
    assert any(lab == "cross-well" and s for lab, s in zip(right.labels, right.stable, strict=True))


def test_backbones_in_each_well_and_across(strong):
    labels = [b.label for b in strong.backbones]
    assert sum(lab.startswith("in-well") for lab in labels) == 2 and "cross-well" in labels
    for b in strong.backbones:
        assert b.stopped  # each says why it ends (the separatrix, the truncation, or the amplitude asked)


@pytest.mark.slow
def test_every_checked_point_agrees_with_time_integration(strong):
    checked = strong.verify(points=6, unstable=3)
    assert checked.max_error_percent < 0.5
    assert checked.unstable_reached == 0
    assert max(c.error_percent for c in checked.backbone_checks) < 0.5


def test_hill_multipliers_are_the_monodromy_matrix_of_time_integration(double_well, strong):
    """After a period doubling two exponents share Im = omega/2; Hill's groups of copies still find both."""
    from nlid.response.fitted import as_fitted
    from nlid.response.timesim import Simulator

    curve = next(c for c in strong.curves if c.start[0] < 0)  # the left well: unstable by period doubling at 8 Hz
    assert not curve.stable[0] and curve.instability[0] == "flip"
    sim = Simulator(as_fitted(double_well))
    c = curve.coefficients[0]
    omega = 2 * np.pi * curve.frequency_hz[0]
    z0 = c[0, 0] + c[0, 1::2].sum()
    v0 = omega * (c[0, 2::2] * np.arange(1, curve.harmonics + 1)).sum()

    def flow(z, v):
        _, ze, ve = sim.harmonic(omega, 8.0, np.ones(1), np.array([z]), np.array([v]), 1, steps=4096)
        return np.array([ze[0], ve[0]])

    h = 1e-7
    monodromy = np.column_stack(
        [
            (flow(z0 + h, v0) - flow(z0 - h, v0)) / (2 * h),
            (flow(z0, v0 + h * omega) - flow(z0, v0 - h * omega)) / (2 * h * omega),
        ]
    )
    assert curve.multiplier[0] == pytest.approx(np.max(np.abs(np.linalg.eigvals(monodromy))), rel=0.01)
