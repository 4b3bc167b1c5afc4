"""The paper's double well: a curve per well, in-well and cross-well motion labelled, stability checked in time."""

from __future__ import annotations

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
