"""The model JSON says where it came from, so the fit can be made again from the JSON alone (issue 23, item 3):
the nlid version, the SHA-256 of the data (of the file, else of the record's samples in a documented byte
order), the column map and units, and the call (terms, method, options, mass)."""

from __future__ import annotations

import dataclasses
import hashlib
import json
import shlex
import struct

import pandas as pd
import pytest

import nlid
from nlid import DataError, IdentifiedModel, InputError
from nlid.cli.common import identify_command
from nlid.data.digest import record_sha256
from nlid.identification.replay import identify_again

TERMS = "z^3, z^2, v*|v|"
COLUMNS = "t=time, f[kN]=load, z=disp, a=acc"
UNITS = {"z": "mm", "a": "g"}
#: The keys of IdentifiedModel.to_dict() before the provenance; they keep their values (the pins check them).
KEYS_BEFORE = [
    "schema", "method", "terms", "coefficients", "standard_errors", "units", "mass", "mass_estimated",
    "mass_standard_error", "px_roots", "equilibria", "modal", "eps_percent", "force_residual_percent", "scores",
    "options", "diagnostics", "warnings", "seconds", "z_range",
]  # fmt: skip


@pytest.fixture(scope="module")
def rig(tmp_path_factory):
    """A rig's CSV in kN, mm and g, and the record it gives."""
    simulated = nlid.simulate("paper-numerical", seed=7, channels="z,a", duration=4.0, noise=0.02)
    frame = pd.DataFrame(
        {"time": simulated.t, "load": simulated.f / 1000, "disp": simulated.z * 1000, "acc": simulated.a / 9.80665}
    )
    path = tmp_path_factory.mktemp("rig") / "rig.csv"
    frame.to_csv(path, index=False, float_format="%.12g")
    return path, nlid.load(path, columns=COLUMNS, units=UNITS)


def _same_fit(a: IdentifiedModel, b: IdentifiedModel) -> None:
    assert a.terms == b.terms and a.mass == pytest.approx(b.mass, rel=1e-12)
    for term, value in a.coefficients.items():
        assert b.coefficients[term] == pytest.approx(value, rel=1e-12, abs=1e-300), term


def test_the_json_says_where_the_model_came_from(rig):
    path, record = rig
    fit = nlid.identify(record, TERMS, "rfs", mass=0.2)
    out = json.loads(json.dumps(fit.to_dict(), allow_nan=False))
    assert list(out)[: len(KEYS_BEFORE)] == KEYS_BEFORE and list(out)[len(KEYS_BEFORE) :] == ["provenance"]
    prov = out["provenance"]
    assert prov["nlid_version"] == nlid.__version__
    data, call = prov["data"], prov["identify"]
    assert data["source"] == str(path) and data["sha256_of"] == "file"
    assert data["sha256"] == hashlib.sha256(path.read_bytes()).hexdigest()
    assert data["record_sha256"] == record_sha256(record) and data["as_loaded"] is True
    assert data["columns"] == COLUMNS and data["fs_given"] is None
    assert data["units"]["f"] == {"unit": "kN", "si": "N", "factor": 1000.0}
    assert data["units"]["z"] == {"unit": "mm", "si": "m", "factor": 0.001}
    assert data["units"]["a"] == {"unit": "g", "si": "m/s^2", "factor": 9.80665}
    assert data["units"]["v"] == {"unit": "m/s", "si": "m/s", "factor": 1.0}
    assert (data["samples"], data["fs"], data["channels"]) == (record.n, record.fs, ["f", "z", "a"])
    assert call == {
        "method": "rfs",
        "terms": ["z^2", "z^3", "v*|v|"],
        "without": [],
        "mass": 0.2,
        "options": dict(fit.options),
        "px_roots": None,
        "px_tol": 1e-4,
        "px_max_iter": 30,
        "cutoff": None,
    }
    again = IdentifiedModel.from_dict(out)
    assert again.provenance == fit.provenance and again.to_dict() == fit.to_dict()


@pytest.mark.parametrize(
    "terms, method, kwargs",
    [
        (TERMS, "rfs", {"mass": 0.2}),
        (TERMS, "rfs", {"mass": 0.2, "options": {"decimate": 2}, "without": "1"}),
        (TERMS, "sindy", {}),  # the mass estimated
        ("z^3, z^2, sign(v)*|px(z)|", "rfs", {"mass": 0.2}),  # px(z) roots iterated
    ],
)
def test_the_fit_is_made_again_from_the_json_alone(rig, terms, method, kwargs):
    _, record = rig
    fit = nlid.identify(record, terms, method, **kwargs)
    text = json.dumps(fit.to_dict(), allow_nan=False)
    del fit  # only the JSON text is left
    stored = IdentifiedModel.from_dict(json.loads(text))
    _same_fit(stored, identify_again(json.loads(text)["provenance"]))


def test_the_recorded_command_repeats_the_fit(rig, capsys):
    from nlid.cli.main import main

    _, record = rig
    fit = nlid.identify(record, TERMS, "rfs", mass=0.2, options={"decimate": 2}, without="1")
    command = identify_command(json.loads(json.dumps(fit.to_dict()))["provenance"])
    assert command.startswith("nlid identify ") and "--units z=mm,a=g" in command and "--without 1" in command
    argv = shlex.split(command)
    assert main([*argv[1:], "--json"]) == 0
    _same_fit(fit, IdentifiedModel.from_dict(json.loads(capsys.readouterr().out)))


def test_the_record_hash_follows_its_documented_byte_order(rig):
    _, record = rig
    digest = hashlib.sha256(b"nlid.Record/1\n")
    digest.update(struct.pack("<dd", record.fs, record.t0))
    for name in ("f", "z", "v", "a"):
        values = getattr(record, name)
        if values is not None:
            digest.update(name.encode() + b"\0" + struct.pack(f"<{values.size}d", *values))
    assert record_sha256(record) == digest.hexdigest()
    assert record_sha256(record[1:]) != record_sha256(record)
    assert record_sha256(record.with_meta(mass=1.0)) == record_sha256(record)  # the samples, not the metadata


def test_a_record_changed_after_loading_is_flagged(rig):
    _, record = rig
    fit = nlid.identify(record[100:], TERMS, "rfs", mass=0.2)
    data = fit.provenance["data"]
    assert data["as_loaded"] is False and data["samples"] == record.n - 100
    assert identify_command(fit.provenance) is None
    with pytest.raises(InputError, match="the record was changed after loading"):
        identify_again(fit.provenance)


def test_a_changed_file_is_refused(rig, tmp_path):
    path, _ = rig
    copy = tmp_path / "copy.csv"
    copy.write_bytes(path.read_bytes())
    fit = nlid.identify(nlid.load(copy, columns=COLUMNS, units=UNITS), TERMS, "rfs", mass=0.2)
    copy.write_text(copy.read_text().replace("time,", "time ,", 1))
    with pytest.raises(InputError, match="has changed since the model was identified"):
        identify_again(fit.provenance)


def test_data_from_python_are_hashed_by_their_samples(rig):
    path, record = rig
    frame = pd.read_csv(path)
    fit = nlid.identify(nlid.load(frame, columns=COLUMNS, units=UNITS), TERMS, "rfs", mass=0.2)
    data = fit.provenance["data"]
    assert data["source"] == "DataFrame" and data["sha256_of"] == "record"
    assert data["sha256"] == data["record_sha256"] == record_sha256(record)
    assert identify_command(fit.provenance) is None
    with pytest.raises(InputError, match="not a file: give it as source="):
        identify_again(fit.provenance)
    _same_fit(fit, identify_again(fit.provenance, source=frame))


def test_a_model_made_otherwise_has_no_provenance(rig):
    _, record = rig
    fit = nlid.identify(record, TERMS, "rfs", mass=0.2)
    bare = dataclasses.replace(fit, provenance={})
    assert bare.to_dict()["provenance"] is None and IdentifiedModel.from_dict(bare.to_dict()).provenance == {}
    with pytest.raises(InputError, match="lacks its 'data' or 'identify' part"):
        identify_again({})


def test_a_bundled_benchmark_is_named_as_such():
    try:
        record = nlid.load("dataset:emps")
    except DataError as exc:
        pytest.skip(f"EMPS data not available: {exc}")
    fit = nlid.identify(record, "sign(v)", "rfs", without="z")
    data = fit.provenance["data"]
    assert data["source"] == "dataset:emps" and data["sha256_of"] == "record" and data["as_loaded"] is True
    command = identify_command(fit.provenance)
    assert command.startswith("nlid identify dataset:emps --method rfs --terms 'sign(v)' --without z --set")
    _same_fit(fit, identify_again(fit.provenance))
