"""The data-source layer: files, DataFrames, xarray Datasets and mappings go through one column map
(:mod:`nlid.data.columnmap`) into one Record, and anything else is refused with one line naming it."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

import nlid
from nlid import DataError, InputError, Record
from nlid.data.sources import as_record

MAP = "t=time,f=load_N,z=disp_mm*0.001"


@pytest.fixture(scope="module")
def simulated():
    """A short simulated record (force held over each sample) and the same data without its metadata."""
    record = nlid.simulate("paper-numerical", seed=2, channels="z,v,a", duration=2.0)
    plain = Record.from_time(record.t, f=record.f, z=record.z, v=record.v, a=record.a)
    return record, plain


@pytest.fixture
def frame():
    """A rig's table in its own units; values with six decimals, so that CSV round-trips them exactly."""
    rng = np.random.default_rng(5)
    fs = 500.0
    t = np.arange(300) / fs
    return pd.DataFrame(
        {
            "time": np.round(t, 6),
            "load_N": np.round(3 * np.sin(2 * np.pi * 7 * t) + 0.1 * rng.standard_normal(t.size), 6),
            "disp_mm": np.round(2 * np.cos(2 * np.pi * 5 * t), 6),
            "note": np.arange(t.size),
        }
    )


def _same(a: Record, b: Record) -> None:
    assert a.channels == b.channels and a.fs == b.fs and a.t0 == b.t0
    for channel in a.channels:
        np.testing.assert_array_equal(getattr(a, channel), getattr(b, channel))


@pytest.mark.parametrize("columns", [MAP, {"t": "time", "f": "load_N", "z": "disp_mm*0.001"}])
def test_a_frame_gives_the_record_its_csv_gives(tmp_path, frame, columns):
    path = tmp_path / "rig.csv"
    frame.to_csv(path, index=False)
    from_file = nlid.load(path, columns=columns)
    for record in (
        Record.from_frame(frame, columns),
        nlid.load(frame, columns=columns),
        as_record(frame, columns=columns),
    ):
        _same(record, from_file)
    assert from_file.meta["source"] == str(path) and "source" not in Record.from_frame(frame, columns).meta


def test_a_frame_without_time_takes_fs_and_force_hold(tmp_path, frame):
    table = frame.drop(columns="time")
    path = tmp_path / "rig.csv"
    table.to_csv(path, index=False)
    record = nlid.load(table, columns="f=load_N,z=disp_mm/1000", fs=500.0, force_hold="zoh")
    _same(record, nlid.load(path, columns="f=load_N,z=disp_mm/1000", fs=500.0))
    assert record.force_hold == "zoh"
    assert Record.from_frame(table, "f=load_N,z=disp_mm", fs=500.0, force_hold="zoh").force_hold == "zoh"


def test_the_index_is_a_column_when_it_is_named(frame):
    expected = Record.from_frame(frame, MAP)
    _same(Record.from_frame(frame.set_index("time"), MAP), expected)
    named_t = frame.rename(columns={"time": "t"}).set_index("t")
    _same(Record.from_frame(named_t, "f=load_N,z=disp_mm*0.001"), expected)
    seconds = frame.assign(time=pd.to_timedelta(frame["time"], unit="s")).set_index("time")
    assert Record.from_frame(seconds, MAP).fs == pytest.approx(500.0, rel=1e-9)
    with pytest.raises(DataError, match="no time column 't'"):  # an unnamed index is not time
        Record.from_frame(frame.set_index("time").rename_axis(None), "f=load_N,z=disp_mm")


def test_channels_named_like_the_channels_need_no_map(simulated):
    record, plain = simulated
    frame = pd.DataFrame(record.to_dict())
    _same(nlid.load(frame), plain)
    _same(nlid.load(dict(record.to_dict())), plain)
    _same(nlid.load({"f": record.f, "z": record.z, "fs": record.fs}), plain.without("v", "a"))


def test_identify_on_a_frame_equals_identify_on_the_record(simulated):
    record, plain = simulated
    frame = pd.DataFrame(record.to_dict())
    by_frame = nlid.identify(frame, "z^3, z^2, v*|v|", "rfs", mass=0.2).to_dict()
    by_record = nlid.identify(plain, "z^3, z^2, v*|v|", "rfs", mass=0.2).to_dict()
    by_frame.pop("seconds"), by_record.pop("seconds")
    frame_data, record_data = by_frame.pop("provenance")["data"], by_record.pop("provenance")["data"]
    assert by_frame == by_record
    assert frame_data["record_sha256"] == record_data["record_sha256"]  # the same samples; the sources differ
    assert (frame_data["source"], record_data["source"]) == ("DataFrame", None)


def test_a_record_is_returned_as_is(simulated):
    record, _ = simulated
    assert as_record(record) is record and nlid.load(record) is record
    assert nlid.load(record, force_hold="sampled").force_hold == "sampled"
    with pytest.raises(InputError, match="not to a Record"):
        nlid.load(record, columns=MAP)


@pytest.mark.parametrize(
    "given, named",
    [
        ([1.0, 2.0, 3.0], "list [1.0, 2.0, 3.0]"),
        (3, "int 3"),
        (np.zeros((3, 100)), "numpy.ndarray of shape (3, 100) without column names"),
        (None, "from None;"),
        (pd.Series([1.0, 2.0]), "pandas.Series of shape (2,)"),
    ],
)
@pytest.mark.parametrize("verb", ["load", "identify", "as_record"])
def test_other_types_are_refused_in_one_line_naming_them(given, named, verb):
    call = {
        "load": lambda: nlid.load(given),
        "identify": lambda: nlid.identify(given, "z^3", mass=1.0),
        "as_record": lambda: as_record(given),
    }[verb]
    with pytest.raises(InputError) as caught:
        call()
    message = str(caught.value)
    assert "\n" not in message and named in message and "pandas DataFrame" in message


def test_text_is_not_taken_for_a_file_name(frame):
    with pytest.raises(InputError, match="no line breaks"):
        nlid.load(frame.to_csv(index=False))
    with pytest.raises(DataError, match="not a file name"):
        nlid.load("x" * 300 + ".csv")


def test_identify_without_terms_says_so(simulated):
    record, _ = simulated
    with pytest.raises(InputError, match="terms are missing"):
        nlid.identify(record, None)
    with pytest.raises(InputError, match="terms must be a string.*got int"):
        nlid.identify(record, 3)


def _message(call) -> str:
    with pytest.raises(DataError) as caught:
        call()
    return str(caught.value)


@pytest.mark.parametrize(
    "change, columns",
    [
        (lambda f: f, "t=time,f=nope,z=disp_mm"),  # a missing column
        (lambda f: f.assign(load_N=f["load_N"].where(f.index != 17)), MAP),  # a NaN
        (lambda f: f.assign(time=f["time"].where(f.index != 40, 99.0)), MAP),  # a time axis with a jump
        (lambda f: f.drop(columns="time"), "f=load_N,z=disp_mm"),  # no time and no fs
        (lambda f: f.assign(load_N=f["load_N"].astype(str).where(f.index != 3, "abc")), MAP),  # text
    ],
)
def test_a_frame_fails_with_the_message_a_file_gives(tmp_path, frame, change, columns):
    bad = change(frame)
    path = tmp_path / "bad.csv"
    bad.to_csv(path, index=False)
    from_file = _message(lambda: nlid.load(path, columns=columns))
    from_frame = _message(lambda: nlid.load(bad, columns=columns))
    assert from_frame == from_file.replace(str(path), "DataFrame")


def test_a_missing_channel_names_the_columns_there_are(frame):
    with pytest.raises(DataError, match="no column for channel 'f'.*the DataFrame has: disp_mm, load_N, note, time"):
        Record.from_frame(frame, "t=time,z=disp_mm")
    with pytest.raises(DataError, match="holds dates and times"):
        Record.from_frame(frame.assign(time=pd.Timestamp("2024-01-01") + pd.to_timedelta(frame["time"], unit="s")), MAP)
    with pytest.raises(InputError, match="needs a pandas DataFrame, got dict"):
        Record.from_frame({"f": [1.0]})


def test_a_structured_array_has_names():
    rng = np.random.default_rng(0)
    table = np.zeros(64, dtype=[("force", float), ("z", float)])
    table["force"], table["z"] = rng.standard_normal(64), rng.standard_normal(64)
    record = nlid.load(table, columns="f=force", fs=100.0)
    np.testing.assert_array_equal(record.f, table["force"])


def test_an_xarray_dataset_is_a_table():
    xr = pytest.importorskip("xarray")
    record = nlid.simulate("paper-numerical", seed=2, channels="z", duration=1.0)
    dataset = xr.Dataset(
        {"load": ("time", record.f), "disp_mm": ("time", record.z * 1e3), "gain": 2.0},
        coords={"time": record.t},
    )
    loaded = nlid.load(dataset, columns="t=time,f=load*gain,z=disp_mm/1000")
    expected = Record.from_table(
        {"time": record.t, "load": record.f, "disp_mm": record.z * 1e3, "gain": 2.0},
        "t=time,f=load*gain,z=disp_mm/1000",
    )
    _same(loaded, expected)
    _same(Record.from_xarray(dataset, "t=time,f=load*gain,z=disp_mm/1000"), expected)
    channels = xr.Dataset({"f": ("t", record.f), "z": ("t", record.z)}, coords={"t": record.t})
    assert (
        nlid.identify(channels, "z^3", mass=0.2).coefficients
        == nlid.identify(Record.from_time(record.t, f=record.f, z=record.z), "z^3", mass=0.2).coefficients
    )
    with pytest.raises(DataError, match="column 'nope' not found in Dataset; it has: disp_mm, gain, load, time"):
        nlid.load(dataset, columns="t=time,f=nope,z=disp_mm")
    with pytest.raises(InputError, match="xarray.DataArray of shape"):
        nlid.load(dataset["load"])
