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
