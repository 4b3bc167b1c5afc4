"""Loaders of the shared measured benchmarks (read from $NLID_DATA_DIR)."""

import numpy as np
import pytest

from nlid import DataError, InputError, identify
from nlid.datasets import SILVERBOX_ARROW, SILVERBOX_FS, load


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
