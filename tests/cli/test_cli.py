"""The command line: happy paths, JSON contract, and one-line errors with exit status 2."""

import json
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

from nlid.cli.main import main


@pytest.fixture(scope="module")
def csv_exact(tmp_path_factory):
    path = tmp_path_factory.mktemp("cli") / "x.csv"
    assert (
        main(["simulate", "--preset", "paper-numerical", "--seed", "0", "--channels", "v,a", "--out", str(path)]) == 0
    )
    return path


def test_simulate_writes_the_preset(csv_exact):
    frame = pd.read_csv(csv_exact)
    assert list(frame.columns) == ["t", "f", "z", "v", "a"] and len(frame) == 122_880


def test_simulate_default_columns(tmp_path, cli):
    out = tmp_path / "y.csv"
    status, _, err = cli(
        "simulate", "--preset", "paper-numerical", "--duration", "2", "--noise", "0.02", "--out", str(out)
    )
    assert status == 0 and "wrote 4096 samples" in err
    assert list(pd.read_csv(out).columns) == ["t", "f", "z"]


def test_identify_json_contract(csv_exact, cli):
    status, out, _ = cli(
        "identify", str(csv_exact), "--method", "rfs", "--terms", "z^3,z^2,v*|v|", "--mass", "0.2", "--json"
    )
    assert status == 0
    data = json.loads(out)
    for key in ("method", "coefficients", "mass", "equilibria", "modal", "eps_percent", "diagnostics", "seconds"):
        assert key in data
    assert data["method"] == "rfs" and data["mass"] == 0.2
    assert data["coefficients"]["z"] == pytest.approx(-500, rel=1e-3)
    assert set(data["equilibria"]) == {"stable", "unstable"} and len(data["equilibria"]["stable"]) == 2
    modal = data["modal"][0]
    assert set(modal) >= {"equilibrium", "fn_hz", "zeta"} and 0 < modal["zeta"] < 1


def test_identify_table(csv_exact, cli):
    status, out, _ = cli("identify", str(csv_exact), "--terms", "z^3,z^2,v*|v|", "--mass", "0.2")
    assert status == 0 and "v*|v|" in out and "N*s^2/m^2" in out and "epsilon (Eq. 26)" in out


def test_methods_and_terms(cli):
    status, out, _ = cli("methods")
    assert status == 0 and out.startswith("Which method?") and "rfs: first choice" in out
    assert "--set cutoff" not in out and "2 options: nlid methods rfs" in out  # options on request
    assert max(len(line) for line in out.splitlines()) <= 100
    status, out, _ = cli("methods", "rfs")
    assert status == 0 and "--set cutoff" in out and "Which method?" not in out and "sindy" not in out
    status, out, _ = cli("methods", "--all")
    assert "--set cutoff" in out and "--set library=<str> [terms|automatic]" in out
    status, _, err = cli("methods", "rfx")
    assert status == 2 and "did you mean 'rfs'" in err
    status, out, _ = cli("methods", "--json")
    assert "rfs" in json.loads(out)["methods"]
    status, out, _ = cli("terms")
    assert status == 0 and "sign(v)*|px(z)|" in out
    status, out, _ = cli("terms", "sign(v)*|v|^2")
    assert out.startswith("v*|v|")


@pytest.fixture(scope="module")
def nan_csv(tmp_path_factory):
    path = tmp_path_factory.mktemp("bad") / "nan.csv"
    t = np.arange(100) / 100
    z = np.sin(t)
    z[42] = np.nan
    pd.DataFrame({"t": t, "f": np.cos(t), "z": z}).to_csv(path, index=False)
    return path


BAD = [
    (["identify", "missing.csv"], "file not found"),
    (["identify", "{nan}"], "'z' has a non-finite value (nan) at index 42"),
    (["identify", "{csv}", "--terms", "z^^3", "--mass", "0.2"], "at character 3 of 'z^^3'"),
    (["identify", "{csv}", "--terms", "q^3"], "unknown name 'q'"),
    (["identify", "{csv}", "--method", "nope"], "unknown method 'nope'"),
    (["identify", "{csv}", "--set", "cutof=3"], "did you mean 'cutoff'"),
    (["identify", "{csv}", "--set", "decimate=many"], "expects an integer"),
    (["identify", "{csv}", "--set", "oops"], "--set expects key=value"),
    (["identify", "{csv}", "--mass", "-1"], "mass must be a positive"),
    (["identify", "{csv}", "--columns", "f=nope,z=z"], "column 'nope' not found"),
    (["identify", "{csv}", "--px-roots", "1"], "--px-roots expects two numbers"),
    (["simulate", "--preset", "paper", "--out", "x.csv"], "unknown preset 'paper'"),
    (["simulate", "--preset", "paper-numerical", "--out", "x.txt"], "must end in .csv or .npz"),
    (["simulate", "--preset", "paper-numerical", "--channels", "q", "--out", "x.csv"], "unknown channel 'q'"),
    (["identify", "{csv}", "--mass", "abc"], "--mass must be a number of kg, 'estimate', a matrix"),
]


def _status(argv):
    """Exit status of the CLI, whether it returns or exits (argparse errors)."""
    try:
        return main(argv)
    except SystemExit as exc:
        return exc.code


@pytest.mark.parametrize("argv, message", BAD, ids=[" ".join(a[:3]) for a, _ in BAD])
def test_bad_input_is_one_line_and_status_2(argv, message, csv_exact, nan_csv, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    status = _status([a.format(csv=csv_exact, nan=nan_csv) for a in argv])
    err = capsys.readouterr().err
    assert status == 2
    assert message in err, err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err


def test_debug_shows_the_traceback():
    from nlid import DataError

    with pytest.raises(DataError):
        main(["--debug", "identify", "missing.csv"])


def test_installed_console_script(tmp_path):
    """The real `nlid` entry point: --help for newcomers and a one-line error."""
    exe = [sys.executable, "-m", "nlid.cli.main"]
    help_text = subprocess.run([*exe, "--help"], capture_output=True, text=True, check=True).stdout
    assert "identify" in help_text and "examples:" in help_text
    sub_help = subprocess.run([*exe, "identify", "--help"], capture_output=True, text=True, check=True).stdout
    assert "--terms" in sub_help and "--mass" in sub_help
    bad = subprocess.run([*exe, "identify", str(tmp_path / "none.csv")], capture_output=True, text=True)
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1 and "Traceback" not in bad.stderr


def test_force_hold_from_the_sidecar_and_the_option(tmp_path, capsys):
    from nlid.cli.common import load_data
    from nlid.cli.main import build_parser

    out = tmp_path / "h.csv"
    assert main(["simulate", "--preset", "paper-numerical", "--duration", "2", "--out", str(out)]) == 0
    args = build_parser().parse_args(["identify", str(out)])
    assert load_data(args).force_hold == "zoh"
    args = build_parser().parse_args(["identify", str(out), "--force-hold", "sampled"])
    assert load_data(args).force_hold == "sampled"
