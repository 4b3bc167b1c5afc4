import numpy as np
import pytest
from scipy import signal

from nlid import InputError
from nlid.signal.derivatives import complementary, differentiate, integrate, lowpass, suggest_cutoff, zoh_equivalent


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


def _one_column(x, fs, cutoff, derivative=0, hold=False):
    """The filter of one column as nlid applied it before the batched transforms: 1-D FFTs, a fresh response."""
    from scipy import fft as sp_fft

    from nlid.signal import derivatives as d

    n = x.size
    pad = d._pad_length(n, fs, cutoff)
    ext, offset, slope = d._extend(x, pad)
    size = sp_fft.next_fast_len(ext.size, real=True)
    buf = np.zeros(size)
    buf[: ext.size] = ext
    response = d._compute_response(size, fs, cutoff, d.FILTER_ORDER, derivative, hold, False)
    col = sp_fft.irfft(sp_fft.rfft(buf) * response, size)[pad : pad + n]
    if derivative == 0:
        col += offset + slope * (np.arange(n) - (0.5 if hold else 0.0))
    elif derivative == 1:
        col += slope * fs
    return col


@pytest.mark.parametrize("block_bytes", [None, 2 * 8 * 4500])  # the default, and blocks of two columns
def test_batched_column_filters_give_each_columns_numbers_to_the_bit(monkeypatch, block_bytes):
    from nlid.signal import derivatives as d

    if block_bytes is not None:
        monkeypatch.setattr(d, "FILTER_BLOCK_BYTES", block_bytes)
    rng = np.random.default_rng(4)
    fs, fc = 1000.0, 60.0
    x = np.cumsum(rng.standard_normal((4000, 5)), axis=0) + np.linspace(0.0, 30.0, 4000)[:, None]
    y = d.lowpass_columns(x.copy(), fs, fc, [0, 2, 3, 4])
    np.testing.assert_array_equal(y[:, 1], x[:, 1])  # a column not named is untouched
    for j in (0, 2, 3, 4):
        np.testing.assert_array_equal(y[:, j], _one_column(x[:, j], fs, fc))
    held = zoh_equivalent(x, fs, cutoff=fc)
    for j in range(5):
        np.testing.assert_array_equal(held[:, j], _one_column(x[:, j], fs, fc, hold=True))
        np.testing.assert_array_equal(lowpass(x[:, j], fs, fc), _one_column(x[:, j], fs, fc))


def test_lowpass_and_derivatives_share_one_transform_with_the_same_numbers():
    from nlid.signal.derivatives import lowpass_and_derivatives

    rng = np.random.default_rng(5)
    fs, fc = 1000.0, 80.0
    x = np.cumsum(rng.standard_normal(3000)) + 0.01 * np.arange(3000)
    low, d1, d2 = lowpass_and_derivatives(x, fs, fc, (0, 1, 2))
    np.testing.assert_array_equal(low, lowpass(x, fs, fc))
    np.testing.assert_array_equal(d1, differentiate(x, fs, order=1, cutoff=fc)[0])
    np.testing.assert_array_equal(d2, differentiate(x, fs, order=2, cutoff=fc)[0])
    np.testing.assert_array_equal(d1, _one_column(x, fs, fc, derivative=1))
    with pytest.raises(InputError, match="orders must be"):
        lowpass_and_derivatives(x, fs, fc, (3,))


def test_filter_responses_are_kept_within_their_budget(monkeypatch):
    from nlid.signal import derivatives as d

    monkeypatch.setattr(d, "_RESPONSES", type(d._RESPONSES)())
    monkeypatch.setattr(d, "RESPONSE_CACHE_BYTES", 3 * 16 * 1001)  # three responses of 1001 frequencies
    first = d._response(2000, 1000.0, 50.0, 4, 0, False, False)
    assert d._response(2000, 1000.0, 50.0, 4, 0, False, False) is first  # computed once
    assert not first.flags.writeable
    np.testing.assert_array_equal(first, d._compute_response(2000, 1000.0, 50.0, 4, 0, False, False))
    for cutoff in (60.0, 70.0, 80.0):
        d._response(2000, 1000.0, cutoff, 4, 0, False, False)
    assert len(d._RESPONSES) == 3 and (2000, 1000.0, 50.0, 4, 0, False, False) not in d._RESPONSES
    d._response(100_000, 1000.0, 50.0, 4, 0, False, False)  # larger than the whole budget: not kept
    assert len(d._RESPONSES) == 0


@pytest.mark.parametrize("n", [37, 4096, 10_001, 61_440])
def test_welch_density_is_scipys_welch(n):
    """The noise floor's Welch estimate without scipy.signal gives scipy.signal.welch's numbers (to the bit on
    scipy 1.17; rounding allowed for other versions)."""
    from nlid.signal.noisefloor import welch_density

    rng = np.random.default_rng(n)
    fs = float(rng.uniform(100.0, 5000.0))
    x = np.cumsum(rng.standard_normal(n)) * 1e-3
    x -= x.mean()
    nperseg = int(min(n, 4096))
    f_ref, p_ref = signal.welch(x, fs=fs, nperseg=nperseg)
    f, p = welch_density(x, fs, nperseg)
    np.testing.assert_allclose(f, f_ref, rtol=1e-14, atol=0)
    np.testing.assert_allclose(p, p_ref, rtol=1e-12, atol=0)


def _complex_response(size, fs, cutoff, order, derivative, hold, complement):
    """The filters' response in complex arithmetic throughout: its definition (nlid's code until the fifth
    session of issue 36)."""
    from scipy import fft as sp_fft

    freqs = sp_fft.rfftfreq(size, d=1.0 / fs)
    response = np.ones(freqs.size, dtype=complex)
    if cutoff is not None:
        low = 1.0 / (1.0 + (freqs / cutoff) ** (2 * order))
        response *= 1.0 - low if complement else low
    if derivative > 0:
        response *= (2j * np.pi * freqs) ** derivative
    elif derivative < 0:
        response[0] = 0.0
        response[1:] *= (2j * np.pi * freqs[1:]) ** derivative
    if hold:
        response *= np.sinc(freqs / fs) * np.exp(-1j * np.pi * freqs / fs)
    return response


@pytest.mark.parametrize("size", [64, 65, 4097])
@pytest.mark.parametrize("cutoff", [None, 0.7, 43.5])
def test_responses_in_real_arithmetic_are_the_complex_products(size, cutoff):
    """The low-pass and the first two derivatives formed in real arithmetic give the complex products of the
    definition exactly (each of those products has a zero part, so no rounding differs); the other orders
    keep the definition."""
    from nlid.signal import derivatives as d

    fs = 200.0
    for order in (2, 4):
        for derivative in (-2, -1, 0, 1, 2, 3):
            for hold in (False, True):
                for complement in (False, True):
                    args = (size, fs, cutoff, order, derivative, hold, complement)
                    fast, reference = d._compute_response(*args), _complex_response(*args)
                    assert fast.dtype == reference.dtype and fast.shape == reference.shape
                    np.testing.assert_array_equal(fast, reference, err_msg=str(args))
