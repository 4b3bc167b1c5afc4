"""Files users have: MATLAB v7.3 (HDF5) .mat, plain HDF5 and Parquet, with the column map of every other source
(issue 23, item 2). The files are written here by h5py and pyarrow; a v7.3 file is HDF5 behind a 512-byte
MATLAB header, with a ``MATLAB_class`` attribute on each variable and every array stored transposed."""

from __future__ import annotations

import json
import sys

import numpy as np
import pandas as pd
import pytest

import nlid
from nlid import DataError, Record
from nlid.data.io import read_record, read_table

h5py = pytest.importorskip("h5py")
pq = pytest.importorskip("pyarrow.parquet")
pa = pytest.importorskip("pyarrow")

FS = 200.0
N = 600


@pytest.fixture(scope="module")
def data():
    """A rig's channels in its own units: force in V (gain gtau to N), displacement in mm, acceleration in g."""
    rng = np.random.default_rng(11)
    t = np.arange(N) / FS
    return {
        "t": t,
        "vir": np.sin(2 * np.pi * 3 * t) + 0.05 * rng.standard_normal(N),
        "qm": 4.0 * np.cos(2 * np.pi * 2 * t) + 0.01 * rng.standard_normal(N),
        "acc": 0.3 * np.sin(2 * np.pi * 5 * t),
        "gtau": 35.15,
    }


def _expected(data):
    return Record.from_time(
        data["t"], f=data["vir"] * data["gtau"], z=data["qm"] / 1000, a=data["acc"] * 9.80665, meta={"source": "x"}
    )


def _same(record: Record, expected: Record, rtol: float = 0.0) -> None:
    assert record.channels == expected.channels and record.fs == pytest.approx(expected.fs, rel=1e-12)
    for c in expected.channels:
        np.testing.assert_allclose(getattr(record, c), getattr(expected, c), rtol=rtol, atol=0)


# --------------------------------------------------------------------------- MATLAB v7.3
MATLAB_HEADER = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Jan  6 10:00:00 2025 HDF5 schema 1.00 ."


def _matlab_dataset(group, name, value):
    """One MATLAB variable as MATLAB writes it: column-major, so HDF5 holds the transpose."""
    if isinstance(value, str):
        ds = group.create_dataset(name, data=np.array([[ord(c)] for c in value], dtype=np.uint16))
        ds.attrs["MATLAB_class"] = np.bytes_("char")
        ds.attrs["MATLAB_int_decode"] = np.int32(2)
        return
    array = np.atleast_2d(np.asarray(value))
    if array.shape[0] == 1 and np.ndim(value) == 1:
        array = array.T  # a MATLAB column vector, N x 1
    if np.iscomplexobj(array):
        stored = np.empty(array.T.shape, dtype=[("real", "<f8"), ("imag", "<f8")])
        stored["real"], stored["imag"] = array.T.real, array.T.imag
        ds = group.create_dataset(name, data=stored)
        ds.attrs["MATLAB_class"] = np.bytes_("double")
        return
    ds = group.create_dataset(name, data=array.T)
    ds.attrs["MATLAB_class"] = np.bytes_("logical" if array.dtype == bool else "double")


def write_mat73(path, variables, structs=None, cells=(), sparse=()):
    """A MATLAB v7.3 file: HDF5 with a 512-byte user block holding MATLAB's 128-byte header."""
    with h5py.File(path, "w", userblock_size=512) as f:
        for name, value in variables.items():
            _matlab_dataset(f, name, value)
        for name, fields in (structs or {}).items():
            group = f.create_group(name)
            group.attrs["MATLAB_class"] = np.bytes_("struct")
            for field, value in fields.items():
                _matlab_dataset(group, field, value)
        refs = f.create_group("#refs#")
        for name in cells:
            inner = refs.create_dataset(f"{name}_0", data=np.arange(3.0)[:, None])
            inner.attrs["MATLAB_class"] = np.bytes_("double")
            ds = f.create_dataset(name, data=np.array([[inner.ref]], dtype=h5py.ref_dtype))
            ds.attrs["MATLAB_class"] = np.bytes_("cell")
        for name in sparse:
            group = f.create_group(name)
            group.attrs["MATLAB_class"] = np.bytes_("double")
            group.attrs["MATLAB_sparse"] = np.uint64(3)
            group.create_dataset("data", data=np.ones(2))
            group.create_dataset("ir", data=np.array([0, 2], dtype=np.uint64))
            group.create_dataset("jc", data=np.array([0, 1, 2], dtype=np.uint64))
    header = MATLAB_HEADER.ljust(116, b" ") + b"\0" * 8 + b"\x00\x02IM"  # text, subsystem offset, version, endian
    with open(path, "r+b") as handle:
        handle.write(header)
    return path


@pytest.fixture
def mat73(tmp_path, data):
    return write_mat73(
        tmp_path / "rig73.mat",
        {"t": data["t"], "vir": data["vir"], "qm": data["qm"], "acc": data["acc"], "gtau": data["gtau"]},
        structs={"run": {"disp": data["qm"], "fs": FS}},
        cells=("notes",),
        sparse=("mask",),
    )


def test_a_v73_mat_file_reads_as_its_v7_twin(tmp_path, data, mat73):
    from scipy.io import savemat

    v7 = tmp_path / "rig7.mat"
    savemat(v7, {k: (np.asarray(v)[:, None] if np.ndim(v) else v) for k, v in data.items()})
    columns = "f=vir*gtau, z[mm]=qm, a[g]=acc"
    new = read_record(mat73, columns)
    _same(new, read_record(v7, columns))
    _same(new, _expected(data), rtol=1e-15)
    assert new.meta["input_units"]["z"] == {"unit": "mm", "si": "m", "factor": 0.001}
    _same(nlid.load(str(mat73), columns="f=vir*gtau, z=qm", units={"z": "mm"}), new.without("a"))


def test_v73_arrays_have_matlab_shapes(tmp_path, data):
    """HDF5 holds MATLAB's column-major arrays transposed: they are turned back."""
    matrix = np.column_stack([data["t"], data["qm"], data["vir"]])  # N x 3 in MATLAB
    path = write_mat73(tmp_path / "m.mat", {"M": matrix, "row": data["qm"][None, :], "flag": np.array([[True]])})
    table = read_table(path)
    assert table["M"].shape == (N, 3) and table["row"].shape == (1, N)
    np.testing.assert_array_equal(table["M"][:, 1], data["qm"])
    record = read_record(path, "f=row, z=row*2", fs=FS)
    np.testing.assert_array_equal(record.z, 2 * data["qm"])
    with pytest.raises(DataError, match=r"'M' .* is an array of shape \(600, 3\); a channel needs one dimension"):
        read_record(path, "f=row, z=M", fs=FS)


def test_v73_struct_fields_are_paths(data, mat73):
    record = read_record(mat73, 'f=vir, z="run/disp"')  # fs from the time column
    np.testing.assert_array_equal(record.z, data["qm"])
    record = read_record(mat73, "f=vir, z='/run/disp'*0.001", fs=None)
    np.testing.assert_allclose(record.z, data["qm"] / 1000, rtol=1e-15)


@pytest.mark.parametrize(
    "columns, says",
    [
        ("f=vir, z=notes", r"holds objects \(a cell array or strings\), not numbers"),
        ("f=vir, z=mask", r"is a sparse matrix; save it with full\(\) first"),
        ("f=vir, z=label", "holds text, not numbers"),
        ("f=vir, z=cplx", "holds complex numbers"),
    ],
)
def test_v73_variables_that_are_not_numbers_are_named(tmp_path, data, columns, says):
    path = write_mat73(
        tmp_path / "odd.mat",
        {"t": data["t"], "vir": data["vir"], "label": "run 3", "cplx": data["qm"] * (1 + 1j)},
        cells=("notes",),
        sparse=("mask",),
    )
    with pytest.raises(DataError, match=says):
        read_record(path, columns)
    read_record(path, "f=vir, z=vir*2")  # unused odd variables are never read
    assert sorted(read_table(path)) == ["cplx", "label", "notes", "t", "vir"]  # the sparse matrix is left out


def test_v73_objects_are_not_numbers(tmp_path, data):
    path = write_mat73(tmp_path / "obj.mat", {"t": data["t"], "vir": data["vir"]})
    with h5py.File(path, "a") as f:
        f.create_dataset("s", data=np.arange(6, dtype=np.uint32)[None, :]).attrs["MATLAB_class"] = np.bytes_("string")
    with pytest.raises(DataError, match="variable 's' in .* is a MATLAB string, not an array of numbers"):
        read_record(path, "f=vir, z=s")


# --------------------------------------------------------------------------- HDF5
@pytest.fixture
def h5(tmp_path, data):
    path = tmp_path / "rig.h5"
    with h5py.File(path, "w") as f:
        f["vir"] = data["vir"]
        f["gtau"] = data["gtau"]
        f["fs"] = FS
        group = f.create_group("data")
        group["disp_mm"] = data["qm"]
        group.create_group("sensors")["acc"] = data["acc"][:, None]  # an N x 1 column
        f["notes"] = "bench 2"
    return path


@pytest.mark.parametrize(
    "columns, units",
    [
        ('f=vir*gtau, z[mm]="data/disp_mm", a[g]="data/sensors/acc"', None),
        ('f=vir*gtau, z="/data/disp_mm", a="/data/sensors/acc"', {"z": "mm", "a": "g"}),
    ],
)
def test_hdf5_datasets_are_columns_named_by_their_path(h5, data, columns, units):
    record = nlid.load(h5, columns=columns, units=units)
    expected = _expected(data)
    _same(record, Record(expected.f, expected.z, FS, a=expected.a), rtol=1e-15)
    assert sorted(read_table(h5)) == ["data/disp_mm", "data/sensors/acc", "fs", "gtau", "notes", "vir"]


def test_hdf5_errors_are_one_line(h5):
    with pytest.raises(DataError, match=r"column 'disp' not found in .*rig.h5; it has: data/disp_mm, "):
        read_record(h5, "f=vir, z=disp")
    with pytest.raises(DataError, match="'notes' in .* holds text, not numbers"):
        read_record(h5, "f=vir, z=notes")


# --------------------------------------------------------------------------- Parquet
def test_a_parquet_file_reads_as_its_csv_and_frame(tmp_path, data):
    frame = pd.DataFrame({"zeit_ms": data["t"] * 1000, "kraft_N": data["vir"], "weg_µm": data["qm"] * 1000})
    path = tmp_path / "rig.parquet"
    pq.write_table(pa.Table.from_pandas(frame, preserve_index=False), path)
    csv = tmp_path / "rig.csv"
    frame.to_csv(csv, index=False, float_format="%.17g")
    columns = "t[ms]=zeit_ms, f=kraft_N, z[µm]=weg_µm"
    record = nlid.load(path, columns=columns)
    _same(record, nlid.load(csv, columns=columns))
    _same(record, Record.from_frame(frame, columns))
    np.testing.assert_allclose(record.z, data["qm"] / 1000, rtol=1e-14)
    assert record.fs == pytest.approx(FS, rel=1e-9)


# --------------------------------------------------------------------------- optional packages
@pytest.mark.parametrize(
    "module, suffix, extra",
    [("h5py", ".h5", "nlid[hdf5]"), ("h5py", ".mat", "nlid[hdf5]"), ("pyarrow", ".parquet", "nlid[parquet]")],
)
def test_a_missing_optional_package_names_its_extra(tmp_path, data, monkeypatch, module, suffix, extra):
    path = tmp_path / f"rig{suffix}"
    if suffix == ".mat":
        write_mat73(path, {"t": data["t"], "vir": data["vir"]})
    elif suffix == ".h5":
        with h5py.File(path, "w") as f:
            f["vir"] = data["vir"]
    else:
        pq.write_table(pa.table({"vir": data["vir"]}), path)
    for name in [m for m in sys.modules if m == module or m.startswith(module + ".")]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, module, None)  # import fails as if it were not installed
    with pytest.raises(DataError) as caught:
        read_record(path, "f=vir, z=vir", fs=FS)
    message = str(caught.value)
    assert f"pip install '{extra}'" in message and module.split(".")[0] in message and "\n" not in message


# --------------------------------------------------------------------------- the command line
@pytest.mark.parametrize("kind", ["mat73", "h5", "parquet"])
def test_identify_reads_each_file_type(tmp_path, data, mat73, h5, kind, capsys):
    from nlid.cli.main import main

    if kind == "parquet":
        path = tmp_path / "rig.parquet"
        frame = pd.DataFrame({"t": data["t"], "vir": data["vir"], "qm": data["qm"]})
        pq.write_table(pa.Table.from_pandas(frame, preserve_index=False), path)
        columns = "f=vir*35.15,z[mm]=qm"
    else:
        path = mat73 if kind == "mat73" else h5
        columns = "f=vir*gtau,z[mm]=qm" if kind == "mat73" else 'f=vir*gtau,z[mm]="data/disp_mm"'
    status = main(["identify", str(path), "--columns", columns, "--terms", "z^3", "--mass", "1", "--json"])
    out = capsys.readouterr()
    assert status == 0, out.err
    result = json.loads(out.out)
    assert result["provenance"]["data"]["units"]["z"]["unit"] == "mm"
    assert result["provenance"]["data"]["sha256_of"] == "file"
