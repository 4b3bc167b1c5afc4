"""One surface: each verb run from the command line (``--json``) and from the API on the same input gives the same JSON.

Only what differs by nature is left out of the comparison: wall times (``seconds``) and the paths
each side wrote to. Every number else must be equal.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import nlid
from nlid.base.jsonable import to_jsonable

TERMS = "z^3,z^2,v*|v|"
#: Keys whose values are wall times or say where a side wrote: not the verb's answer.
VOLATILE = {"seconds", "wall_seconds", "elapsed", "elapsed_s", "time_s", "folder", "report", "path"}


def _volatile(key: str, drop: set[str]) -> bool:
    """A wall time (``seconds``, ``method_seconds``...), a measured resource or a path."""
    return key in drop or key.endswith("seconds") or key.endswith("memory_mb")


def _strip(value: Any, drop: set[str] = VOLATILE) -> Any:
    """``value`` without the volatile keys, at any depth."""
    if isinstance(value, dict):
        return {k: _strip(v, drop) for k, v in value.items() if not _volatile(k, drop)}
    if isinstance(value, list):
        return [_strip(v, drop) for v in value]
    return value


def _json(value: Any) -> Any:
    """What ``print_json`` would print, read back."""
    return json.loads(json.dumps(to_jsonable(value), allow_nan=False))


def _assert_same(cli: Any, api: Any, where: str = "") -> None:
    """Equal JSON; the first difference is named with its path."""
    if isinstance(api, dict):
        assert isinstance(cli, dict) and set(cli) == set(api), f"{where}: keys {sorted(cli)} != {sorted(api)}"
        for key in api:
            _assert_same(cli[key], api[key], f"{where}.{key}")
    elif isinstance(api, list):
        assert isinstance(cli, list) and len(cli) == len(api), f"{where}: lengths differ"
        for i, (a, b) in enumerate(zip(cli, api, strict=True)):
            _assert_same(a, b, f"{where}[{i}]")
    else:
        assert cli == api, f"{where}: CLI {cli!r} != API {api!r}"


@pytest.fixture(scope="module")
def record_file(tmp_path_factory) -> Path:
    """A short simulated record (4 s at 1 kHz, 1 % noise on z, v, a), written by ``nlid simulate``."""
    from nlid.cli.main import main

    path = tmp_path_factory.mktemp("parity") / "x.npz"
    argv = ["simulate", "--preset", "paper-numerical", "--seed", "3", "--duration", "4", "--set", "fs=1000"]
    assert main([*argv, "--channels", "v,a", "--noise", "0.01", "--out", str(path)]) == 0
    return path


def test_simulate(cli, tmp_path):
    path = tmp_path / "sim.npz"
    status, out, _ = cli(
        "simulate", "--preset", "paper-numerical", "--seed", "2", "--duration", "3", "--set", "fs=1000",
        "--channels", "z,a", "--noise", "z=0.02,a=0.01", "--out", str(path), "--json",
    )  # fmt: skip
    assert status == 0
    printed = json.loads(out)
    record = nlid.simulate("paper-numerical", seed=2, duration=3, fs=1000, channels="z,a", noise={"z": 0.02, "a": 0.01})
    from nlid.cli.cmd_simulate import simulation_summary

    _assert_same(printed, _json(simulation_summary(record, str(path))))
    assert printed["path"] == str(path) and printed["channels"] == ["t", "f", "z", "a"]
    assert printed["samples"] == 3000 and printed["fs"] == 1000.0 and printed["noise"] == {"z": 0.02, "a": 0.01}
    written = nlid.load(path)  # the file holds the API's record, sample for sample
    for channel in ("f", "z", "a"):
        np.testing.assert_array_equal(getattr(written, channel), getattr(record, channel))
    np.testing.assert_allclose(written.t, record.t, rtol=0, atol=1e-12)  # the time axis is rebuilt from fs


def test_identify(cli, record_file):
    status, out, _ = cli("identify", str(record_file), "--method", "rfs", "--terms", TERMS, "--mass", "0.2", "--json")
    assert status == 0
    api = nlid.identify(nlid.load(record_file), TERMS, "rfs", mass=0.2)
    _assert_same(_strip(json.loads(out)), _strip(_json(api.to_dict())))


def test_compare(cli, record_file):
    argv = ["compare", str(record_file), "--methods", "rfs,sindy", "--terms", TERMS, "--mass", "0.2"]
    status, out, _ = cli(*argv, "--holdout", "0.25", "--rule", "window:50", "--set", "sindy.threshold=0", "--json")
    assert status == 0
    frame = nlid.compare(
        nlid.load(record_file),
        TERMS,
        "rfs,sindy",
        mass=0.2,
        holdout=0.25,
        rule="window:50",
        options={"sindy": {"threshold": "0"}},
    )
    from nlid.cli.cmd_compare import frame_records

    api = [r for r in _json(frame_records(frame)) if r["quantity"] != "seconds"]
    printed = [r for r in json.loads(out) if r["quantity"] != "seconds"]
    _assert_same(printed, api)
    assert {r["method"] for r in printed} == {"rfs", "sindy"}
    assert any(r["quantity"] == "freerun_rmse" and r["name"] == "holdout" for r in printed)


def test_compare_table_and_csv(cli, record_file, tmp_path):
    out_csv = tmp_path / "table.csv"
    status, out, _ = cli(
        "compare", str(record_file), "--methods", "rfs", "--terms", TERMS, "--mass", "0.2", "--out", str(out_csv)
    )
    assert status == 0
    assert out.splitlines()[0].split()[:4] == ["method", "quantity", "name", "value"]
    assert "coefficient" in out and "v*|v|" in out
    import pandas as pd

    table = pd.read_csv(out_csv)
    assert list(table.columns) == ["method", "quantity", "name", "value", "std_error", "unit", "reference",
                                   "error_pct", "note", "force_hold", "force_hold_source"]  # fmt: skip
    assert set(table["force_hold_source"]) == {"the sidecar x.npz.meta.json"}  # the assumption, said (issue 35)
    assert set(table["method"]) == {"rfs"}


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--methods", "rfs,sindy", "--set", "threshold=0"], "name the method whose option it is"),
        (["--methods", "rfs", "--set", "sindy.threshold=0"], "'sindy' is not among the methods compared (rfs)"),
        (["--methods", "rfz"], "unknown"),
        (["--holdout", "1.5"], "--holdout must be a fraction between 0 and 1"),
    ],
)
def test_compare_errors_are_one_line(cli, record_file, argv, message):
    status, out, err = cli("compare", str(record_file), "--terms", TERMS, "--mass", "0.2", *argv)
    assert status == 2 and message in err and out == ""
    assert len(err.strip().splitlines()) == 1


def test_discover(cli, record_file):
    declared = "1, z, z^3, v"
    argv = ["discover", str(record_file), "--declared", declared, "--method", "rfs", "--mass", "0.2"]
    status, out, err = cli(*argv, "--max-steps", "1", "--json")
    assert status == 0
    api = nlid.discover(nlid.load(record_file), declared, "rfs", mass=0.2, max_steps=1)
    printed = json.loads(out)
    _assert_same(_strip(printed), _strip(_json(api.to_dict())))
    assert len(printed["steps"]) == 1
    assert err == ""  # piped, --json: no progress, no stage lines


def test_posterior(cli, record_file):
    argv = ["posterior", str(record_file), "--method", "rfs", "--terms", TERMS, "--mass", "0.2"]
    settings = ["--params", "v*|v|", "--no-bias-correction", "--seed", "1", "--steps", "5000"]
    status, out, err = cli(*argv, *settings, "--json")
    assert status == 0, err
    record = nlid.load(record_file)
    fit = nlid.identify(record, TERMS, "rfs", mass=0.2)
    api = nlid.posterior(record, fit, params="v*|v|", bias_correction=False, seed=1, max_steps=5000)
    _assert_same(_strip(json.loads(out)), _strip(_json(api.to_dict())))


def test_response_of_a_data_file(cli, record_file):
    # the data is identified first, with --mass parsed as nlid identify parses it (a number of kg)
    argv = ["response", str(record_file), "--method", "rfs", "--terms", TERMS, "--mass", "0.2"]
    settings = ["--force", "0.5", "--band", "5:10", "--harmonics", "3", "--no-verify", "--no-backbone"]
    status, out, err = cli(*argv, *settings, "--json")
    assert status == 0, err
    from nlid.response import frequency_response

    fit = nlid.identify(nlid.load(record_file), TERMS, "rfs", mass=0.2)
    api = frequency_response(fit, "0.5", "5:10", harmonics=3, backbone=False)
    _assert_same(_strip(json.loads(out)), _strip(_json(api.to_dict())))


STUDY = """
[study]
name = "parity"
repetitions = 1
identifiers = ["rfs"]

[[datasets]]
name = "short"
preset = "paper-numerical"
overrides = { duration = 3.0, fs = 1000.0 }
noise = { z = 0.01 }
"""


def test_study_run(cli, tmp_path):
    path = tmp_path / "parity.toml"
    path.write_text(STUDY)
    status, out, err = cli("study", "run", str(path), "--out", str(tmp_path / "cli"), "--jobs", "1", "--json")
    assert status == 0, err
    printed = json.loads(out)
    api = nlid.run_study(path, tmp_path / "api", jobs=1)
    expected = api.to_dict()
    assert printed["folder"] == str(tmp_path / "cli") and expected["folder"] == str(tmp_path / "api")
    assert printed["executed"] == 1 and len(printed["results"]) == 1
    _assert_same(_strip(printed), _strip(_json(expected)))
    row = printed["results"][0]
    assert row["status"] == "ok" and row["method"] == "rfs" and math.isfinite(row["eps_percent"])


def test_study_list(cli):
    status, out, _ = cli("study", "list", "--json")
    assert status == 0
    from nlid.study import builtin_studies

    printed = json.loads(out)["studies"]
    assert set(printed) == set(builtin_studies())
    assert all(isinstance(s["description"], str) and s["description"] for s in printed.values())


def test_bench_list(cli):
    status, out, _ = cli("bench", "--list", "--json")
    assert status == 0
    from nlid.benchmarking import builtin_benchmarks, load_protocol

    printed = json.loads(out)["benchmarks"]
    assert list(printed) == list(builtin_benchmarks())
    for name, entry in printed.items():
        p = load_protocol(name)
        assert entry["title"] == p.title and entry["unit"] == p.unit and entry["official"] == bool(p.official)
        assert [(t["name"], t["rule"]) for t in entry["tests"]] == [(t.name, str(t.rule)) for t in p.tests]


def test_every_command_that_answers_has_json():
    """``--json`` on every command whose answer is data (``terms`` and ``data`` included)."""
    from nlid.cli.main import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    missing = []
    for command in sub.choices.values():
        parsers = [command]
        nested = [a for a in command._actions if getattr(a, "choices", None) and isinstance(a.choices, dict)]
        for action in nested:
            parsers = list(action.choices.values())
        for p in parsers:
            if not any("--json" in a.option_strings for a in p._actions):
                missing.append(p.prog)
    assert missing == []


def test_the_numbers_compared_are_not_all_nan(record_file):
    """A guard on the comparison itself: equal JSON means equal numbers, not two empty answers."""
    fit = nlid.identify(nlid.load(record_file), TERMS, "rfs", mass=0.2)
    assert all(math.isfinite(x) for x in fit.coefficients.values())
