"""Building blocks of the NSI plugin, each against an independent reference."""

import math

import numpy as np
import pytest

from nlid_nsi.continuous import band_limits, d2c_zoh, extended_frf
from nlid_nsi.gram import block_hankel_gram, clip_indefinite, sub_gram, transform_gram
from nlid_nsi.intersample import force_interval_mean, interval_mean, trapezoid_mean
from nlid_nsi.ip import ensemble_values
from nlid_nsi.noise import NoiseSource, build_noise_model
from nlid_nsi.reconstruction import crossover_frequency, fuse_motion, oscillator_response
from nlid_nsi.shift import histogram_modes, taylor_shift
from nlid_nsi.subspace import estimate_b, po_moesp, select_order


def explicit_gram(w, s):
    n, c = w.shape
    j = n - s + 1
    hankel = np.concatenate([w[p : p + j].T for p in range(s)], axis=0)  # (s c, J)
    return (hankel @ hankel.T / j).reshape(s, c, s, c)


def test_gram_equals_explicit_hankel_product():
    rng = np.random.default_rng(0)
    w = rng.standard_normal((700, 3)) + np.array([0.5, -1.0, 2.0])
    for s in (1, 2, 9, 40):
        assert np.allclose(block_hankel_gram(w, s), explicit_gram(w, s), rtol=0, atol=1e-12)


def test_gram_congruence_and_sub_gram():
    rng = np.random.default_rng(1)
    w = rng.standard_normal((500, 3))
    t = rng.standard_normal((2, 3))
    g = block_hankel_gram(w, 10)
    assert np.allclose(transform_gram(g, t), block_hankel_gram(w @ t.T, 10), atol=1e-12)
    assert np.array_equal(sub_gram(g, 2), g[3:7, :, 3:7, :])


def test_gram_refuses_short_record():
    with pytest.raises(ValueError, match="too short"):
        block_hankel_gram(np.ones((50, 4)), 20)


def test_interval_mean_is_exact_for_constant_acceleration():
    # v linear and z quadratic over each interval (a held force): the Hermite
    # interpolant is exact, and 3-point Gauss integrates v^2 and z^3 exactly
    dt, a = 0.01, np.array([3.0, -2.0, 5.0])
    z0, v0 = 0.1, -0.4
    z, v = [z0], [v0]
    for ak in a:
        z.append(z[-1] + v[-1] * dt + 0.5 * ak * dt**2)
        v.append(v[-1] + ak * dt)
    z, v = np.array(z), np.array(v)
    got = interval_mean(lambda zz, vv: vv**2 + zz**3, z, v, dt)
    for k, ak in enumerate(a):
        t = np.linspace(0, dt, 20001)
        zt = z[k] + v[k] * t + 0.5 * ak * t**2
        vt = v[k] + ak * t
        exact = np.trapezoid(vt**2 + zt**3, t) / dt
        assert got[k] == pytest.approx(exact, rel=1e-9)


def test_force_interval_mean():
    f = np.arange(10.0) ** 3
    assert np.array_equal(force_interval_mean(f, "zoh"), f)
    got = force_interval_mean(f, "sampled")
    exact = ((np.arange(1, 11.0) ** 4 - np.arange(10.0) ** 4) / 4)[1:-2]  # mean of t^3 over [k, k+1]
    assert np.allclose(got[1:-2], exact)
    assert np.allclose(trapezoid_mean(np.array([1.0, 3.0, 5.0])), [2.0, 4.0, 5.0])


def test_oscillator_response_matches_zoh_discretisation():
    m, c, k, dt = 0.2, 1.0, 100.0, 1e-3
    f = np.zeros(2000)
    f[0] = 1.0  # one held pulse: x after it is the step response at dt, then free decay
    z, v = oscillator_response(f, dt, m, c, k)
    wn, zeta = math.sqrt(k / m), c / (2 * math.sqrt(k * m))
    wd = wn * math.sqrt(1 - zeta**2)
    t = dt
    step = (1 - math.exp(-zeta * wn * t) * (math.cos(wd * t) + zeta * wn / wd * math.sin(wd * t))) / k
    assert z[0] == 0.0 and z[1] == pytest.approx(step, rel=1e-9)


def test_subspace_recovers_a_known_two_input_system():
    # m x'' + c x' + k x = u1 + 3 u2, sampled with a ZOH: exact discrete model
    rng = np.random.default_rng(3)
    m, c, k, dt = 0.2, 1.0, 600.0, 1 / 2048
    ac = np.array([[0.0, 1.0], [-k / m, -c / m]])
    bc = np.array([[0.0, 0.0], [1 / m, 3 / m]])
    from scipy.linalg import expm

    em = expm(np.block([[ac, bc], [np.zeros((2, 4))]]) * dt)
    ad, bd = em[:2, :2], em[:2, 2:]
    u = rng.standard_normal((20000, 2))
    x = np.zeros(2)
    y = np.empty(20000)
    for t in range(20000):
        y[t] = x[0]
        x = ad @ x + bd @ u[t]
    y = y + 1e-4 * y.std() * rng.standard_normal(y.size)  # a little output noise: a clear order gap
    w = np.column_stack([u, y])
    scales = w.std(0)
    g = block_hankel_gram((w - w.mean(0)) / scales, 20)
    a, cm, sv, n = po_moesp(g, 2)
    assert n == 2 and select_order(sv) == 2
    b = estimate_b(a, cm, (u - u.mean(0)) / scales[:2], (y - y.mean()) / scales[2])
    b = b / scales[None, :2]
    cm = cm * scales[2]
    acc, bcc, lc = d2c_zoh(a, b, dt)
    h = extended_frf(acc, bcc, cm, np.array([10.0, 50.0]))
    true = 1 / (k - m * np.array([10.0, 50.0]) ** 2 + 1j * c * np.array([10.0, 50.0]))
    assert np.allclose(h[:, 0], true, rtol=1e-3)
    assert np.allclose(h[:, 1] / h[:, 0], 3.0, rtol=1e-3)


def test_half_power_band_brackets_resonance():
    lo, hi = band_limits(100.0, 0.05, "halfpower")
    assert lo < 100.0 < hi and hi - lo == pytest.approx(2 * 0.05 * 100.0, rel=0.01)
    assert band_limits(100.0, 0.05, (1.0, 2.0)) == (2 * math.pi, 4 * math.pi)


def test_taylor_shift():
    c = np.array([1.0, -2.0, 0.5, 3.0])  # 1 - 2x + 0.5x^2 + 3x^3
    shifted = taylor_shift(c, 0.7)
    x = np.linspace(-1, 1, 5)
    assert np.allclose(np.polynomial.polynomial.polyval(x, shifted), np.polynomial.polynomial.polyval(x + 0.7, c))


def test_histogram_modes_find_both_wells():
    rng = np.random.default_rng(4)
    z = np.concatenate([rng.normal(-0.027, 0.006, 60000), rng.normal(0.017, 0.004, 30000)])
    modes = histogram_modes(z, degree=6)
    assert len(modes) == 2
    assert modes[0] == pytest.approx(-0.027, abs=2e-3) and modes[1] == pytest.approx(0.017, abs=2e-3)


def _consistent_motion(n=2**16, fs=512.0, seed=0):
    """A smooth random displacement and its exact velocity and acceleration (spectral)."""
    rng = np.random.default_rng(seed)
    freqs = np.fft.rfftfreq(n, 1 / fs)
    spec = (rng.standard_normal(freqs.size) + 1j * rng.standard_normal(freqs.size)) / (1 + (freqs / 8.0) ** 4)
    spec[0] = 0.0
    w = 2j * np.pi * freqs
    z, v, a = (np.fft.irfft(spec * w**k, n) for k in range(3))
    scale = 0.02 / z.std()
    return z * scale, v * scale, a * scale, fs


def test_noise_levels_and_automatic_crossover_recover_the_noises():
    z, v, a, fs = _consistent_motion()
    rng = np.random.default_rng(1)
    sz, sa = 0.02 * z.std(), 0.02 * a.std()
    zn, an = z + sz * rng.standard_normal(z.size), a + sa * rng.standard_normal(z.size)
    zero = np.zeros_like(z)
    rec = fuse_motion(zn, an, zero, zero, 1 / fs, (1.0, 1.0, 1.0))
    assert rec.crossover == pytest.approx(crossover_frequency(sz**2, sa**2, fs), rel=0.05)
    assert rec.crossover == pytest.approx((sa / sz) ** 0.5 / (2 * np.pi), rel=0.05)
    assert np.sqrt(rec.source("z").var) == pytest.approx(sz, rel=0.05)
    assert np.sqrt(rec.source("a").var) == pytest.approx(sa, rel=0.05)
    inner = slice(4000, -4000)
    # the fused estimate is closer to the truth than either channel alone would be
    assert np.std((rec.z - z)[inner]) < 0.5 * sz
    # its noise is what the kernels say
    var_v = rec.velocity_noise_var
    assert np.std((rec.v - v)[inner]) == pytest.approx(np.sqrt(var_v), rel=0.1)


def test_fusion_reproduces_consistent_noise_free_channels():
    z, v, a, fs = _consistent_motion(seed=2)
    zero = np.zeros_like(z)
    rec = fuse_motion(z, a, zero, zero, 1 / fs, (1.0, 1.0, 1.0), crossover=6.0)
    inner = slice(4000, -4000)
    assert np.abs(rec.z - z)[inner].max() < 1e-6 * np.abs(z).max()
    assert np.abs(rec.v - v)[inner].max() < 1e-6 * np.abs(v).max()
    assert rec.crossover == 6.0


def test_independent_noise_sources_add_in_the_noise_model():
    rng = np.random.default_rng(3)
    n, half = 500, 20
    jac = [(rng.standard_normal(n), rng.standard_normal(n)) for _ in range(2)]
    scales = np.array([1.0, 2.0, 3.0, 0.5])
    kz, kv = rng.standard_normal(2 * half + 1), rng.standard_normal(2 * half + 1)
    s1 = NoiseSource("z", 0.3, kz, kv, True)
    s2 = NoiseSource("a", 2.0, kv, kz, False)
    both = build_noise_model([s1, s2], jac, scales, 10).lag_covariance()
    one = build_noise_model([s1], jac, scales, 10).lag_covariance()
    two = build_noise_model([s2], jac, scales, 10).lag_covariance()
    assert np.allclose(both, one + two)
    assert np.allclose(two[:, -1, :], 0.0)  # the acceleration's noise does not reach the output


def test_k_tilde_ensemble_values():
    assert ensemble_values(800.0, 5, 2.5) == [800.0, 1100.0, 1400.0, 1700.0, 2000.0]
    assert ensemble_values(800.0, 1, 2.5) == [800.0]
    assert ensemble_values(800.0, 5, 1.0) == [800.0]
    assert ensemble_values(0.0, 5, 2.5) == [0.0]  # nothing to spread: one fit, not five identical ones


def test_clip_indefinite_projects_only_an_indefinite_gram():
    rng = np.random.default_rng(4)
    w = rng.standard_normal((400, 3))
    gram = block_hankel_gram(w, 4)
    same, clipped = clip_indefinite(gram)
    assert same is gram and not clipped
    flat = gram.reshape(12, 12)
    ev, vec = np.linalg.eigh(flat)
    ev[0] = -0.05 * ev.mean()  # a noise correction that went a little too far
    bad = ((vec * ev) @ vec.T).reshape(gram.shape)
    fixed, clipped = clip_indefinite(bad, floor=1e-8)
    assert clipped
    ev_fixed = np.linalg.eigvalsh(fixed.reshape(12, 12))
    assert ev_fixed.min() > 0
    np.testing.assert_allclose(ev_fixed[1:], ev[1:], rtol=1e-9)  # the other directions are untouched
    t = rng.standard_normal((2, 3))
    np.linalg.cholesky(transform_gram(fixed, t).reshape(8, 8))  # every congruence is positive definite


# --------------------------------------------------------------------------- issue 14: the fast paths


def _two_input_record(n=6000, seed=5, noise=1e-3):
    """A second-order system driven by a white input and a band-limited one, with output noise."""
    rng = np.random.default_rng(seed)
    lam = np.exp((-3.0 + 22.0j) / 512)
    a = np.array([[lam.real, -lam.imag], [lam.imag, lam.real]])
    b = np.array([[1.0, -0.5], [0.3, 0.8]])
    u = np.column_stack([rng.standard_normal(n), np.convolve(rng.standard_normal(n), np.ones(5) / 5, "same")])
    x, y = np.zeros(2), np.empty(n)
    for t in range(n):
        y[t] = x[0]
        x = a @ x + b @ u[t]
    y += noise * y.std() * rng.standard_normal(n)
    return u, y


def test_lag_products_equal_the_direct_sums():
    from nlid_nsi.gram import lag_products

    rng = np.random.default_rng(7)
    w = rng.standard_normal((5000, 3))
    for lags, length in ((1, 5000), (7, 4990), (60, 4941)):
        got = lag_products(w, lags, length)
        ref = np.array([w[:length].T @ w[d : d + length] for d in range(lags)])
        np.testing.assert_allclose(got, ref, rtol=0, atol=1e-10 * np.abs(ref).max())


def test_perturbed_moesp_equals_po_moesp_on_every_map():
    from nlid_nsi.subspace import PerturbedMOESP

    # channels [f, z, g, y]: T(kappa) = [f + kappa z, g, y] as nsi-ip forms them
    u, y = _two_input_record()
    rng = np.random.default_rng(8)
    zc = y + 0.05 * rng.standard_normal(len(y))  # a channel correlated with the output
    w = np.column_stack([u[:, 0], zc, u[:, 1], y])
    w = (w - w.mean(0)) / w.std(0)
    gram = block_hankel_gram(w, 2 * 15)
    t0 = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0], [0, 0, 0, 1.0]])
    t1 = np.zeros_like(t0)
    t1[0, 1] = 1.0
    fam = PerturbedMOESP(gram, t0, t1)
    assert fam.ok
    for kappa in (0.0, 0.4, 2.5):
        t = t0 + kappa * t1
        a1, c1, sv1, n1 = po_moesp(transform_gram(gram, t), 2)
        a2, c2, sv2, n2 = fam.estimate(t)
        assert n1 == n2 == 2
        # a singular value computed two ways agrees to rounding of the largest one (Weyl's bound), not
        # to a fraction of itself: the noise-floor values 1e-5 below the largest carry 1e-16 * sv[0] of error
        np.testing.assert_allclose(sv2, sv1, rtol=1e-7, atol=1e-10 * sv1[0])
        np.testing.assert_allclose(
            np.sort_complex(np.linalg.eigvals(a2)), np.sort_complex(np.linalg.eigvals(a1)), rtol=1e-10
        )
        # the state coordinates may differ by signs only: C A^k is the same up to them, |C| is not changed
        np.testing.assert_allclose(np.abs(c2), np.abs(c1), rtol=1e-9)
    # a map that is not t0 + kappa t1 goes through po_moesp itself
    other = t0.copy()
    other[1, 1] = 0.3
    got = fam.estimate(other)
    ref = po_moesp(transform_gram(gram, other), 2)
    np.testing.assert_array_equal(got[0], ref[0])


def test_perturbed_moesp_falls_back_on_a_singular_gram():
    from nlid_nsi.subspace import PerturbedMOESP

    u, y = _two_input_record(n=3000)
    w = np.column_stack([u[:, 0], u[:, 0], u[:, 1], y])  # z is a copy of f: the varying rows are singular
    w = (w - w.mean(0)) / w.std(0)
    gram = block_hankel_gram(w, 20)
    t0 = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0], [0, 0, 0, 1.0]])
    t1 = np.zeros_like(t0)
    t1[0, 1] = 1.0
    fam = PerturbedMOESP(gram, t0, t1)
    t = t0 - 1.0 * t1  # fbar = f - z = 0: PO-MOESP's Cholesky needs its diagonal load
    got = fam.estimate(t)
    ref = po_moesp(transform_gram(gram, t), 2)
    for g, r in zip(got, ref, strict=True):
        np.testing.assert_array_equal(g, r)


def test_b_step_normal_equations_equal_the_explicit_regressors():
    from scipy import signal

    from nlid_nsi import subspace

    rng = np.random.default_rng(9)
    lam = np.exp((-30 + 220j) / 2048)
    a = np.array([[lam.real, -lam.imag], [lam.imag, lam.real]])
    cm = np.array([[0.3, -0.7]])
    den, nums = subspace._state_filters(a, cm)
    n, m, length = 2, 3, 301
    u, y = rng.standard_normal((length, m)), rng.standard_normal(length)
    phi = np.empty((length, n * m + n))
    for r in range(n):
        for j in range(m):
            phi[:, r * m + j] = signal.lfilter(nums[r], den, u[:, j])
        imp = np.zeros(length + 1)
        imp[0] = 1.0
        phi[:, n * m + r] = signal.lfilter(nums[r], den, imp)[1:]
    for size in (1, 2, 7, 64, 1000):  # blocks shorter than the filter order too
        gram, rhs, total = subspace._normal_equations(den, nums, subspace._row_blocks(u, y, size))
        assert total == length
        np.testing.assert_allclose(gram, phi.T @ phi, rtol=0, atol=1e-12 * np.abs(phi.T @ phi).max())
        np.testing.assert_allclose(rhs, phi.T @ y, rtol=0, atol=1e-12 * np.abs(phi.T @ y).max())


def test_interval_means_of_several_functions_with_signs():
    from nlid_nsi.intersample import interval_means

    rng = np.random.default_rng(10)
    z, v = rng.standard_normal(1000), rng.standard_normal(1000)
    funcs = [lambda a, b: a**3, lambda a, b: b * np.abs(b), lambda a, b: a * b]
    got = interval_means(funcs, z, v, 0.01, block=97, signs=[1.0, -1.0, 1.0])
    for j, (func, sign) in enumerate(zip(funcs, (1.0, -1.0, 1.0), strict=True)):
        np.testing.assert_array_equal(got[:, j], sign * interval_mean(func, z, v, 0.01))


def test_noise_subtraction_matches_the_lag_loop():
    from nlid_nsi.noise import NoiseModel, subtract_noise

    rng = np.random.default_rng(11)
    for s, c, lag in ((40, 4, 30), (10, 3, 30), (50, 2, 5)):
        gram = rng.standard_normal((s, c, s, c))
        model = NoiseModel(1.0, rng.standard_normal((c, c, 3, 3)), rng.standard_normal((3, 3, 2 * lag + 1)))
        cov = model.lag_covariance(exclude_output=c - 1)
        ref = gram.copy()
        for d in range(-min(lag, s - 1), min(lag, s - 1) + 1):
            p = np.arange(max(0, -d), min(s, s - d))
            ref[p, :, p + d, :] -= cov[lag + d]
        np.testing.assert_array_equal(subtract_noise(gram, model, c - 1), ref)


def test_fast_term_evaluation_matches_the_term_language():
    from nlid.model.terms import Model
    from nlid_nsi.basis import split_model

    spec = (
        "z^3, z^2, z*|z|, |z|^5, sign(z), v*|v|, v^3, |v|^4, z^15, sign(v)*|px(z)|, v*|px(z)|, "
        "v*|v|*|px(z)|, px(z)^2*v, z^2*v*exp(-|v|/0.1), tanh(v/0.01)^2*z, v*exp(-(v/0.1)^2)"
    )
    model = Model.from_spec(spec).with_px_roots((-0.027, 0.017))
    rng = np.random.default_rng(12)
    z, v = 0.03 * rng.standard_normal(2000), 0.5 * rng.standard_normal(2000)
    z[:3], v[:3] = 0.0, 0.0  # signs and powers at zero
    terms = {t.name: t for t in model.terms}
    for b in split_model(model).basis:
        term = terms[b.name]
        ref = np.asarray(term.evaluate(z, v, model.px(z) if term.uses_px else None, {}), dtype=float)
        np.testing.assert_allclose(b.func(z, v), ref, rtol=1e-14, atol=0, err_msg=b.name)
        assert b.uses_v == term.depends_on_v


# --------------------------------------------------------------------------- issue 26: work done once


def test_the_suggested_cutoff_is_computed_once_per_identification(monkeypatch):
    import nlid
    from nlid.signal import derivatives
    from nlid_nsi.common import default_cutoff

    calls = []
    suggest = derivatives.suggest_cutoff

    def counted(x, fs):
        calls.append(len(x))
        return suggest(x, fs)

    record = nlid.simulate("paper-numerical", seed=1, noise={"z": 0.02}, channels="z", duration=16)
    ref = suggest(record.z, record.fs)
    monkeypatch.setattr(derivatives, "suggest_cutoff", counted)
    res = nlid.identify(record, "z^3, z^2, v*|v|", "nsi-ip", mass=0.2)
    # nsi-ip's velocity differentiator and the core's scores share the record's one Welch estimate
    assert calls == [record.n]
    assert res.diagnostics["velocity_cutoff_hz"] == default_cutoff(record.z, record.fs, ref)


def test_a_constant_regressor_column_skips_the_filter_with_the_same_numbers():
    from nlid.estimation.balance import _lowpass_columns
    from nlid.signal import derivatives

    rng = np.random.default_rng(13)
    n, fs = 5000, 1000.0
    smooth = np.cumsum(rng.standard_normal((n, 2)), axis=0)
    for columns in ([np.ones(n), smooth[:, 0], np.full(n, -2.5), smooth[:, 1]], [np.full(n, 3.0)], [smooth[:, 0]]):
        values = np.column_stack(columns)
        np.testing.assert_array_equal(_lowpass_columns(values.copy(), fs, 40.0), derivatives.lowpass(values, fs, 40.0))
