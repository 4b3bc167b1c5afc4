"""The loop on measured data: EMPS (Coulomb friction) and Silverbox (cubic spring)."""

from __future__ import annotations

import pytest

from nlid.data.datasets import load
from nlid.discovery import discover


@pytest.fixture(scope="module")
def emps_run(data_dir):
    return discover(load("emps"), "v, 1", views=False)


def test_emps_finds_coulomb_first(emps_run):
    out = emps_run.to_dict()
    assert out["method"] == "rfs" and out["declared"] == ["1", "v"] and out["mass_estimated"]
    step = out["steps"][0]
    assert step["effect"] == "coulomb" and step["terms"] == ["sign(v)"]
    # the benchmark's figures: ~17 % relative force residual without Coulomb friction, ~4 % with it
    assert 15.0 < step["force_residual_before"] < 19.0 and step["force_residual_after"] < 5.0
    assert 15.0 < step["force_residual_before_holdout"] < 19.0 and step["force_residual_after_holdout"] < 5.0
    # epsilon of Eq. 26 is relative to f - m a, so larger
    assert step["eps_after"] < 7.5 and step["eps_after_holdout"] < 7.5 < 20.0 < step["eps_before"]
    assert 90.0 < step["mass_after"] < 100.0 and 19.0 < step["coefficients_after"]["sign(v)"] < 22.0


def test_emps_reports_whether_anything_else_is_significant(emps_run):
    check = emps_run.to_dict()["final_check"]
    fitted = [e for e in check["ranking"] if e["explained_holdout"] is not None]
    assert len(fitted) >= 5 and check["stop_reason"]
    for e in fitted:
        assert {"explained_holdout", "delta_bic", "n_eff", "eps_after_holdout", "passes"} <= set(e)


def test_silverbox_finds_the_cubic_spring_and_the_simulation_error_drops(data_dir):
    """On the benchmark's estimation part; the arrow head (a test set) is only scored, never decides."""
    arrow = load("silverbox", part="arrow-full")
    result = discover(load("silverbox", part="estimation"), "1, z, v", validation=arrow)
    out = result.to_dict()
    assert out["steps"][0]["effect"] == "cubic-stiffness"
    assert out["eps_final"] < 0.5 * out["eps_initial"] and out["eps_final_holdout"] < 0.5 * out["eps_initial_holdout"]
    # nlid's RMS simulation errors on the arrow head (no published source: docs/results.md): 10-18 mV linear,
    # about 1 mV with the cubic spring (fitted on the estimation part without its hold-out; the dictionary's
    # terms, which lowered it below 1 mV, are refused by the cross-fitted prediction since issue 31)
    assert 0.010 < out["sim_rms_initial_validation"] < 0.018
    assert out["sim_rms_final_validation"] < 0.1 * out["sim_rms_initial_validation"]
