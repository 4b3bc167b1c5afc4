"""The test set never takes part in a decision: changing it changes the scores and nothing else."""

from __future__ import annotations

import json

import numpy as np
import pytest

from nlid.benchmarking import BenchJob, parse_pipelines, parse_protocol


def _run(protocol, files, pipelines):
    job = BenchJob.make(protocol, tuple(pipelines), files=files)
    payload = job.execute()
    assert payload["row"]["status"] == "ok", payload["row"]["error"] + str(payload.get("traceback"))
    return payload["result"]


@pytest.mark.slow
def test_changing_the_test_output_changes_no_choice_only_the_scores(toy, perturb, tmp_path):
    text, est, test, _ = toy
    protocol = parse_protocol(text)
    names = ["rfs", "linear", "discover", "discover-refine", "pysindy", "linear-ss"]
    pipelines = parse_pipelines(names)
    other = perturb(test, tmp_path / "test_perturbed.csv")
    first = _run(protocol, {"toy:estimation": str(est), "toy:independent": str(test)}, pipelines)
    second = _run(protocol, {"toy:estimation": str(est), "toy:independent": str(other)}, pipelines)

    assert [f["pipeline"] for f in first["fits"]] == names
    for a, b in zip(first["fits"], second["fits"], strict=True):
        # every decision (terms, discovery steps, coefficients to the last bit, peer hyper-parameters) is the same
        assert json.dumps(a["choices"], sort_keys=True) == json.dumps(b["choices"], sort_keys=True), a["pipeline"]
        assert a.get("coefficients") == b.get("coefficients")
        assert a["parameters"] == b["parameters"]
    # discover found the missing cubic spring on the estimation part (so there was a choice to make)
    discover = first["fits"][2]["choices"]
    assert [s["effect"] for s in discover["steps"]][:1] == ["cubic-stiffness"]
    # and only the scores moved
    rmse_a = {r["pipeline"]: r["rmse"] for r in first["rows"]}
    rmse_b = {r["pipeline"]: r["rmse"] for r in second["rows"]}
    assert set(rmse_a) == set(names)
    # the peers chose their hyper-parameters on the end of the estimation part, and say so
    peers = {f["pipeline"]: f["details"]["selection"] for f in first["fits"] if f["kind"] == "peer"}
    assert peers["pysindy"]["holdout_rule"] == "window:20" and peers["linear-ss"]["holdout_fraction"] == 0.25
    for name in rmse_a:
        assert np.isfinite(rmse_a[name]) and np.isfinite(rmse_b[name])
        assert abs(rmse_b[name] - rmse_a[name]) > 0.05 * rmse_a[name], name
    # the estimation offsets come from the estimation part alone
    assert first["offsets"] == second["offsets"]


def test_the_peers_choose_their_settings_on_the_estimation_part_only(toy, perturb, tmp_path):
    """A changed test set moves the peers' scores and none of their choices (the fast check, peers only)."""
    text, est, test, _ = toy
    protocol = parse_protocol(text)
    pipelines = parse_pipelines("pysindy, linear-ss")
    other = perturb(test, tmp_path / "test_perturbed.csv")
    first = _run(protocol, {"toy:estimation": str(est), "toy:independent": str(test)}, pipelines)
    second = _run(protocol, {"toy:estimation": str(est), "toy:independent": str(other)}, pipelines)
    for a, b in zip(first["fits"], second["fits"], strict=True):
        assert json.dumps(a["choices"], sort_keys=True) == json.dumps(b["choices"], sort_keys=True), a["pipeline"]
        assert a["details"]["selection"] == b["details"]["selection"]
        # each choice was made on the end of the estimation part, under the benchmark's window rule
        assert a["details"]["selection"]["holdout_fraction"] == 0.25
        assert a["details"]["selection"]["holdout_rule"] == "window:20"
    assert [r["rmse"] for r in first["rows"]] != [r["rmse"] for r in second["rows"]]
