"""A study over a structure preset: runs, resumes (the second run does nothing) and reports."""

from __future__ import annotations

import pandas as pd
import pytest

from nlid.study import columns as col
from nlid.study import load_study, parse_study, run_study
from nlid.study.values import ConfigError

STUDY = """
[study]
name = "mdof-tiny"
seed = 7
repetitions = 1
timeout = 300
identifiers = ["rfs"]

[[datasets]]
name = "well"
preset = "2dof-double-well"
overrides = {{ duration = 3.0 }}
noise = {{ z = 0.01 }}
channels = ["z1", "z2"]
terms = "(z1-z2)^3, (z1-z2)^2, (v1-v2)*|v1-v2|"
mass = "known"
{extra}
"""


def test_study_over_a_structure_preset_runs_resumes_and_reports(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(STUDY.format(extra=""))
    out = tmp_path / "out"
    first = run_study(load_study(str(path)), out, progress=False)
    assert (first.executed, first.skipped) == (1, 0)
    frame = pd.read_csv(out / "results.csv")
    assert list(frame[col.STATUS.key()]) == ["ok"]
    row = frame.iloc[0]
    for element in ("(z1-z2)^3", "(z1-z2)^2", "(v1-v2)*|v1-v2|"):
        assert abs(row[col.COEF_ERROR.key(element)]) < 10.0
    assert abs(row[col.COEF_ERROR.key("(z1-z2)^3")]) < 1.0
    assert abs(row[col.LINEAR_FN_ERROR.key("m1")]) < 1.0
    assert row[col.EQ_FOUND.key()] == 2 and row[col.EQ_MISSING.key()] == 0
    assert abs(row[col.WELL_FN_ERROR.key("s1.m1")]) < 2.0
    assert all(col.declared(c) for c in frame.columns)
    summary = (out / "summary.md").read_text()
    assert "Modes of the structure" in summary and "(z1-z2)^3" in summary
    assert first.summary
    again = run_study(load_study(str(path)), out, progress=False)
    assert (again.executed, again.skipped) == (0, 1)
    assert pd.read_csv(out / "results.csv").equals(frame)


def test_a_structure_study_reports_the_posterior_of_its_elements(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(STUDY.format(extra='\n[posterior]\nparams = "elements"\nlevel = 0.9\n'))
    out = tmp_path / "out"
    run_study(load_study(str(path)), out, progress=False)
    row = pd.read_csv(out / "results.csv").iloc[0]
    assert "posterior" not in str(row[col.WARNINGS.key()])
    for element in ("(z1-z2)^3", "(z1-z2)^2", "(v1-v2)*|v1-v2|"):
        lo, hi = row[col.CI_LO.key(element)], row[col.CI_HI.key(element)]
        assert lo < row[col.COEF.key(element)] < hi  # rfs's estimate inside its own posterior's 90 % interval
        assert row[col.CI_WIDTH.key(element)] == pytest.approx(hi - lo)
        assert col.CI_COVERS.key(element) in row.index


@pytest.mark.parametrize(
    ("extra", "match"),
    [
        ('params = "elements"\nnoise = { z = 1e-5 }', "noise floor"),
        ('params = "(z2-z3)^3"', "not an element"),
        ('params = "elements"\npriors = { "(z2-z1)^3" = "flat" }', "opposite sign"),
    ],
)
def test_posterior_settings_a_structure_cannot_honour_are_refused_at_load(tmp_path, extra, match):
    text = STUDY.format(extra="\n[posterior]\n" + extra + "\n")
    with pytest.raises(ConfigError, match=match):
        parse_study(text, source="s.toml", base_dir=tmp_path)


def test_builtin_mdof_study_plans_both_presets():
    config = load_study("mdof-presets")
    assert {ds.name for ds in config.datasets} == {"3dof-cubic", "2dof-double-well"}
