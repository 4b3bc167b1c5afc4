"""nlid posterior: JSON contract, files, and one-line errors."""

import json

import pytest

from nlid.cli.main import main


@pytest.fixture(scope="module")
def csv_noisy(tmp_path_factory):
    """20 s of paper-numerical, 2 % noise, channels f, z, a."""
    path = tmp_path_factory.mktemp("posterior") / "x.csv"
    argv = ["simulate", "--preset", "paper-numerical", "--seed", "4", "--duration", "20", "--noise", "0.02"]
    assert main([*argv, "--channels", "a", "--out", str(path)]) == 0
    return path


TERMS = ("--terms", "z^3,z^2,v*|v|", "--mass", "0.2")


def test_json_contract(csv_noisy, cli):
    status, out, err = cli("posterior", str(csv_noisy), *TERMS, "--params", "v*|v|", "--json", "--seed", "1")
    assert status == 0, err
    doc = json.loads(out)
    assert set(doc) >= {"params", "tau", "acceptance", "n_effective", "seconds"}
    assert list(doc["params"]) == ["v*|v|"]
    s = doc["params"]["v*|v|"]
    assert set(s) == {"mean", "sd", "q05", "q50", "q95"}
    assert s["q05"] < s["q50"] < s["q95"] and s["sd"] > 0 and doc["others"] == "marginal"


def test_table_and_files(csv_noisy, tmp_path, cli):
    out_dir = tmp_path / "post"
    status, out, err = cli("posterior", str(csv_noisy), *TERMS, "--out", str(out_dir), "--no-figures")
    assert status == 0, err
    assert "v*|v|" in out and "N*s^2/m^2" in out and "tau" in out and "integrated out (not sampled)" in out
    assert (out_dir / "posterior_samples.npz").is_file() and (out_dir / "posterior_table.csv").is_file()
    assert "wrote" in err


@pytest.mark.parametrize(
    "extra, message",
    [
        (("--prior", "v*|v|=gauss(5,1)"), "cannot read the prior 'gauss(5,1)'"),
        (("--prior", "v*|v|=uniform(0,1)"), "excludes the identifier's estimate"),
        (("--params", "sign(v)"), "does not contain"),
        (("--params", "v+"), "v+"),
        (("--walkers", "1"), "--walkers"),
    ],
)
def test_bad_input_is_one_line_with_status_2(csv_noisy, cli, extra, message):
    status, out, err = cli("posterior", str(csv_noisy), *TERMS, "--no-bias-correction", *extra)
    assert status == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith("nlid posterior: error:") and message in err


def test_unconverged_chains_are_not_reported(csv_noisy, cli):
    status, out, err = cli("posterior", str(csv_noisy), *TERMS, "--steps", "100", "--no-bias-correction")
    assert status == 1 and out == ""
    assert "did not converge in 100 steps" in err and "raise --steps" in err and err.count("\n") == 1
