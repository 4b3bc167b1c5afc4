"""The report: Markdown, HTML, figures, CSV and JSON files, and the terminal table."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from nlid.discovery import discover, summary_table, write_report
from nlid.discovery.plots import binned_mean, binned_mean_2d


@pytest.fixture(scope="module")
def run(make_case):
    record, declared = make_case("single", "coulomb", ("z",), 21)
    return discover(record, declared, "rfs", candidates="coulomb,quadratic-damping,cubic-stiffness")


def test_write_report(run, tmp_path):
    paths = write_report(run, tmp_path)
    names = {p.name for p in paths}
    assert {"report.md", "report.html", "result.json", "models.csv", "coefficients.csv"} <= names
    assert {"residual_0.png", "residual_1.png", "progress.png"} <= names
    md = (tmp_path / "report.md").read_text()
    assert "## Step 1: coulomb (sign(v))" in md and "figures/residual_0.png" in md and "figures/residual_1.png" in md
    assert "Final check" in md and "acceptance rule" in md
    page = (tmp_path / "report.html").read_text()
    assert page.startswith("<!DOCTYPE html>") and '<img src="figures/residual_1.png"' in page and "<table>" in page
    data = json.loads((tmp_path / "result.json").read_text())
    assert data["steps"][0]["effect"] == "coulomb"
    models = pd.read_csv(tmp_path / "models.csv")
    assert len(models) == 2 and models["eps_percent"].iloc[1] < models["eps_percent"].iloc[0]
    coeffs = pd.read_csv(tmp_path / "coefficients.csv")
    assert "sign(v)" in set(coeffs["term"]) and set(coeffs["unit"]) >= {"N", "N*s/m"}


def test_summary_table(run):
    text = summary_table(run)
    assert "declared:" in text and "+ coulomb: sign(v)" in text and "stopped:" in text and "sign(v)" in text


def test_every_free_run_figure_states_its_rule(run, make_case, tmp_path):
    """The terminal table, the Markdown report and the JSON name the rule of the held-out (and validation) runs."""
    assert "free run held-out: from the record's first sample" in summary_table(run)
    assert run.to_dict()["info"]["freerun_rule"] == "from the record's first sample"
    record, declared = make_case("single", "coulomb", ("z",), 22)
    est, val = record.split(0.3)
    with_validation = discover(est, declared, "rfs", candidates="coulomb", validation=val, freerun_rule="window:30")
    text = summary_table(with_validation)
    assert "free run held-out: initialisation window of 30 samples" in text
    assert "free run validation: initialisation window of 30 samples" in text
    write_report(with_validation, tmp_path)
    md = (tmp_path / "report.md").read_text()
    assert "- free run validation: initialisation window of 30 samples" in md
    info = json.loads((tmp_path / "result.json").read_text())["info"]
    assert info["freerun_rule_validation"].startswith("initialisation window of 30 samples")


def test_json_contract(run):
    out = run.to_dict()
    required = {
        "method",
        "declared",
        "eps_initial",
        "eps_final",
        "eps_initial_holdout",
        "eps_final_holdout",
        "steps",
        "final_terms",
        "coefficients",
    }
    assert required <= set(out)
    step_keys = {"effect", "terms", "eps_before", "eps_after", "eps_before_holdout", "eps_after_holdout", "evidence"}
    assert step_keys <= set(out["steps"][0])
    assert json.loads(json.dumps(out, allow_nan=False)) == out


def test_binned_means_and_their_bands():
    rng = np.random.default_rng(1)
    x = rng.uniform(-1, 1, 200_000)
    r = np.sign(x) + rng.standard_normal(x.size)
    centers, mean, half, counts = binned_mean(x, r, tau=1.0, bins=20)
    assert np.allclose(mean, np.sign(centers), atol=5 * np.nanmax(half))
    assert counts.sum() == pytest.approx(0.99 * x.size, rel=0.01)
    _, _, half4, _ = binned_mean(x, r, tau=4.0, bins=20)
    assert np.allclose(half4, 2 * half)  # four times fewer effective samples: twice as wide
    xe, ye, grid = binned_mean_2d(x, rng.uniform(-1, 1, x.size), r, bins=10)
    assert grid.shape == (10, 10) and np.nanmax(np.abs(grid - np.sign(0.5 * (xe[1:] + xe[:-1]))[:, None])) < 0.2


def test_validation_note_names_the_better_earlier_model(make_case):
    """When a validation record prefers an earlier model, the summary and the JSON say so (and only then)."""
    import dataclasses

    record, declared = make_case("single", "coulomb", ("z",), 22)
    est, val = record.split(0.3)
    run = discover(est, declared, "rfs", candidates="coulomb", validation=val)
    assert len(run.states) == 2 and all(st.sim_rms_validation is not None for st in run.states)
    assert run.validation_note is None or "declared model" in run.validation_note
    # the same run as if the step had worsened the validation free run fivefold
    first, last = run.states
    worse = dataclasses.replace(last.validation, freerun_rmse=5 * first.sim_rms_validation)
    spoiled = dataclasses.replace(run, states=[first, dataclasses.replace(last, validation=worse)])
    note = spoiled.validation_note
    assert note is not None and "the declared model is the best" in note
    assert "validation: on the validation record" in summary_table(spoiled)
    assert json.loads(json.dumps(spoiled.to_dict()))["validation_note"] == note
    # a final model within the tolerance of the best: no note
    close = dataclasses.replace(last.validation, freerun_rmse=1.1 * first.sim_rms_validation)
    fine = dataclasses.replace(run, states=[first, dataclasses.replace(last, validation=close)])
    assert fine.validation_note is None


def test_a_validation_record_beyond_the_estimation_range_is_said(make_case):
    """The validation record's reach beyond the estimation range is said once, in the summary and the JSON."""
    import dataclasses

    from nlid.scoring import RANGE_TOLERANCE

    record, declared = make_case("single", "coulomb", ("z",), 22)
    est, val = record.split(0.3)
    run = discover(est, declared, "rfs", candidates="coulomb", validation=val)
    lo, hi = run.info["z_range"]
    width = hi - lo

    def reaching(beyond: float):
        info = dict(run.info, z_range_validation=[lo, hi + beyond * width])
        return dataclasses.replace(run, info=info)

    assert reaching(0.9 * RANGE_TOLERANCE).validation_range is None
    far = reaching(0.25)
    assert far.validation_range.startswith("the validation record reaches 25 % of the estimation range beyond it")
    assert far.validation_note is None  # the step improves the validation free run: no note, so the range is said
    assert summary_table(far).count("validation: the validation record reaches 25 %") == 1
    assert json.loads(json.dumps(far.to_dict()))["validation_range"] == far.validation_range
