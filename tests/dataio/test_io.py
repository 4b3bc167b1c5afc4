import numpy as np
import pandas as pd
import pytest

from nlid import DataError, InputError
from nlid.data.columnmap import parse_columns
from nlid.data.io import read_record, write_csv, write_npz


@pytest.fixture
def table(tmp_path):
    fs = 200.0
    t = np.arange(400) / fs
    frame = pd.DataFrame({"time": t, "volts": np.sin(7 * t), "disp_mm": 1000 * np.cos(3 * t)})
    path = tmp_path / "test.csv"
    frame.to_csv(path, index=False)
    return path, frame


def test_column_map_with_scales(table):
    path, frame = table
    rec = read_record(path, "t=time, f=volts*35.15, z=disp_mm/1000")
    assert rec.fs == pytest.approx(200.0)
    np.testing.assert_allclose(rec.f, 35.15 * frame["volts"])
    np.testing.assert_allclose(rec.z, frame["disp_mm"] / 1000)
    neg = read_record(path, "t=time, f=-volts*2, z=disp_mm")
    np.testing.assert_allclose(neg.f, -2 * frame["volts"])


def test_round_trip_csv_and_npz(tmp_path, short_record):
    csv = write_csv(short_record, tmp_path / "r.csv")
    back = read_record(csv)
    np.testing.assert_allclose(back.z, short_record.z, rtol=1e-11)
    assert back.channels == short_record.channels and back.fs == pytest.approx(short_record.fs)
    npz = write_npz(short_record, tmp_path / "r.npz")
    again = read_record(npz)
    np.testing.assert_array_equal(again.a, short_record.a)


def test_mat_with_scalar_scale(tmp_path):
    from scipy.io import savemat

    n = 100
    savemat(
        tmp_path / "m.mat",
        {
            "vir": np.sin(np.arange(n))[:, None],
            "qm": np.cos(np.arange(n))[:, None],
            "gtau": np.array([[35.0]]),
            "fs": np.array([[1000.0]]),
        },
    )
    rec = read_record(tmp_path / "m.mat", "f=vir*gtau, z=qm")
    assert rec.fs == 1000.0
    np.testing.assert_allclose(rec.f, 35.0 * np.sin(np.arange(n)))


@pytest.mark.parametrize(
    "spec, message",
    [
        ("f=volts, q=disp_mm", "unknown channel 'q'"),
        ("f=volts*, z=disp_mm", "expected a column name or a number"),
        ("f=volts+1, z=disp_mm", "unexpected '\\+'"),
        ("f=3", "names no column"),
        ("fvolts", "must look like channel=column"),
        ("f=a, f=b", "twice"),
    ],
)
def test_bad_column_maps(spec, message):
    with pytest.raises(InputError, match=message):
        parse_columns(spec)


def test_bad_files(tmp_path, table):
    path, frame = table
    with pytest.raises(DataError, match="file not found"):
        read_record(tmp_path / "missing.csv")
    with pytest.raises(DataError, match="column 'nope' not found.*it has"):
        read_record(path, "t=time, f=nope, z=disp_mm")
    with pytest.raises(DataError, match="no column for channel 'f'"):
        read_record(path, "t=time, z=disp_mm")
    with pytest.raises(DataError, match="no time column"):
        read_record(path, "f=volts, z=disp_mm")
    bad = frame.copy()
    bad.loc[17, "volts"] = np.nan
    bad.to_csv(tmp_path / "nan.csv", index=False)
    with pytest.raises(DataError, match="'f' has a non-finite value.*index 17"):
        read_record(tmp_path / "nan.csv", "t=time, f=volts, z=disp_mm")
    text = tmp_path / "text.csv"
    text.write_text("t,f,z\n0,1,2\n0.1,abc,3\n")
    with pytest.raises(DataError, match="non-numeric value 'abc' at row 2"):
        read_record(text)
    garbage = tmp_path / "garbage.npz"
    garbage.write_bytes(b"not a zip file")
    with pytest.raises(DataError, match="cannot read"):
        read_record(garbage)
    with pytest.raises(DataError, match="unknown file type"):
        (tmp_path / "x.xlsx").write_text("x")
        read_record(tmp_path / "x.xlsx")


def test_npz_with_pickled_objects_is_refused(tmp_path):
    path = tmp_path / "p.npz"
    np.savez(path, f=np.arange(50.0), z=np.array([{"a": 1}] * 50, dtype=object))
    with pytest.raises(DataError, match="pickled"):
        read_record(path, fs=10.0)


def test_metadata_sidecar_round_trip(tmp_path, numerical):
    rec = numerical.with_overrides(duration=2.0).simulate(3, noise=0.01, channels=("z",))
    path = write_csv(rec, tmp_path / "sim.csv")
    assert (tmp_path / "sim.csv.meta.json").is_file()
    back = read_record(path)
    assert back.force_hold == "zoh" and back.mass == 0.2
    assert back.meta["truth"]["coefficients"]["v*|v|"] == 5.0 and back.meta["seed"] == 3
    assert read_record(path, meta={"force_hold": "sampled"}).force_hold == "sampled"
    (tmp_path / "sim.csv.meta.json").write_text("{not json")
    with pytest.raises(DataError, match="cannot read the metadata file"):
        read_record(path)
