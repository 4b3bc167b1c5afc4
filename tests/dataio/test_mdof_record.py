"""StructureRecord: validation, units per channel, views, derived records, every reader and the writers."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

import nlid
from nlid.data.io import write_csv, write_npz
from nlid.data.record import Record
from nlid.data.structure_record import StructureRecord
from nlid.errors import DataError, InputError


@pytest.fixture(scope="module")
def arrays():
    rng = np.random.default_rng(3)
    return {"z": rng.standard_normal((500, 3)), "f": rng.standard_normal(500), "a": rng.standard_normal((500, 3))}


def test_construction_validation_and_units(arrays):
    rec = StructureRecord(
        f=arrays["f"], z=arrays["z"], a=arrays["a"], fs=100.0, force_dofs=2, units={"z": "mm", "z3": "um"}
    )
    assert rec.n == 500 and rec.n_dofs == 3 and rec.force_dofs == (2,)
    assert rec.channels == ("f2", "z1", "z2", "z3", "a1", "a2", "a3")
    assert np.allclose(rec.z[:, 0], 1e-3 * arrays["z"][:, 0]) and np.allclose(rec.z[:, 2], 1e-6 * arrays["z"][:, 2])
    assert np.array_equal(rec.f[:, 0], np.zeros(500)) and np.array_equal(rec.channel("f2"), arrays["f"])
    assert rec.units["z2"] == "m" and rec.meta["input_units"]["z3"]["unit"] == "µm"
    bad = arrays["z"].copy()
    bad[7, 1] = np.nan
    with pytest.raises(DataError, match="channel z2 has a non-finite value .* at index 7"):
        StructureRecord(f=arrays["f"], z=bad, fs=100.0, force_dofs=(1,))
    flat = arrays["z"].copy()
    flat[:, 2] = 1.0
    with pytest.raises(DataError, match="channel z3 is constant"):
        StructureRecord(f=arrays["f"], z=flat, fs=100.0, force_dofs=(1,))
    with pytest.raises(DataError, match="no force acts"):
        StructureRecord(f=np.zeros((500, 3)), z=arrays["z"], fs=100.0)
    with pytest.raises(DataError, match="f1 is not zero but DOF 1 is not in force_dofs"):
        StructureRecord(f=np.ones((500, 3)) + arrays["z"], z=arrays["z"], fs=100.0, force_dofs=(2, 3))
    with pytest.raises(InputError, match="unknown unit 'furlong' for channel 'z2'"):
        StructureRecord(f=arrays["f"], z=arrays["z"], fs=100.0, force_dofs=(1,), units={"z2": "furlong"})
    with pytest.raises(InputError, match="names DOF 4"):
        StructureRecord(f=arrays["f"], z=arrays["z"], fs=100.0, force_dofs=(1,), units={"z4": "mm"})


def test_dof_views_slices_and_derived_records(chain_record):
    rec = chain_record
    one = rec.dof(1)
    assert isinstance(one, Record) and np.array_equal(one.z, rec.z[:, 0]) and np.array_equal(one.a, rec.a[:, 0])
    assert one.mass == 1.0 and one.meta["dof"] == 1 and "reference" not in one.meta
    with pytest.raises(DataError, match="no force acts on DOF 2"):
        rec.dof(2)
    with pytest.raises(InputError, match="from 1 to 3"):
        rec.dof(4)
    head, tail = rec.split(0.25)
    assert head.n + tail.n == rec.n and tail.t0 == pytest.approx(head.n / rec.fs)
    assert rec[::2].fs == rec.fs / 2 and rec.time_slice(1.0, 2.0).n == int(rec.fs)
    low = rec.decimate(2)
    assert low.fs == rec.fs / 2 and low.force_dofs == rec.force_dofs
    assert "decimated by 2" in low.source_of("z3")
    estimated = rec.without("v", "a").with_derivatives()
    assert estimated.source_of("a2").startswith("estimated from z2") and not estimated.is_measured("v1")
    assert rec.is_measured("a1") and estimated.is_measured("z1")
    # one filter for every DOF: the estimate of a2 is close to the exact one in the band of the response
    err = np.std(estimated.a[500:-500, 1] - rec.a[500:-500, 1]) / np.std(rec.a[:, 1])
    assert err < 0.05
    assert StructureRecord.from_record(one).channels == ("f1", "z1", "v1", "a1")


def test_csv_and_npz_round_trip_with_the_sidecar(chain_record, tmp_path):
    for writer, suffix in ((write_csv, "csv"), (write_npz, "npz")):
        path = writer(chain_record, tmp_path / f"rec.{suffix}")
        back = nlid.load(path)
        assert isinstance(back, StructureRecord) and back.channels == chain_record.channels
        assert np.allclose(back.z, chain_record.z, rtol=1e-10, atol=1e-16)
        assert back.meta["reference"]["coefficients"] == chain_record.meta["reference"]["coefficients"]
        assert back.force_hold == "zoh" and back.meta["loaded"]["sha256"]
    write_csv(chain_record, tmp_path / "some.csv", ("f", "z", "a2"))
    assert (tmp_path / "some.csv").read_text().splitlines()[0].strip() == "t,f1,z1,z2,z3,a2"
    json.loads((tmp_path / "rec.csv.meta.json").read_text())


def test_every_reader_maps_indexed_channels(chain_record, tmp_path):
    rec = chain_record
    table = {"time": rec.t, "load": rec.f[:, 0], "d1": rec.z[:, 0] * 1e3, "d2": rec.z[:, 1] * 1e3, "d3": rec.z[:, 2]}
    table["acc"] = rec.a[:, 0] / 9.80665
    columns = "t=time, f1=load, z1[mm]=d1, z2=d2*0.001, z3=d3, a1[g]=acc"
    frame = pd.DataFrame(table)
    frame.to_csv(tmp_path / "rig.csv", index=False)
    for source in (table, frame, tmp_path / "rig.csv"):
        got = nlid.load(source, columns=columns)
        assert isinstance(got, StructureRecord) and got.n_dofs == 3
        assert np.allclose(got.z, rec.z, rtol=1e-9, atol=1e-15) and np.allclose(got.a[:, 0], rec.a[:, 0], rtol=1e-9)
        assert got.source_of("a1") == "measured" and got.source_of("a3").startswith("estimated from z3")
        assert got.meta["loaded"]["columns"] == columns
    # without a map: columns named like the channels
    plain = pd.DataFrame({"t": rec.t, "f1": rec.f[:, 0], "z1": rec.z[:, 0], "z2": rec.z[:, 1], "z3": rec.z[:, 2]})
    assert isinstance(nlid.load(plain), StructureRecord)
    # one DOF stays a Record
    assert isinstance(nlid.load({"t": rec.t, "f": rec.f[:, 0], "z": rec.z[:, 0]}), Record)


@pytest.mark.parametrize(
    ("columns", "error", "why"),
    [
        ("f=load, z1=d1, z2=d2", InputError, "names both 'f' and 'z1'"),
        ("f1=load, z1=d1, z3=d2", DataError, "no column for z2"),
        ("z1=d1, z2=d2", DataError, "no force column"),
        ("f3=load, z1=d1, z2=d2", DataError, "names DOF 3"),
        ("f1=load, z1[furlong]=d1, z2=d2", InputError, "unknown unit 'furlong' for channel 'z1'"),
    ],
)
def test_reader_errors_are_one_line(columns, error, why):
    rng = np.random.default_rng(0)
    table = {"t": np.arange(100) / 100.0, **{k: rng.standard_normal(100) for k in ("load", "d1", "d2")}}
    with pytest.raises(error, match=why):
        nlid.load(table, columns=columns)


def test_a_one_dof_record_refuses_an_indexed_map():
    table = {"t": np.arange(100) / 100.0, "f": np.sin(np.arange(100.0)), "z": np.cos(np.arange(100.0))}
    with pytest.raises(InputError, match="make a StructureRecord"):
        Record.from_table(table, "f1=f, z1=z")
