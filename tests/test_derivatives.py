import numpy as np
import pytest
from scipy import signal

from nlid import InputError
from nlid.derivatives import complementary, differentiate, integrate, lowpass, suggest_cutoff, zoh_equivalent


def test_spectral_derivative_is_exact_in_band():
    fs = 2048.0
    t = np.arange(8192) / fs
    fc = 0.4 * fs
    for f0 in (13.0, 100.0, 400.0):
        w = 2 * np.pi * f0
        x = np.sin(w * t + 0.3) + 3.0 + 20.0 * t  # a trend must not matter
        gain = 1.0 / (1.0 + (f0 / fc) ** 8)
        d1, used = differentiate(x, fs, cutoff=fc)
        d2, _ = differentiate(x, fs, order=2, cutoff=fc)
        inner = slice(200, -200)  # measured: < 6e-7 relative beyond 200 samples from the ends
        np.testing.assert_allclose(d1[inner], gain * w * np.cos(w * t[inner] + 0.3) + 20.0, atol=1e-6 * w)
        np.testing.assert_allclose(d2[inner], -gain * w**2 * np.sin(w * t[inner] + 0.3), atol=1e-6 * w**2)
    assert used.cutoff == fc


def test_zoh_equivalent_is_half_sample_delay_in_band():
    fs = 1000.0
    t = np.arange(20000) / fs
    x = np.sin(2 * np.pi * 20 * t)
    y = zoh_equivalent(x, fs, cutoff=200.0)
    gain = np.sinc(20 / fs) / (1 + (20 / 200) ** 8)
    expected = gain * np.sin(2 * np.pi * 20 * (t - 0.5 / fs))
    np.testing.assert_allclose(y[500:-500], expected[500:-500], atol=1e-6)


def test_filtered_derivative_is_zero_phase():
    fs = 1000.0
    t = np.arange(10000) / fs
    x = np.sin(2 * np.pi * 7 * t)
    v, used = differentiate(x, fs, cutoff=80.0)
    expected = 2 * np.pi * 7 * np.cos(2 * np.pi * 7 * t)
    np.testing.assert_allclose(v[500:-500], expected[500:-500], atol=1e-4 * expected.max())
    assert "fc=80 Hz" in used.describe()


def test_suggested_cutoff_tracks_noise():
    rng = np.random.default_rng(0)
    fs = 2048.0
    t = np.arange(2**16) / fs
    x = np.sin(2 * np.pi * 10 * t) + 0.5 * np.sin(2 * np.pi * 23 * t)
    clean = suggest_cutoff(x, fs)
    noisy = suggest_cutoff(x + 0.02 * x.std() * rng.standard_normal(x.size), fs)
    very = suggest_cutoff(x + 0.1 * x.std() * rng.standard_normal(x.size), fs)
    assert 23 <= very <= noisy <= clean <= 0.4 * fs


def test_integrate_removes_drift():
    fs = 500.0
    t = np.arange(20000) / fs
    a = np.cos(2 * np.pi * 4 * t) + 0.05  # offset would drift linearly
    v, hp = integrate(a, fs)
    expected = np.sin(2 * np.pi * 4 * t) / (2 * np.pi * 4)
    assert hp == pytest.approx(10 / 40.0)
    np.testing.assert_allclose(v[2000:-2000], expected[2000:-2000], atol=0.02 * expected.max())


def test_bad_arguments():
    with pytest.raises(InputError, match="Nyquist"):
        lowpass(np.zeros(100), 100.0, 60.0)
    with pytest.raises(InputError, match="order"):
        differentiate(np.zeros(100), 100.0, order=3)


@pytest.mark.parametrize("crossover", [2.0, 10.0, 40.0])
def test_complementary_reproduces_consistent_channels(crossover):
    fs = 512.0
    t = np.arange(20_000) / fs
    freqs, amps = np.array([1.5, 7.0, 23.0, 61.0]), np.array([1.0, 0.3, 0.05, 0.01])
    w = 2 * np.pi * freqs
    z = (amps * np.sin(np.outer(t, w) + 0.3)).sum(1)
    v = (amps * w * np.cos(np.outer(t, w) + 0.3)).sum(1)
    a = -(amps * w**2 * np.sin(np.outer(t, w) + 0.3)).sum(1)
    inner = slice(2000, -2000)
    zh = complementary(z, a, fs, crossover)
    vh = complementary(z, a, fs, crossover, derivative=1)
    np.testing.assert_allclose(zh[inner], z[inner], atol=1e-3 * np.abs(z).max())
    np.testing.assert_allclose(vh[inner], v[inner], atol=1e-3 * np.abs(v).max())
    # an offset and a slow drift of the acceleration do not reach the estimate
    drift = complementary(None, 0.5 + 0.01 * t, fs, crossover)
    assert np.abs(drift[inner]).max() < 1e-6


def test_complementary_puts_each_channel_in_its_band():
    fs, n = 512.0, 2**15
    rng = np.random.default_rng(0)
    ez, ea = rng.standard_normal(n), rng.standard_normal(n)
    fz, pz = signal.welch(complementary(ez, np.zeros(n), fs, 10.0), fs=fs, nperseg=4096)
    _, pa = signal.welch(complementary(None, ea, fs, 10.0), fs=fs, nperseg=4096)
    low, high = (fz > 1) & (fz < 4), (fz > 40) & (fz < 100)
    # z noise passes below the crossover and is cut above it; a noise the opposite, divided by w^2
    assert np.median(pz[low]) > 1e3 * np.median(pz[high])
    expected = 2 / fs / (2 * np.pi * fz[high]) ** 4
    assert np.median(pa[high] / expected) == pytest.approx(1.0, rel=0.1)
    with pytest.raises(InputError, match="derivative"):
        complementary(ez, ea, fs, 10.0, derivative=2)
