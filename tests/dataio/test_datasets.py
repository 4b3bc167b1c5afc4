"""Loaders of the shared measured benchmarks (read from $NLID_DATA_DIR)."""

import numpy as np
import pytest

from nlid import DataError, InputError, identify
from nlid.data.datasets import SILVERBOX_ARROW, SILVERBOX_FS, load


def test_emps(data_dir):
    rec = load("emps")
    assert rec.n == 24841 and rec.fs == pytest.approx(1000.0, rel=1e-4)
    assert rec.channels == ("f", "z")
    assert 10 < np.ptp(rec.z * 1000) < 500, "position in m (a stroke of a few cm)"
    assert np.abs(rec.f).max() > 50, "force in N (gtau * vir)"


def test_emps_reference_values_with_rfs(data_dir):
    # Issue 2 proves the loader; the RFS issue asserts the 3 % agreement.
    res = identify(load("emps"), "sign(v)", "rfs", without="z")
    ref = load("emps").meta["reference"]
    assert res.mass == pytest.approx(ref["mass"], rel=0.03)
    assert res.coefficients["sign(v)"] == pytest.approx(ref["coefficients"]["sign(v)"], rel=0.03)


def test_silverbox(data_dir):
    rec = load("silverbox")
    assert rec.n == 131072 and rec.fs == pytest.approx(SILVERBOX_FS)
    assert abs(rec.f.mean()) < 1e-12 and abs(rec.z.mean()) < 1e-12, "means removed"
    assert rec.units["z"] == "V"
    assert load("silverbox", part="arrow").n == SILVERBOX_ARROW
    assert load("silverbox", part="multisine").n == 131072 - SILVERBOX_ARROW


def test_missing_data_names_the_directory(tmp_path, monkeypatch):
    monkeypatch.setenv("NLID_DATA_DIR", str(tmp_path))
    with pytest.raises(DataError, match=f"{tmp_path}.*emps/DATA_EMPS.mat"):
        load("emps")
    monkeypatch.delenv("NLID_DATA_DIR")
    with pytest.raises(DataError, match="set NLID_DATA_DIR"):
        load("silverbox")
    with pytest.raises(InputError, match="did you mean 'emps'"):
        load("emp")


# --------------------------------------------------------------------------- nlid data: presence and checksums
def _copy_benchmark_files(src, dst, names):
    import shutil

    from nlid.data.datasets import BENCHMARKS

    for name in names:
        for f in BENCHMARKS[name].files:
            (dst / f.path).parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(src / f.path, dst / f.path)


def test_check_reports_ok_missing_and_mismatch(data_dir, tmp_path):
    from nlid.data.datasets import BENCHMARKS, check, sha256

    _copy_benchmark_files(data_dir, tmp_path, ["emps", "silverbox"])
    corrupt = tmp_path / "silverbox" / "Schroeder80mV.mat"
    corrupt.write_bytes(corrupt.read_bytes()[:-1] + b"\0")  # one byte changed
    status = {s.file.path: s for s in check(tmp_path)}
    assert set(status) == {f.path for b in BENCHMARKS.values() for f in b.files}
    assert status["emps/DATA_EMPS.mat"].status == "ok"
    assert status["silverbox/SNLS80mV.mat"].status == "ok"
    bad = status["silverbox/Schroeder80mV.mat"]
    assert bad.status == "mismatch" and bad.found_sha256 == sha256(corrupt) != bad.file.sha256
    assert {status[p].status for p in status if p.startswith("boucwen/")} == {"missing"}


def test_check_hashes_a_file_it_was_given(tmp_path):
    """The checksum is SHA-256 of the bytes (a file of known content, no measured data needed)."""
    import hashlib

    from nlid.data.datasets import BENCHMARKS, check

    path = tmp_path / BENCHMARKS["emps"].files[0].path
    path.parent.mkdir()
    path.write_bytes(b"not the EMPS data")
    (emps,) = check(tmp_path, ["emps"])
    assert emps.status == "mismatch" and emps.found_sha256 == hashlib.sha256(b"not the EMPS data").hexdigest()
    with pytest.raises(InputError, match="unknown benchmark 'emp'"):
        check(tmp_path, ["emp"])


def test_nlid_data_command(data_dir, tmp_path, capsys, monkeypatch):
    import json

    from nlid.cli.main import main

    assert main(["data", "--dir", str(data_dir)]) == 0  # the shared folder: every checksum matches
    out = capsys.readouterr().out
    assert "6 files: 6 ok, 0 missing, 0 checksum mismatch(es)" in out
    assert max(len(line) for line in out.splitlines()) <= 100

    _copy_benchmark_files(data_dir, tmp_path, ["emps"])
    (tmp_path / "boucwen").mkdir()
    (tmp_path / "boucwen" / "train_multisine.mat").write_bytes(b"truncated download")
    monkeypatch.setenv("NLID_DATA_DIR", str(tmp_path))
    assert main(["data"]) == 1  # a checksum mismatch fails
    out = capsys.readouterr().out
    assert "6 files: 1 ok, 4 missing, 1 checksum mismatch(es)" in out
    assert "MISMATCH  boucwen/train_multisine.mat" in out and "missing   silverbox/SNLS80mV.mat" in out
    assert main(["data", "emps", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["folder"] == str(tmp_path) and doc["benchmarks"]["emps"]["files"][0]["status"] == "ok"
    monkeypatch.delenv("NLID_DATA_DIR")
    assert main(["data"]) == 0
    assert "NLID_DATA_DIR is not set" in capsys.readouterr().out
