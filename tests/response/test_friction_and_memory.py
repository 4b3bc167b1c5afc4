"""Coulomb friction (exact signs, regularised where the mass sticks) and Bouc-Wen (its state in the AFT step)."""

from __future__ import annotations

import pytest

from nlid.response import Settings


@pytest.fixture(scope="module")
def sliding(coulomb):
    return coulomb.frequency_response(1.0, (12, 35), harmonics=21, backbone=False)


def test_coulomb_signs_are_used_exactly_while_the_mass_slides(sliding):
    (curve,) = sliding.curves
    assert "regularisation" not in curve.meta
    assert any("no regularisation" in n for n in sliding.notes)
    assert len(curve.folds) == 2  # the cubic spring bends the curve; friction damps it


@pytest.mark.slow
def test_coulomb_points_agree_with_time_integration(sliding):
    checked = sliding.verify(points=4, unstable=2)
    assert checked.max_error_percent < 0.5 and checked.unstable_reached == 0


def test_a_sticking_mass_is_regularised_and_says_so(make_oscillator):
    sticky = make_oscillator("sign(v)", {"sign(v)": 2.0, "z": 1e4, "v": 1.0, "1": 0.0})
    resp = sticky.frequency_response(1.0, (5, 25), backbone=False)  # the force never beats friction far from 15.9 Hz
    (curve,) = resp.curves
    eps, why = curve.meta["regularisation"]
    assert eps > 0 and why
    assert any("regularised as tanh" in n for n in resp.notes)


def test_a_given_regularisation_is_used(coulomb):
    resp = coulomb.frequency_response(1.0, (12, 14), settings=Settings(regularisation=1e-4), backbone=False)
    assert resp.curves[0].meta["regularisation"] == (1e-4, "asked")


@pytest.fixture(scope="module")
def hysteretic(bouc_wen):
    return bouc_wen.frequency_response(3.0, (10, 20), harmonics=7)


def test_bouc_wen_has_its_folds_and_no_backbone(hysteretic):
    (curve,) = hysteretic.curves
    assert len(curve.folds) == 2 and not curve.stable.all()
    assert hysteretic.backbones == ()  # a memory term has no conservative part
    assert any("memory states" in n for n in hysteretic.notes)


@pytest.mark.slow
def test_bouc_wen_points_agree_with_time_integration(hysteretic):
    checked = hysteretic.verify(points=4, unstable=1)
    assert checked.max_error_percent < 0.5 and checked.unstable_reached == 0
