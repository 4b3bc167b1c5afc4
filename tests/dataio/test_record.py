import numpy as np
import pytest

from nlid import DataError, InputError, Record
from nlid.data.checks import MIN_SAMPLES, TIME_TOLERANCE


def _signals(n=1000, fs=100.0):
    t = np.arange(n) / fs
    return t, np.sin(2 * np.pi * 3 * t), np.cos(2 * np.pi * 2 * t)


def test_valid_record_is_immutable_copy():
    t, f, z = _signals()
    rec = Record(f=f, z=z, fs=100.0)
    assert rec.n == 1000 and rec.channels == ("f", "z") and rec.duration == pytest.approx(10.0)
    f[0] = 99.0
    assert rec.f[0] != 99.0, "record must hold its own copy"
    with pytest.raises(ValueError):
        rec.z[0] = 1.0


@pytest.mark.parametrize("channel", ["f", "z", "v", "a"])
@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_non_finite_value_names_channel_and_index(channel, bad):
    _, f, z = _signals()
    arrays = {"f": f.copy(), "z": z.copy(), "v": z.copy(), "a": z.copy()}
    arrays[channel][123] = bad
    with pytest.raises(DataError, match=rf"'{channel}'.*index 123"):
        Record(fs=100.0, **arrays)


def test_unequal_lengths():
    _, f, z = _signals()
    with pytest.raises(DataError, match="'z' has 999 samples"):
        Record(f=f, z=z[:-1], fs=100.0)


def test_too_short_and_constant():
    _, f, z = _signals()
    with pytest.raises(DataError, match=f"at least {MIN_SAMPLES}"):
        Record(f=f[:10], z=z[:10], fs=100.0)
    with pytest.raises(DataError, match="'z' is constant"):
        Record(f=f, z=np.ones_like(z), fs=100.0)


def test_bad_sampling_frequency():
    _, f, z = _signals()
    for fs in (0.0, -1.0, np.nan):
        with pytest.raises(DataError, match="sampling frequency"):
            Record(f=f, z=z, fs=fs)


def test_time_axis_uniformity():
    t, f, z = _signals()
    rec = Record.from_time(t + 5.0, f, z)
    assert rec.fs == pytest.approx(100.0) and rec.t0 == pytest.approx(5.0)
    jitter = t.copy()
    jitter[500] += 0.5 * TIME_TOLERANCE / 100.0  # within tolerance
    Record.from_time(jitter, f, z)
    dropped = np.delete(t, 400)
    with pytest.raises(DataError, match="not uniform: step 399"):
        Record.from_time(dropped, np.delete(f, 400), np.delete(z, 400))


def test_slicing_split_and_time_slice():
    t, f, z = _signals()
    rec = Record(f=f, z=z, fs=100.0)
    part = rec[100:300]
    assert part.n == 200 and part.t0 == pytest.approx(1.0)
    np.testing.assert_array_equal(part.z, z[100:300])
    est, held = rec.split(0.25)
    assert est.n == 750 and held.n == 250 and held.t0 == pytest.approx(7.5)
    assert rec.time_slice(2.0, 3.0).n == 100
    with pytest.raises(InputError):
        rec.split(1.5)


def test_decimate_keeps_band_and_provenance():
    t, f, z = _signals(n=4000, fs=1000.0)
    rec = Record(f=f, z=z, fs=1000.0)
    dec = rec.decimate(4)
    assert dec.fs == pytest.approx(250.0) and dec.n == 1000
    np.testing.assert_allclose(dec.z[50:-50], z[::4][50:-50], atol=1e-6)
    assert dec.is_measured("z") and "decimated by 4" in dec.source_of("z")
    res = rec.resample(500.0)
    assert res.fs == pytest.approx(500.0) and res.n == 2000


def test_derivative_channels_are_estimated_and_labelled():
    fs = 1000.0
    t = np.arange(5000) / fs
    z = np.sin(2 * np.pi * 5 * t) + 0.3 * np.sin(2 * np.pi * 13 * t)
    v_true = 2 * np.pi * 5 * np.cos(2 * np.pi * 5 * t) + 0.3 * 2 * np.pi * 13 * np.cos(2 * np.pi * 13 * t)
    rec = Record(f=np.cos(t), z=z, fs=fs).with_derivatives(cutoff=60.0)
    inner = slice(200, -200)
    np.testing.assert_allclose(rec.v[inner], v_true[inner], rtol=0, atol=1e-3 * np.abs(v_true).max())
    assert not rec.is_measured("v") and "fc=60 Hz" in rec.source_of("v")
    back = Record(f=np.cos(t), z=z, fs=fs, a=-((2 * np.pi * 5) ** 2) * np.sin(2 * np.pi * 5 * t))
    integrated = back.with_velocity_from_acceleration(highpass=1.0)
    v5 = 2 * np.pi * 5 * np.cos(2 * np.pi * 5 * t)
    settled = slice(2000, -2000)  # beyond the 1 Hz high-pass's edge transient
    np.testing.assert_allclose(integrated.v[settled], v5[settled], atol=1e-2 * np.abs(v5).max())
    assert "integrated from a" in integrated.source_of("v")
