"""Where a benchmark's records come from: user files, the nonlinear-benchmarks package (a fake), $NLID_DATA_DIR."""

from __future__ import annotations

import sys
import types

import numpy as np
import pytest
from scipy import io as sio

from nlid import DataError, InputError
from nlid.benchmarking import data as bench_data
from nlid.benchmarking import load_estimation, load_protocol, load_test, parse_protocol
from nlid.benchmarking.data import check_user_files, noise_floor, read_user_file
from nlid.data.record import Record


def test_user_files_in_the_benchmarks_format_and_as_nlid_records(tmp_path):
    bw = load_protocol("bouc-wen")
    test = bw.test("multisine")
    rng = np.random.default_rng(0)
    u, y = rng.standard_normal(8192), 1e-4 * rng.standard_normal(8192)
    sio.savemat(tmp_path / "uval_multisine.mat", {"uval_multisine": u[:, None]})
    sio.savemat(tmp_path / "yval_multisine.mat", {"yval_multisine": y[:, None]})
    for given in (tmp_path / "uval_multisine.mat", tmp_path / "yval_multisine.mat", tmp_path):
        rec = read_user_file(bw, test.file, given)
        assert rec.n == 8192 and rec.fs == 750.0 and np.array_equal(rec.f, u) and np.array_equal(rec.z, y)
    # scored under the declared rule: the record says so (nlid.scoring.default_rule reads it)
    scored = load_test(bw, test, bench_data.Offsets(), path=tmp_path / "uval_multisine.mat")
    assert scored.meta["protocol"] == {
        "benchmark": "bouc-wen",
        "test": "multisine",
        "rule": "periodic:8192",
        "metric": "rmse",
        "unit": "m",
        "scale": 1.0,
    }
    assert scored.meta["periodic"] == 8192 and scored.meta["mass"] == 2.0 and scored.force_hold == "sampled"
    # checked: the number of samples and the sampling frequency
    sio.savemat(tmp_path / "uval_short.mat", {"f": u[:100], "z": y[:100]})
    with pytest.raises(DataError, match="100 samples, the benchmark declares 8192"):
        load_test(bw, test, bench_data.Offsets(), path=tmp_path / "uval_short.mat")
    import pandas as pd

    pd.DataFrame({"t": np.arange(8192) / 1000.0, "f": u, "z": y}).to_csv(tmp_path / "fast.csv", index=False)
    with pytest.raises(DataError, match="sampled at 1000 Hz; the bouc-wen benchmark's is 750 Hz"):
        read_user_file(bw, test.file, tmp_path / "fast.csv")


def test_a_missing_user_test_set_says_how_to_give_it(monkeypatch):
    monkeypatch.setitem(sys.modules, "nonlinear_benchmarks", None)  # not installed
    emps = load_protocol("emps")
    with pytest.raises(DataError, match="give its file in files= with the key 'emps:pulses'"):
        load_test(emps, emps.test("pulses"), bench_data.Offsets(), source="local")
    with pytest.raises(DataError, match="package is not installed.*files= with the key 'emps:pulses'"):
        load_test(emps, emps.test("pulses"), bench_data.Offsets())


def test_check_user_files(tmp_path):
    from scipy.io import savemat

    protocols = {"bouc-wen": load_protocol("bouc-wen")}
    rng = np.random.default_rng(6)
    path = tmp_path / "uval_multisine.mat"
    savemat(path, {"uval_multisine": rng.standard_normal((1, 8192))})
    savemat(tmp_path / "yval_multisine.mat", {"yval_multisine": 1e-4 * rng.standard_normal((1, 8192))})
    assert check_user_files(protocols, {"bouc-wen:multisine": str(path)}) == {"bouc-wen:multisine": str(path)}
    empty = tmp_path / "u.mat"
    empty.write_bytes(b"")
    with pytest.raises(DataError, match="u.mat"):  # each file is read before any job runs: an empty one is refused
        check_user_files(protocols, {"bouc-wen:multisine": str(empty)})
    with pytest.raises(InputError, match="is read from \\$NLID_DATA_DIR, not from a file you give"):
        check_user_files(protocols, {"bouc-wen:sinesweep": str(path)})
    with pytest.raises(InputError, match="name it BENCHMARK:TEST"):
        check_user_files(protocols, {"silverbox:arrow-full": str(path)})
    with pytest.raises(InputError, match="does not exist"):
        check_user_files(protocols, {"bouc-wen:multisine": str(tmp_path / "nope.mat")})


class _IO:
    """What nonlinear_benchmarks.Input_output_data offers: u, y, sampling_time."""

    def __init__(self, u, y, sampling_time=None):
        self.u, self.y, self.sampling_time = u, y, sampling_time


def _fake_package(monkeypatch, n=1000, fs=1024.0):
    rng = np.random.default_rng(3)
    u = rng.standard_normal(3 * n)
    y = 1e-3 * rng.standard_normal(3 * n) + 0.5
    calls = []

    def toy():
        calls.append(1)
        train = _IO(u[:n], y[:n], 1 / fs)
        return train, (_IO(u[n : 2 * n], y[n : 2 * n], 1 / fs), _IO(u[2 * n :], y[2 * n :], 1 / fs))

    module = types.ModuleType("nonlinear_benchmarks")
    module.Silverbox = toy  # a loader of the package's allow-list (nlid.benchmarking.protocol.PACKAGE_FUNCTIONS)
    monkeypatch.setitem(sys.modules, "nonlinear_benchmarks", module)
    bench_data._package_result.cache_clear()
    return u, y, calls


def test_loading_through_the_nonlinear_benchmarks_package(monkeypatch, toy_text):
    PROTOCOL = toy_text
    u, y, calls = _fake_package(monkeypatch)
    text = (
        PROTOCOL.replace("[estimation]\n", '[estimation]\npackage = "train"\n')
        .replace('[estimation.file]\nnames = ["toy_estimation.mat"]\ncolumns = "f=force, z=disp"\n', "")
        .replace('name = "independent"\n', 'name = "independent"\npackage = "test:1"\n')
        .replace(
            "remove_means = true\n",
            'remove_means = true\n\n[benchmark.package]\nfunction = "Silverbox"\nforce_scale = 2.0\n',
        )
    )
    protocol = parse_protocol(text)
    est, offsets = load_estimation(protocol, source="package")
    assert est.n == 1000 and est.fs == 1024.0
    assert np.allclose(est.f, 2.0 * u[:1000] - 2.0 * u[:1000].mean()) and abs(est.z.mean()) < 1e-15
    test = load_test(protocol, protocol.test("independent"), offsets, source="package")
    # the test set is the package's second test set, with the *estimation* means removed
    assert np.allclose(test.z, y[2000:] - y[:1000].mean()) and np.allclose(test.f, 2.0 * u[2000:] - offsets.f)
    assert test.meta["source"] == "nonlinear-benchmarks: Silverbox() test:1"
    assert len(calls) == 1, "the package function is called once per process"
    # a sampling time other than the benchmark file's is refused
    bad = parse_protocol(text.replace("fs = 1024.0", "fs = 1000.0"))
    bench_data._package_result.cache_clear()
    with pytest.raises(DataError, match="sampling frequency of 1024 Hz, the benchmark file 1000 Hz"):
        load_estimation(bad, source="package")

    # the package failing (no network) is a data error naming it
    def broken():
        raise ConnectionError("no network")

    sys.modules["nonlinear_benchmarks"].Silverbox = broken
    bench_data._package_result.cache_clear()
    with pytest.raises(DataError, match="nonlinear_benchmarks.Silverbox\\(\\) failed: ConnectionError: no network"):
        load_estimation(protocol, source="package")
    bench_data._package_result.cache_clear()


def test_noise_floor_of_periodic_records():
    rng = np.random.default_rng(4)
    period, sigma = 512, 0.01
    clean = np.tile(np.sin(2 * np.pi * np.arange(period) / 64), 4)
    rec = Record(f=clean, z=clean + sigma * rng.standard_normal(clean.size), fs=100.0)
    from nlid.benchmarking.declarations import NoiseFloor

    assert noise_floor(rec, NoiseFloor(period, (2, 3, 4))) == pytest.approx(sigma, rel=0.1)
    with pytest.raises(DataError, match="ends after the estimation part"):
        noise_floor(rec, NoiseFloor(period, (4, 5)))


def test_measured_benchmark_parts(data_dir):
    sb = load_protocol("silverbox")
    est, offsets = load_estimation(sb, source="local")
    assert est.n == 65062 and abs(est.z.mean()) < 1e-12 and abs(est.f.mean()) < 1e-12
    arrow = load_test(sb, sb.test("arrow-full"), offsets, source="local")
    assert arrow.n == 40475 and arrow.meta["protocol"]["rule"] == "window:50"
    bw = load_protocol("bouc-wen")
    est, offsets = load_estimation(bw, source="local")
    assert est.n == 32768 and offsets.f == 0.0
    period = load_test(bw, bw.test("held-out-period"), offsets, source="local")
    assert period.n == 8192
    # the noise floor of the training multisine, from periods 2-4 of the estimation part (sigma about 7.4e-6 m)
    assert 6e-6 < noise_floor(est, bw.test("held-out-period").noise_floor) < 9e-6
    internal = load_protocol("emps-internal")
    est, offsets = load_estimation(internal, source="local")
    last = load_test(internal, internal.test("last-quarter"), offsets, source="local")
    assert est.n + last.n == 24841 and est.n == 18631
