"""``nlid discover``: the JSON contract, the report, and one-line errors with exit status 2."""

from __future__ import annotations

import json

import pytest

from nlid.cli.main import main

DECLARED = "1, z, z^2, z^3, v"  # paper-numerical without its quadratic damping


@pytest.fixture(scope="module")
def csv_noisy(tmp_path_factory):
    path = tmp_path_factory.mktemp("discover") / "x.csv"
    argv = ["simulate", "--preset", "paper-numerical", "--seed", "4", "--duration", "12", "--noise", "0.01"]
    assert main([*argv, "--out", str(path)]) == 0
    return path


def test_discover_json_and_report(csv_noisy, cli, tmp_path):
    status, out, err = cli("discover", str(csv_noisy), "--declared", DECLARED, "--json", "--out", str(tmp_path / "rep"))
    assert status == 0, err
    data = json.loads(out)
    for key in ("method", "declared", "eps_initial", "eps_final", "eps_initial_holdout", "eps_final_holdout"):
        assert key in data
    assert data["method"] == "rfs" and data["declared"] == ["1", "z", "z^2", "z^3", "v"]
    assert [s["effect"] for s in data["steps"]] == ["quadratic-damping"]
    assert data["steps"][0]["terms"] == ["v*|v|"] and "v*|v|" in data["final_terms"]
    assert set(data["coefficients"]) == set(data["final_terms"])
    # piped stderr: no stage lines (a terminal shows them: tests/cli/test_cli_progress.py); what was written, yes
    assert "step 1: accepted" not in err and "report written" in err
    assert (tmp_path / "rep" / "report.html").is_file() and (tmp_path / "rep" / "figures" / "residual_1.png").is_file()


def test_discover_table(csv_noisy, cli):
    status, out, err = cli(
        "discover",
        str(csv_noisy),
        "--declared",
        DECLARED,
        "--candidates",
        "quadratic-damping,coulomb",
        "--mass",
        "0.2",
        "--quiet",
    )
    assert status == 0 and err == ""
    assert "+ quadratic-damping: v*|v|" in out and "eps: Eq. 26" in out and "mass: 0.2 kg (given)" in out
    assert max(map(len, out.splitlines())) <= 100


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--candidates", "colomb"], "unknown candidate 'colomb' (did you mean 'coulomb'?)"),
        (["--candidate", "drag"], "NAME=TERMS"),
        (["--candidate", "drag=v*w"], "candidate 'drag'"),
        (["--holdout", "1.5"], "--holdout: a fraction must lie between 0 and 1"),
        (["--holdout", "no_such_file.csv"], "file not found"),
        (["--method", "nope"], "unknown method 'nope'"),
        (["--min-explained", "2"], "min_explained must lie between 0 and 1"),
        (["--set", "cutof=3"], "unknown option 'cutof'"),
    ],
)
def test_bad_input_is_one_line_with_status_2(csv_noisy, cli, extra, message):
    status, out, err = cli("discover", str(csv_noisy), "--declared", DECLARED, "--quiet", *extra)
    assert status == 2 and out == ""
    assert message in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err


def test_bad_declared_term_and_missing_declared(csv_noisy, cli, capfd):
    status, _, err = cli("discover", str(csv_noisy), "--declared", "z^3, w")
    assert status == 2 and "unknown" in err and len(err.strip().splitlines()) == 1
    with pytest.raises(SystemExit) as exit_info:
        main(["discover", str(csv_noisy)])
    assert exit_info.value.code == 2 and "--declared" in capfd.readouterr().err
