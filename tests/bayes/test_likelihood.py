"""The adjusted equation-error likelihood: sufficient statistics, sandwich, bias correction."""

import numpy as np
import pytest

from nlid.bayes.bias import simulate_bias
from nlid.bayes.likelihood import (
    DegenerateParametersError,
    SufficientStatistics,
    build_likelihood,
    check_identifiable,
    long_run_covariance,
)
from nlid.estimation import balance
from nlid.simulation.presets import get_preset


def test_sufficient_statistics_reproduce_least_squares():
    rng = np.random.default_rng(0)
    G = rng.standard_normal((500, 3)) * [1e-3, 1.0, 1e3]
    y = G @ [2.0, -1.0, 0.5] + rng.standard_normal(500)
    stats = SufficientStatistics.from_arrays(G, y)
    np.testing.assert_allclose(stats.solve(), np.linalg.lstsq(G, y, rcond=None)[0], rtol=1e-9)
    theta = rng.standard_normal((4, 3))
    direct = ((y[None, :] - theta @ G.T) ** 2).sum(axis=1)
    np.testing.assert_allclose(stats.rss(theta), direct, rtol=1e-9)


def test_long_run_covariance_of_an_ar1_series():
    # AR(1) x_k = phi x_{k-1} + w_k has long-run variance 1 / (1 - phi)^2 for unit innovations
    rng = np.random.default_rng(1)
    phi, n = 0.8, 400_000
    w = rng.standard_normal(n)
    x = np.empty(n)
    x[0] = w[0]
    for k in range(1, n):
        x[k] = phi * x[k - 1] + w[k]
    omega = long_run_covariance(x[:, None], block=500)[0, 0]
    assert omega == pytest.approx(1 / (1 - phi) ** 2, rel=0.1)


def test_check_identifiable_names_the_collinear_terms():
    rng = np.random.default_rng(2)
    a, b = rng.standard_normal(1000), rng.standard_normal(1000)
    G = np.column_stack([a, b, a + 1e-7 * b])
    with pytest.raises(DegenerateParametersError, match="x, w are .nearly. collinear|w, x are .nearly. collinear"):
        check_identifiable(G.T @ G, ["w", "y", "x"])
    check_identifiable(G[:, :2].T @ G[:, :2], ["w", "y"])  # fine


@pytest.fixture(scope="module")
def experimental():
    return get_preset("paper-experimental")


@pytest.fixture(scope="module")
def noisy_experimental(experimental):
    """paper-experimental, 2 % noise on z and a, seed 5."""
    return experimental.simulate(5, noise=0.02, channels=("z", "a"))


@pytest.fixture(scope="module")
def likelihood(experimental, noisy_experimental):
    return build_likelihood(noisy_experimental, experimental.model(), experimental.mass, rng=np.random.default_rng(0))


def test_likelihood_is_a_student_t_around_the_corrected_estimate(likelihood):
    rng = np.random.default_rng(3)
    sd = np.sqrt(np.diag(likelihood.covariance))
    theta = likelihood.center + 2 * sd * rng.standard_normal((6, sd.size))
    prec = np.linalg.inv(likelihood.covariance)
    q = np.einsum("wi,ij,wj->w", theta - likelihood.center, prec, theta - likelihood.center)
    np.testing.assert_allclose(likelihood(theta), -0.5 * likelihood.dof * np.log1p(q / likelihood.dof), rtol=1e-8)
    assert likelihood(likelihood.center) == pytest.approx(0.0, abs=1e-12)


def test_likelihood_keeps_no_per_sample_arrays(likelihood):
    # one evaluation is O(p^2): the object holds nothing of the record's length
    p = len(likelihood.names)
    arrays = [v for v in vars(likelihood).values() if isinstance(v, np.ndarray)]
    arrays += [v for v in vars(likelihood.stats).values() if isinstance(v, np.ndarray)]
    assert arrays and max(a.size for a in arrays) <= p * p


def test_effective_samples_follow_the_filter_band(likelihood, noisy_experimental):
    info = likelihood.info
    fs, fc = noisy_experimental.fs, info["band_hz"]
    # residual correlated over about fs / (2 fc) samples after the zero-phase low-pass
    assert 0.5 * fs / (2 * fc) < info["tau_residual_samples"] < 2 * fs / (2 * fc)
    assert info["dof"] == pytest.approx(info["samples"] / info["tau_residual_samples"])
    # the sandwich is wider than the iid standard error for every coefficient
    assert min(info["sandwich_over_iid_sd"].values()) > 1.5


def test_bias_correction_recovers_the_coulomb_coefficient(likelihood, experimental):
    truth = experimental.truth()["coefficients"]
    i = experimental.model().index("sign(v)*|px(z)|")
    sd = np.sqrt(likelihood.covariance[i, i])
    # least squares is ~15 % low, 4 sd of the corrected estimate; the corrected centre is within 2 sd
    assert abs(likelihood.estimate[i] - truth["sign(v)*|px(z)|"]) > 3 * sd
    assert abs(likelihood.center[i] - truth["sign(v)*|px(z)|"]) < 2 * sd


def test_bias_correction_is_the_identity_without_noise_or_filtering(exact_record, numerical):
    model = numerical.model()
    data = balance.regression_data(exact_record, model)
    assert data.filtered_at is None
    theta = model.vector(numerical.truth()["coefficients"])
    corr = simulate_bias(exact_record, model, theta, numerical.mass, data, pairs=1, noise={"z": 0.0, "v": 0.0})
    np.testing.assert_allclose(corr.binding, np.eye(len(model)), atol=1e-8)
    np.testing.assert_allclose(corr.correct(theta), theta, rtol=1e-8)


@pytest.mark.parametrize("n", [17, 1000, 4096, 6001])
def test_integrated_times_are_emcees(n):
    """The posterior's own autocorrelation times (real FFTs) are emcee's estimator, to rounding (issue 36)."""
    import emcee

    from nlid.bayes.likelihood import integrated_times

    rng = np.random.default_rng(n)
    x = rng.standard_normal((n + 4, 3))
    x = (x[4:] + x[3:-1] + x[2:-2] + x[1:-3] + x[:-4]) / 5  # correlated over a few samples
    x[:, 2] = np.cumsum(x[:, 2]) / np.sqrt(n)  # and one that wanders
    expected = emcee.autocorr.integrated_time(x, has_walkers=False, tol=0, quiet=True)
    assert integrated_times(x) == pytest.approx(expected, rel=1e-12)
