"""How far a record leaves the range a model was fitted on (nlid.scoring.coverage)."""

from __future__ import annotations

import numpy as np
import pytest

from nlid.errors import InputError
from nlid.scoring import RANGE_TOLERANCE, RangeExcess, beyond_range, range_excess, value_range


def _sine(amplitude: float, n: int = 4000) -> np.ndarray:
    return amplitude * np.sin(np.linspace(0.0, 20 * np.pi, n))


def test_a_record_inside_the_range_says_nothing():
    z = _sine(1.0)
    found = range_excess(value_range(_sine(1.0)), 0.9 * z)
    assert found.beyond == 0.0 and found.outside == 0.0
    assert not found.extrapolates and found.describe() == ""


def test_the_excursion_is_measured_in_widths_of_the_fitted_range_and_its_share_in_samples():
    fitted = value_range(_sine(1.0))  # width 2
    z = _sine(1.4)  # 0.4 beyond on either side: 20 % of the width
    found = range_excess(fitted, z)
    assert found.beyond == pytest.approx(0.2, rel=1e-6)
    assert found.outside == pytest.approx(np.mean(np.abs(z) > 1.0 + 1e-12), abs=1e-12)
    assert found.reached == pytest.approx((z.min(), z.max()))
    text = found.describe("the test")
    assert text.startswith("the test reaches 20 % of the estimation range beyond it (")
    assert "extrapolate" in text


def test_the_tolerance_separates_noise_at_the_extremes_from_extrapolation():
    fitted = (-1.0, 1.0)
    just_inside = np.array([0.0, 1.0 + 2 * RANGE_TOLERANCE * 0.99])
    just_beyond = np.array([0.0, 1.0 + 2 * RANGE_TOLERANCE * 1.01])
    assert range_excess(fitted, just_inside).describe() == ""
    assert range_excess(fitted, just_beyond).extrapolates


def test_a_structure_is_judged_by_the_dof_that_goes_furthest():
    est = np.column_stack([_sine(1.0), _sine(2.0), _sine(3.0)])
    test = np.column_stack([_sine(1.0), _sine(3.0), _sine(3.0)])  # DOF 1: 1 beyond a width of 4
    found = range_excess(value_range(est), test)
    assert found.dof == 1 and found.beyond == pytest.approx(0.25, rel=1e-6)


def test_the_one_formula_also_serves_ranges_without_samples():
    assert beyond_range((0.0, 2.0), (-0.5, 1.0)) == 0.25
    assert beyond_range((0.0, 2.0), (0.5, 1.0)) == 0.0
    assert beyond_range((1.0, 1.0), (1.0, 2.0)) == float("inf")


@pytest.mark.parametrize(
    "fitted, z, fragment",
    [
        ((0.0, 1.0), np.zeros((5, 2)), "one (min, max) pair per DOF"),
        ((0.0, 1.0), np.zeros(0), "one (min, max) pair per DOF"),
        ((0.0, np.nan), np.zeros(5), "finite"),
        ((0.0, 1.0), np.array([0.0, np.inf]), "finite"),
    ],
)
def test_bad_input_is_refused_in_one_line(fitted, z, fragment):
    with pytest.raises(InputError, match=fragment.replace("(", r"\(").replace(")", r"\)")):
        range_excess(fitted, z)


def test_a_record_known_only_by_its_range_gets_the_same_sentence_without_the_share():
    z = _sine(1.4)
    fitted = value_range(_sine(1.0))
    whole, bare = range_excess(fitted, z), RangeExcess.from_ranges(fitted, (z.min(), z.max()))
    assert bare.beyond == whole.beyond and bare.outside is None
    assert bare.describe("the test") == whole.describe("the test").replace(
        f" ({100 * whole.outside:.3g} % of its samples lie outside)", ""
    )
