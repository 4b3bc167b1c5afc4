"""Every summary says its force-hold assumption and where it came from; a record in volts shows volt-based units.

Issue 35, item 3: per command (identify, compare, discover, posterior), text and JSON.
"""

from __future__ import annotations

import json

import pandas as pd
import pytest

import nlid
from nlid.base.dimensions import coefficient_unit, mass_unit, simplify, unit_of
from nlid.cli.main import main
from nlid.data.io import write_csv

TERMS = "z^3,z^2,v*|v|"


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """The same 10 s of paper-numerical: with its sidecar (zoh), bare (no sidecar), and bare in volts."""
    folder = tmp_path_factory.mktemp("assumptions")
    record = nlid.simulate("paper-numerical", seed=2, noise=0.02, duration=10.0, channels="z")
    with_sidecar, bare = folder / "x.csv", folder / "bare.csv"
    write_csv(record, with_sidecar)
    pd.DataFrame({"t": record.t, "f": record.f, "z": record.z}).to_csv(bare, index=False)
    return {"sidecar": with_sidecar, "bare": bare}


def run(capfd, *argv: str) -> tuple[int, str, str]:
    status = main(list(argv))
    out = capfd.readouterr()
    return status, out.out, out.err


SIDECAR = "force between samples: zoh: held over each sample [from the sidecar x.csv.meta.json]"
DEFAULT = "force between samples: sampled: interpolated between samples [the default"
OPTION = "force between samples: zoh: held over each sample [from the option force_hold=]"


# ---------------------------------------------------------------------------------------------- the force hold
@pytest.mark.parametrize(("which", "extra", "said"), [("sidecar", (), SIDECAR), ("bare", (), DEFAULT)])
def test_identify_says_the_force_hold_and_its_source(files, capfd, which, extra, said):
    status, out, _ = run(capfd, "identify", str(files[which]), "--terms", TERMS, "--mass", "0.2", *extra)
    assert status == 0 and said in out
    status, out, _ = run(capfd, "identify", str(files[which]), "--terms", TERMS, "--mass", "0.2", "--json")
    data = json.loads(out)["provenance"]["data"]
    assert data["force_hold"] == ("zoh" if which == "sidecar" else "sampled")
    assert data["force_hold_source"] == ("the sidecar x.csv.meta.json" if which == "sidecar" else "default")


def test_the_option_is_named_as_the_source(files, capfd):
    status, out, _ = run(
        capfd, "identify", str(files["bare"]), "--terms", TERMS, "--mass", "0.2", "--force-hold", "zoh"
    )
    assert status == 0 and OPTION in out


def test_compare_says_it_in_text_and_json(files, capfd):
    status, out, _ = run(capfd, "compare", str(files["sidecar"]), "--methods", "rfs", "--terms", TERMS, "--mass", "0.2")
    assert status == 0 and out.rstrip().splitlines()[-1] == SIDECAR
    status, out, _ = run(
        capfd, "compare", str(files["bare"]), "--methods", "rfs", "--terms", TERMS, "--mass", "0.2", "--json"
    )
    rows = json.loads(out)
    assert status == 0 and all((r["force_hold"], r["force_hold_source"]) == ("sampled", "default") for r in rows)


def test_discover_says_it(files, capfd):
    status, out, _ = run(
        capfd, "discover", str(files["sidecar"]), "--declared", TERMS, "--mass", "0.2", "--max-steps", "0", "--quiet"
    )
    assert status == 0 and "force between samples: zoh: held over each sample [from the sidecar" in out
    status, out, _ = run(
        capfd,
        "discover",
        str(files["bare"]),
        "--declared",
        TERMS,
        "--mass",
        "0.2",
        "--max-steps",
        "0",
        "--json",
    )
    info = json.loads(out)["info"]
    assert status == 0 and (info["force_hold"], info["force_hold_source"]) == ("sampled", "default")


def test_posterior_says_it(files, capfd):
    argv = ["posterior", str(files["sidecar"]), "--terms", TERMS, "--mass", "0.2", "--quiet"]
    status, out, _ = run(capfd, *argv)
    assert status == 0 and SIDECAR in out
    status, out, _ = run(capfd, *argv, "--json")
    assert json.loads(out)["force_hold"] == {"hold": "zoh", "source": "the sidecar x.csv.meta.json"}


# ---------------------------------------------------------------------------------------------- units
def test_the_unit_algebra():
    assert simplify("V*s^2/V") == "s^2" and simplify("N*s/m") == "N*s/m" and simplify("V/V") == "1"
    assert unit_of(("V", 1), ("V", -3)) == "1/V^2" and unit_of(("m", 1), ("s", -1)) == "m/s"
    assert coefficient_unit(2, 2) == "N*s^2/m^2" and coefficient_unit(2, 2, "V", "V") == "s^2/V"
    assert mass_unit() == "kg" and mass_unit("V", "V") == "s^2" and mass_unit("N", "V") == "N*s^2/V"


VOLTS = ("--units", "f=V,z=V")
#: The units of a model identified from a record in volts: every one derived from V and s, simplified.
VOLT_UNITS = {"1": "V", "z": "1", "z^2": "1/V", "z^3": "1/V^2", "v": "s", "v*|v|": "s^2/V"}


def test_identify_in_volts(files, capfd):
    status, out, _ = run(capfd, "identify", str(files["bare"]), "--terms", TERMS, "--mass", "0.2", *VOLTS)
    assert status == 0
    assert "mass: 0.2 s^2 (given)" in out and "equilibria (V):" in out and " kg" not in out and "N/m" not in out
    rows = {line.split()[0]: line.split()[-1] for line in out.splitlines() if line.split()[:1] and line[0] in "zv1"}
    assert {k: rows[k] for k in VOLT_UNITS} == VOLT_UNITS
    status, out, _ = run(capfd, "identify", str(files["bare"]), "--terms", TERMS, "--mass", "0.2", "--json", *VOLTS)
    assert json.loads(out)["units"] == VOLT_UNITS


def test_compare_in_volts(files, capfd):
    argv = ["compare", str(files["bare"]), "--methods", "rfs", "--terms", TERMS, "--mass", "0.2", "--json", *VOLTS]
    status, out, _ = run(capfd, *argv)
    rows = json.loads(out)
    units = {r["name"]: r["unit"] for r in rows if r["quantity"] == "coefficient"}
    assert status == 0 and units == VOLT_UNITS
    assert {r["unit"] for r in rows if r["quantity"] in ("mass", "equilibrium")} == {"s^2", "V"}


def test_discover_in_volts(files, capfd):
    argv = ["discover", str(files["bare"]), "--declared", TERMS, "--mass", "0.2", "--max-steps", "0", "--quiet"]
    status, out, _ = run(capfd, *argv, *VOLTS)
    assert status == 0 and "mass: 0.2 s^2 (given)" in out and "V*s^2/V" not in out and " kg" not in out
    assert "s^2/V" in out and "1/V^2" in out


def test_posterior_in_volts(files, capfd):
    argv = ["posterior", str(files["bare"]), "--terms", TERMS, "--mass", "0.2", "--quiet", *VOLTS]
    status, out, _ = run(capfd, *argv)
    assert status == 0 and "mass 0.2 s^2" in out and "z = " in out and " V (noise floor)" in out
    assert " m (noise floor)" not in out
    status, out, _ = run(capfd, *argv, "--json")
    data = json.loads(out)
    assert data["units"] == {"v": "s", "v*|v|": "s^2/V"} and data["channel_units"] == {"f": "V", "z": "V"}


def test_figures_in_volts(files):
    mine = nlid.load(str(files["bare"]), units="f=V,z=V")
    fit = nlid.identify(mine, TERMS, "rfs", mass=0.2)
    assert fit.plot_stiffness().get_xlabel() == "z (V)" and fit.plot_stiffness().get_ylabel() == "K(z) (V)"
    assert fit.plot_stiffness(potential=True).get_ylabel() == "U(z) (V^2)"
    assert fit.plot_residual(mine, against="v").get_xlabel() == "v (V/s)"
    assert fit.plot_freerun(mine).get_ylabel() == "z (V)"
    si = nlid.identify(nlid.load(str(files["bare"])), TERMS, "rfs", mass=0.2)
    assert si.plot_stiffness(potential=True).get_ylabel() == "U(z) (J)"
    import matplotlib.pyplot as plt

    plt.close("all")


def test_posterior_damping_figure_in_volts(files):
    from nlid.bayes import PosteriorSampler
    from nlid.bayes.plots import damping_figure

    mine = nlid.load(str(files["bare"]), units="f=V,z=V")
    post = PosteriorSampler("damping", seed=0).run(mine, nlid.identify(mine, TERMS, "rfs", mass=0.2))
    units = post.channel_units
    fig = damping_figure(post.damping_bands(grid=20, draws=50), None, (units["f"], units["z"]))
    top, bottom = fig.axes[0], fig.axes[len(fig.axes) // 2]
    assert top.get_ylabel() == "damping force D (V)" and bottom.get_xlabel() == "v (V/s)"
    assert top.get_title().startswith("z = ") and top.get_title().endswith(" V)")
    import matplotlib.pyplot as plt

    plt.close("all")
