"""nlid.estimation.regression: least squares with honest standard errors, and collinearity."""

import numpy as np
import pytest

from nlid import IdentificationError
from nlid.estimation.regression import collinear_pairs, collinearity_warnings, least_squares
from nlid.signal import derivatives


def test_exact_solution_and_rank_deficiency():
    rng = np.random.default_rng(0)
    X = rng.standard_normal((500, 3)) * [1e-4, 1.0, 1e3]
    theta = np.array([2e4, -3.0, 5e-3])
    fit = least_squares(X, X @ theta, ["a", "b", "c"])
    np.testing.assert_allclose(fit.coefficients, theta, rtol=1e-10)
    assert fit.condition_number < 10  # columns are scaled to unit RMS first
    with pytest.raises(IdentificationError, match="rank deficient"):
        least_squares(np.column_stack([X, 2 * X[:, 1]]), X @ theta, ["a", "b", "c", "d"], context="x: ")
    with pytest.raises(IdentificationError, match="identically zero"):
        least_squares(np.column_stack([X, np.zeros(500)]), X @ theta, ["a", "b", "c", "zero"])


def test_batch_standard_errors_hold_for_coloured_errors():
    """Low-passed equation errors: the batch-means errors match the Monte-Carlo scatter, iid ones are too small."""
    fs, fc, n = 1000.0, 25.0, 4000
    rng = np.random.default_rng(1)
    X = np.column_stack([np.ones(n), derivatives.lowpass(rng.standard_normal(n), fs, 40.0)])
    estimates, se, se_iid = [], [], []
    for _ in range(300):
        noise = derivatives.lowpass(rng.standard_normal(n), fs, fc)
        fit = least_squares(X, X @ [1.0, 2.0] + noise, ["1", "x"], correlation_length=fs / fc)
        estimates.append(fit.coefficients)
        se.append(fit.standard_errors)
        se_iid.append(fit.standard_errors_iid)
    scatter = np.std(estimates, axis=0)
    np.testing.assert_allclose(np.mean(se, axis=0), scatter, rtol=0.2)
    assert np.all(np.mean(se_iid, axis=0) < 0.5 * scatter)


def test_collinear_pairs_centred_when_a_constant_is_present():
    t = np.linspace(0.0, 1.0, 2000)
    z = 0.02 + 1e-3 * np.sin(2 * np.pi * 5 * t)  # small motion about an offset
    X = np.column_stack([z, z**2, np.ones_like(z)])
    # with the constant, z and z^2 are still collinear (z^2 is almost linear in z here) ...
    pairs = collinear_pairs(X, ["z", "z^2", "1"])
    assert ("z", "z^2") in [(a, b) for a, b, _ in pairs]
    # ... and the constant is collinear with both (their means dominate)
    assert ("z", "1") in [(a, b) for a, b, _ in pairs]
    # two zero-mean, uncorrelated columns are not flagged
    Y = np.column_stack([np.sin(2 * np.pi * 5 * t), np.cos(2 * np.pi * 5 * t), np.ones_like(t)])
    assert collinear_pairs(Y, ["s", "c", "1"]) == []
    assert collinearity_warnings(Y, ["s", "c", "1"]) == []


def test_pearson_ignores_means_absorbed_by_the_constant():
    rng = np.random.default_rng(2)
    x = rng.standard_normal(1000)
    y = rng.standard_normal(1000)
    offset = np.column_stack([x + 100.0, y + 100.0])  # cosine ~ 1, centred correlation ~ 0
    assert collinear_pairs(offset, ["x", "y"])  # no constant term: the offsets are collinear
    with_constant = collinear_pairs(np.column_stack([offset, np.ones(1000)]), ["x", "y", "1"])
    assert {(a, b) for a, b, _ in with_constant} == {("x", "1"), ("y", "1")}  # x, y themselves are not
