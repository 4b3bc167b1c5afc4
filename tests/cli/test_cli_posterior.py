"""nlid posterior: JSON contract, files, and one-line errors."""

import json

import pytest

from nlid.cli.main import main


def simulated_csv(factory, preset: str, seed: int, duration: float, noise: str, channels: str):
    """``nlid simulate`` of a preset into a fresh folder; returns the CSV's path."""
    path = factory.mktemp("posterior") / "x.csv"
    argv = ["simulate", "--preset", preset, "--seed", str(seed), "--duration", str(duration), "--noise", noise]
    assert main([*argv, "--channels", channels, "--out", str(path)]) == 0
    return path


@pytest.fixture(scope="module")
def csv_noisy(tmp_path_factory):
    """20 s of paper-numerical, 2 % noise, channels f, z, a."""
    return simulated_csv(tmp_path_factory, "paper-numerical", 4, 20, "0.02", "a")


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


# ---------------------------------------------------------------------------- channels and noise levels (issue 15)
@pytest.fixture(scope="module")
def csv_velocity(tmp_path_factory):
    """20 s of paper-numerical, 2 % noise, channels f, z, v, a (the record of issue 15, shortened)."""
    return simulated_csv(tmp_path_factory, "paper-numerical", 0, 20, "0.02", "v,a")


def test_measured_velocity_noise_comes_from_v_minus_dz_dt(csv_velocity, cli):
    status, out, err = cli("posterior", str(csv_velocity), *TERMS, "--json", "--seed", "0", "--bias-pairs", "2")
    assert status == 0, err
    doc = json.loads(out)
    noise = doc["likelihood"]["noise"]
    assert noise["z"]["source"] == "noise floor" and noise["v"]["source"] == "v - dz/dt"
    # 2 % of the velocity's sd (0.70 m/s) is 0.014 m/s; the old floor read 0.065
    assert 0.010 < noise["v"]["sd"] < 0.018
    assert set(doc["bias_shift_sd"]) == {"v", "v*|v|"} and isinstance(doc["large_corrections"], dict)
    for name, truth in (("v", 1.0), ("v*|v|", 5.0)):
        s = doc["params"][name]
        assert abs(s["mean"] - truth) < 4 * s["sd"], (name, s)


def test_noise_level_given_on_the_command_line(csv_velocity, cli):
    status, out, err = cli(
        "posterior",
        str(csv_velocity),
        *TERMS,
        "--json",
        "--bias-pairs",
        "2",
        "--noise-level",
        "v=0.014",
        "--noise-level",
        "z=3.7e-4",
    )
    assert status == 0, err
    noise = json.loads(out)["likelihood"]["noise"]
    assert noise == {
        "z": {"channel": "z", "sd": 3.7e-4, "source": "given", "relative_se": None},
        "v": {"channel": "v", "sd": 0.014, "source": "given", "relative_se": None},
    }


def test_noise_levels_in_the_table(csv_velocity, cli):
    status, out, err = cli("posterior", str(csv_velocity), *TERMS, "--bias-pairs", "2")
    assert status == 0, err
    assert "noise levels simulated by the correction: z = " in out and "m/s (v - dz/dt, sd +/- " in out


def test_a_large_correction_is_printed(tmp_path, cli):
    path = tmp_path / "x.csv"
    argv = ["simulate", "--preset", "paper-experimental", "--seed", "5", "--duration", "60", "--noise", "0.02"]
    assert cli(*argv, "--channels", "a", "--out", str(path))[0] == 0
    terms = "z^3,z^2,sign(v)*|px(z)|,v*|px(z)|,v*|v|*|px(z)|,v^3*|px(z)|"
    roots = ("--px-roots=-0.02798,0.02668",)
    status, out, err = cli(
        "posterior",
        str(path),
        "--mass",
        "0.265",
        "--terms",
        terms,
        *roots,
        "--params",
        "sign(v)*|px(z)|",
        "--bias-pairs",
        "2",
    )
    assert status == 0, err
    assert "note: the bias correction moved sign(v)*|px(z)| by " in out and "sd (least squares" in out


@pytest.mark.parametrize(
    "extra, message",
    [
        (("--noise-level", "a=1"), "--noise-level expects CHANNEL=SD with CHANNEL z or v"),
        (("--noise-level", "v"), "--noise-level expects CHANNEL=SD"),
        (("--noise-level", "v=fast"), "--noise-level v= expects a number, got 'fast'"),
        (("--noise-level", "v=-1"), "--noise-level v= must be a non-negative number"),
        (("--noise-level", "v=1", "--noise-level", "v=2"), "gives the level of v twice"),
    ],
)
def test_bad_noise_levels_are_one_line_with_status_2(csv_velocity, cli, extra, message):
    status, out, err = cli("posterior", str(csv_velocity), *TERMS, *extra)
    assert status == 2 and out == ""
    assert err.count("\n") == 1 and message in err


def test_a_noise_level_that_cannot_be_established_is_asked_for(tmp_path, cli):
    path = tmp_path / "clean.csv"
    argv = ["simulate", "--preset", "paper-numerical", "--seed", "1", "--duration", "20", "--noise", "0"]
    assert cli(*argv, "--channels", "v,a", "--out", str(path))[0] == 0
    # noise-free channels (written to 12 digits): nothing in v - dz/dt is the white noise the correction simulates
    status, out, err = cli("posterior", str(path), *TERMS)
    assert status == 2 and out == "" and err.count("\n") == 1
    assert "noise level" in err and "cannot be established" in err
    assert "--noise-level " in err and "v=SD" in err and "m/s)" in err and "noise={" not in err


def test_velocity_and_acceleration_without_displacement_are_refused(csv_velocity, tmp_path, cli):
    lines = csv_velocity.read_text().splitlines()
    header = lines[0].split(",")
    keep = [i for i, name in enumerate(header) if name != "z"]
    path = tmp_path / "no_z.csv"
    path.write_text("\n".join(",".join(row.split(",")[i] for i in keep) for row in lines) + "\n")
    status, out, err = cli("posterior", str(path), *TERMS)
    assert status == 2 and out == "" and err.count("\n") == 1
    assert "no column for channel 'z'" in err


@pytest.fixture(scope="module")
def structure_csv(tmp_path_factory):
    """6 s of the 2dof-double-well structure, 2 % noise on the accelerations, every channel written."""
    return simulated_csv(tmp_path_factory, "2dof-double-well", 2, 6, "a=0.02", "v,a")


def test_a_structure_file_gets_the_posterior_of_its_elements(structure_csv, cli):
    elements = "(z1-z2)^3, (z1-z2)^2, (v1-v2)*|v1-v2|"
    args = ("posterior", str(structure_csv), "--method", "rfs", "--terms", elements, "--params", "elements")
    status, out, err = cli(*args, "--json", "--seed", "0")
    assert status == 0, err
    doc = json.loads(out)
    assert set(doc["params"]) == {"(z1-z2)^3", "(z1-z2)^2", "(v1-v2)*|v1-v2|"}
    assert doc["units"]["(z1-z2)^3"] == "N/m^3"
    assert doc["likelihood"]["bias_correction"] is True  # each displacement's noise simulated at its floor
    assert len(doc["likelihood"]["noise_sd"]) == 2
    status, out, err = cli(*args[:-2], "--params", "K[1,2], (z1-z2)^3", "--no-bias-correction")
    assert status == 0, err
    assert "K[1,2]" in out and "N/m" in out and "mass matrix diagonal" in out
    status, _, err = cli(*args, "--noise-level", "z=1e-5")
    assert status == 2 and "noise floor" in err
