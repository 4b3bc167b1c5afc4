"""What physics forbids: the rows of issue 35's table exit 1 naming the cause; healthy records exit 0 with no flag."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pandas as pd
import pytest

import nlid
from nlid.cli.main import main
from nlid.identified.model import IdentifiedModel
from nlid.identified.plausibility import (
    FORCE_RESIDUAL_MAX_PERCENT,
    MASS_RATIO_MAX,
    ZETA_MAX,
    check,
    headline,
    implied_mass,
    mass_hint,
)

TERMS = "z^3,z^2,v*|v|"


@pytest.fixture(scope="module")
def record():
    """20 s of paper-numerical with 2 % noise on z, as `nlid simulate` writes it."""
    return nlid.simulate("paper-numerical", seed=3, noise=0.02, duration=20.0, channels="z")


@pytest.fixture(scope="module")
def files(record, tmp_path_factory):
    """The record as a CSV in SI (with its force hold said), the same with z written in mm, and with f in kN."""
    folder = tmp_path_factory.mktemp("plausibility")
    si, mm, kn = folder / "x.csv", folder / "xmm.csv", folder / "xkn.csv"
    pd.DataFrame({"t": record.t, "f": record.f, "z": record.z}).to_csv(si, index=False)
    pd.DataFrame({"t": record.t, "f": record.f, "z": 1e3 * record.z}).to_csv(mm, index=False)
    pd.DataFrame({"t": record.t, "f": 1e-3 * record.f, "z": record.z}).to_csv(kn, index=False)
    return si, mm, kn


def run(capfd, *argv: str) -> tuple[int, str, str]:
    status = main(list(argv))
    out = capfd.readouterr()
    return status, out.out, out.err


# ---------------------------------------------------------------------------------------------- the table of issue 35
@pytest.mark.parametrize(
    ("which", "mass", "codes", "cause"),
    [
        # the mass in g for kg: negative damping, a negative viscous coefficient, a force residual of 1e4 % and more
        ("si", "200", {"mass", "negative-damping", "force-residual"}, "is --mass in kg (not g)?"),
        # the mass 1000 times too small: damping ratios of several hundred percent
        ("si", "0.0002", {"mass", "overdamped"}, "is --mass in kg (not t)?"),
        # z written in mm, read as m (no --units): the same as a mass 1000 times too large
        ("mm", "0.2", {"mass", "negative-damping"}, "--units z=mm"),
        # f written in kN, read as N: the implied mass 1000 times too small, as with z in mm
        ("kN", "0.2", {"mass"}, "--units f=kN"),
    ],
)
def test_each_row_of_the_table_exits_1_naming_the_cause(files, capfd, which, mass, codes, cause):
    path = files[("si", "mm", "kN").index(which)]
    status, out, err = run(capfd, "identify", str(path), "--method", "rfs", "--terms", TERMS, "--mass", mass)
    assert status == 1
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("nlid identify: error: the result cannot be trusted: ")
    assert "the data suggest m ≈ 0.2 kg" in lines[0] or "the data suggest m ≈ 0.0002 kg" in lines[0]
    assert cause in lines[0]
    assert "NOT TRUSTED" in out  # the summary is still printed, and says it
    status, out, _ = run(capfd, "identify", str(path), "--method", "rfs", "--terms", TERMS, "--mass", mass, "--json")
    data = json.loads(out)
    assert status == 1 and codes <= {f["code"] for f in data["flags"]}


def test_the_healthy_record_exits_0_with_no_flag(files, capfd):
    status, out, err = run(capfd, "identify", str(files[0]), "--method", "rfs", "--terms", TERMS, "--mass", "0.2")
    assert status == 0 and "NOT TRUSTED" not in out and "error" not in err
    status, out, _ = run(capfd, "identify", str(files[0]), "--terms", TERMS, "--mass", "0.2", "--json")
    assert status == 0 and "flags" not in json.loads(out)


def test_mm_with_units_is_healthy(files, capfd):
    status, _, err = run(capfd, "identify", str(files[1]), "--terms", TERMS, "--mass", "0.2", "--units", "z=mm")
    assert status == 0, err


# ---------------------------------------------------------------------------------------------- the API
def test_flags_are_on_the_model_its_repr_summary_and_json(record):
    fit = nlid.identify(record, TERMS, "rfs", mass=200.0)
    assert fit.flags[0].code == "mass"  # the most telling first
    assert "NOT TRUSTED: mass" in repr(fit)
    assert "NOT TRUSTED" in str(fit.summary())
    back = IdentifiedModel.from_dict(json.loads(json.dumps(fit.to_dict())))
    assert back.flags == fit.flags
    line = headline(fit.flags)
    assert "\n" not in line and "mass= in kg (not g)" in line
    assert fit.force_residual_percent > FORCE_RESIDUAL_MAX_PERCENT


def test_implied_mass_is_the_true_one(record):
    implied = implied_mass(record, nlid.Model.from_spec(TERMS))
    assert implied is not None and implied.determined
    # the record's own mass within a fraction of the rule's factor: far from the limit
    assert abs(np.log(implied.value / 0.2)) < 0.1 * np.log(MASS_RATIO_MAX)


def _edited(fit: IdentifiedModel, **coefficients: float) -> IdentifiedModel:
    data = fit.to_dict()
    data["coefficients"] = {**data["coefficients"], **coefficients}
    data["standard_errors"] = None
    return IdentifiedModel.from_dict(data)


def test_a_negative_coulomb_coefficient_is_flagged(record):
    fit = nlid.identify(record, "z^3,z^2,v*|v|,sign(v)", "rfs", mass=0.2)
    assert not [f for f in fit.flags if f.code == "dissipative-sign"]
    bad = _edited(fit, **{"sign(v)": -2.5})
    flags = check(bad)
    assert [f.code for f in flags] == ["dissipative-sign"] and "sign(v) -2.5 N" in flags[0].message


def test_a_position_dependent_negative_law_is_judged_with_the_others():
    """paper-experimental's true v*|px(z)| and v*|v|*|px(z)| are negative: not a flag on their own."""
    record = nlid.simulate("paper-experimental", seed=0, noise={"z": 0.02, "a": 0.02}, duration=20.0, channels="z,a")
    terms = "z^3, z^2, sign(v)*|px(z)|, v*|px(z)|, v*|v|*|px(z)|, v^3*|px(z)|"
    fit = nlid.identify(record, terms, "rfs", mass=record.mass)
    assert fit.coefficients["v*|v|*|px(z)|"] < 0 and fit.flags == ()


def test_damping_beyond_critical_and_a_large_residual_are_flagged(record):
    fit = nlid.identify(record, TERMS, "rfs", mass=0.2)
    assert check(fit, record) == ()
    m = fit.modal[0]
    heavy = dataclasses.replace(fit, modal=(dataclasses.replace(m, zeta=1.5 * ZETA_MAX), *fit.modal[1:]))
    assert [f.code for f in check(heavy)] == ["overdamped"]
    light = dataclasses.replace(fit, modal=(dataclasses.replace(m, zeta=-0.01), *fit.modal[1:]))
    assert [f.code for f in check(light)] == ["negative-damping"]
    scores = dataclasses.replace(fit.scores, force_residual_percent=1.5 * FORCE_RESIDUAL_MAX_PERCENT)
    assert [f.code for f in check(dataclasses.replace(fit, scores=scores))] == ["force-residual"]


@pytest.mark.parametrize(
    ("preset", "terms", "noise", "channels", "duration"),
    [
        ("paper-numerical", TERMS, {"z": 0.02}, "z", 20.0),
        ("paper-numerical-stepped", TERMS, {"z": 0.02}, "z", 40.0),
        ("paper-numerical-swept", TERMS, {"z": 0.02}, "z", 40.0),
    ],
)
def test_presets_raise_no_flag(preset, terms, noise, channels, duration):
    record = nlid.simulate(preset, seed=0, noise=noise, channels=channels, duration=duration)
    for mass in (record.mass, None):
        fit = nlid.identify(record, terms, "rfs", mass=mass)
        assert fit.flags == (), [str(f) for f in fit.flags]


@pytest.mark.parametrize(
    ("source", "terms", "without", "mass"),
    [
        ("dataset:emps", "sign(v)", "z", None),  # the README's model, mass estimated
        ("dataset:emps", "sign(v)", "z", 95.1),  # the benchmark's published mass given
        ("dataset:silverbox", "z^2, z^3", None, None),
        ("dataset:bouc-wen", "", "1", 2.0),  # a linear model of a hysteretic record: 33 % force residual
        ("dataset:bouc-wen", "bouc_wen(800, -1100)", "1", 2.0),
    ],
)
def test_measured_benchmarks_raise_no_flag(data_dir, source, terms, without, mass):
    fit = nlid.identify(nlid.load(source), terms, "rfs", mass=mass, without=without)
    assert fit.flags == (), [str(f) for f in fit.flags]


def test_a_record_in_volts_is_told_in_its_own_units(files, capfd):
    argv = ["identify", str(files[0]), "--terms", TERMS, "--mass", "200", "--units", "f=V,z=V"]
    status, _, err = run(capfd, *argv)
    assert status == 1 and "the data suggest m ≈ 0.2 s^2: is --mass in s^2" in err and " kg" not in err


# ------------------------------------------------------------------ structures (the same rules, per mode and DOF)
@pytest.fixture(scope="module")
def well_structure():
    from nlid.simulation.presets import get_preset

    preset = get_preset("2dof-double-well")
    record = preset.with_overrides(duration=8.0).simulate(1, noise={"z": 0.005}, channels=["z", "v", "a"])
    return record, preset


def test_a_healthy_structure_is_not_flagged(well_structure):
    record, preset = well_structure
    fit = nlid.identify(record, preset.elements, "rfs", mass=record.meta["mass"])
    assert fit.flags == ()
    assert "NOT TRUSTED" not in repr(fit)


def test_a_structure_mass_in_g_is_flagged_and_round_trips(well_structure):
    from nlid.identified.structure import IdentifiedStructure

    record, preset = well_structure
    fit = nlid.identify(record, preset.elements, "rfs", mass=1000 * np.asarray(record.meta["mass"]))
    codes = {f.code for f in fit.flags}
    assert codes & {"negative-damping", "overdamped", "force-residual", "dissipative-sign"}, fit.flags
    assert "NOT TRUSTED" in repr(fit) and "NOT TRUSTED" in str(fit.summary())
    assert IdentifiedStructure.from_dict(fit.to_dict()).flags == fit.flags


def test_a_structure_damping_element_with_the_wrong_sign_is_flagged(well_structure):
    from nlid.identified.plausibility import check_structure

    record, preset = well_structure
    fit = nlid.identify(record, preset.elements, "rfs", mass=record.meta["mass"])
    name = next(e.name for e in fit.elements if e.term.dissipative)
    coefficients = {**dict(fit.coefficients), name: -abs(fit.coefficients[name])}
    structure = dataclasses.replace(fit.structure, coefficients=coefficients)
    flipped = dataclasses.replace(fit, structure=structure, standard_errors=None)
    assert [f.code for f in check_structure(flipped)] == ["dissipative-sign"]


def test_a_reversed_force_is_named_as_such(record, tmp_path, capfd):
    """f written with the opposite sign (issue 31's probe): the force balance implies a negative mass, and the
    headline names the reversed sign instead of a wrong mass or a unit slip; with the mass estimated, the
    identifier's refusal says the same."""
    path = tmp_path / "reversed.csv"
    pd.DataFrame({"t": record.t, "f": -record.f, "z": record.z}).to_csv(path, index=False)
    status, _, err = run(capfd, "identify", str(path), "--method", "rfs", "--terms", TERMS, "--mass", "0.2")
    assert status == 1 and "implies a negative mass" in err and "the force's sign is likely reversed" in err
    status, _, err = run(capfd, "identify", str(path), "--method", "rfs", "--terms", TERMS)
    assert status == 1 and "is the force's sign reversed against z" in err


def test_a_wrong_sampling_rate_is_asked_about_with_its_factor(record):
    # a sampling rate 5 % high scales every acceleration by 1/1.05^2: the data imply a mass 1.05^2 times smaller,
    # exactly as a mass given too large would; the hint says which rate would explain it
    assert "is fs right (a sampling rate 1.05 times the true one" in mass_hint(0.2, 0.2 / 1.05**2)
    fast = nlid.Record(f=record.f, z=record.z, fs=1.05 * record.fs, meta=dict(record.meta))
    result = nlid.discover(fast, ["1", "z", "v", "z^2", "z^3", "v*|v|"], mass=0.2, simulate=False, views=False)
    assert [s.effect for s in result.steps][:1] == ["mass"]
    assert "is fs right (a sampling rate 1.05 times the true one" in result.steps[0].notes[0]
