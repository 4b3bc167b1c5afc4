"""nlid bench end to end on the toy benchmark: the executor, resuming, the leaderboard, the CLI, the scoring adapter."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import nlid
from nlid import InputError
from nlid.benchmarking import BenchJob, parse_pipelines, parse_protocol
from nlid.benchmarking import jobs as bench_jobs
from nlid.cli.main import main


def test_bench_writes_the_leaderboard_and_resumes(toy, tmp_path, capsys):
    _, est, test, folder = toy
    files = {"toy:estimation": str(est), "toy:independent": str(test)}
    out = tmp_path / "out"
    first = nlid.bench([str(folder / "toy.toml")], ["rfs", "pysindy"], out=out, jobs=2, files=files, progress=False)
    assert first.executed == 2 and first.skipped == 0
    assert {p.name for p in first.paths} == {"leaderboard.csv", "leaderboard.md", "leaderboard.html", "bench.json"}
    assert (out / "figures" / "toy--independent.png").is_file() and (out / "figures" / "toy--independent.svg").is_file()
    rows = {(r["kind"], r["pipeline"]): r for r in first.rows}
    assert set(rows) == {("nlid", "rfs"), ("peer", "pysindy"), ("published", "a made-up figure")}
    rfs = rows[("nlid", "rfs")]
    assert rfs["unit"] == "mm" and 0 < rfs["rmse"] < 5 and rfs["parameters"] == 4  # 1, z, z^3, v (mass given)
    assert rfs["rule_declared"] == "window:20" and rfs["test"] == "independent"
    assert rows[("peer", "pysindy")]["same_rule"] and "initialisation window of 20" in rows[("peer", "pysindy")]["rule"]
    published = rows[("published", "a made-up figure")]
    assert published["rmse"] == pytest.approx(0.5) and not published["same_rule"]
    md = (out / "leaderboard.md").read_text()
    assert "Rule `window:20`" in md and "**other rule**: from rest" in md
    assert '<table class="board">' in (out / "leaderboard.html").read_text()
    info = json.loads((out / "bench.json").read_text())
    from nlid.cli.bench_docs import command

    assert command(info).startswith('nlid bench --benchmark toy --pipeline "rfs, pysindy" --jobs 2 --test-file')
    assert [j["status"] for j in info["jobs"]] == ["ok", "ok"]
    again = nlid.bench([str(folder / "toy.toml")], ["rfs", "pysindy"], out=out, jobs=2, files=files, progress=False)
    assert again.executed == 0 and again.skipped == 2
    assert [r["rmse"] for r in again.rows] == [r["rmse"] for r in first.rows]


def test_cli_bench(toy, tmp_path, capsys):
    _, est, test, folder = toy
    code = main(
        [
            "bench",
            "--benchmark",
            str(folder / "toy.toml"),
            "--pipeline",
            "rfs",
            "--jobs",
            "1",
            "--out",
            str(tmp_path / "o"),
            "--test-file",
            f"toy:estimation={est}",
            "--test-file",
            f"toy:independent={test}",
            "--json",
            "--no-progress",
        ]
    )
    captured = capsys.readouterr()
    assert code == 0, captured.err
    rows = json.loads(captured.out)
    assert [r["pipeline"] for r in rows if r["kind"] == "nlid"] == ["rfs"]
    assert main(["bench", "--list"]) == 0
    listing = capsys.readouterr().out
    assert (
        "test arrow-full: rule window:50; local" in listing
        and "test multisine: rule periodic:8192; user file" in listing
    )


@pytest.mark.parametrize(
    "argv, message",
    [
        (["bench", "--pipeline", "rsf"], "unknown pipeline 'rsf' (did you mean 'rfs'?)"),
        (["bench", "--benchmark", "silverbx"], "did you mean 'silverbox'"),
        (["bench", "--test-file", "bouc-wen:multisine"], "--test-file expects BENCHMARK:TEST=PATH"),
        (["bench", "--from", "x"], "--from applies to --render-docs"),
    ],
)
def test_cli_bench_errors_are_one_line(argv, message, capsys, tmp_path):
    assert main([*argv, "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_the_scoring_adapter_applies_the_protocols_transient_rule(toy):
    """A window rule scores fewer samples than the first-sample rule, and says which rule it applied."""
    from nlid.benchmarking.data import load_estimation, load_test
    from nlid.identification.pipeline import identify

    text, est, test, _ = toy
    protocol = parse_protocol(text)
    record, offsets = load_estimation(protocol, path=est)
    fit = identify(record, "z^3", "rfs", mass=0.2)
    rec = load_test(protocol, protocol.test("independent"), offsets, path=test)
    _, first_text, first, n_first = bench_jobs._score(fit, rec, "first-sample")
    scores, text_rule, applied, n = bench_jobs._score(fit, rec, "window:20")
    assert first == "first-sample" and n_first == rec.n
    assert applied == "window:20" and n == rec.n - 20
    assert text_rule != first_text and "20" in text_rule
    assert np.isfinite(scores.freerun_rmse)


def test_a_job_runs_in_a_fresh_interpreter_as_a_dask_worker_would(toy):
    """The spawn path (a fresh interpreter, as on Windows or in a daemonic Dask worker): the job comes back."""
    from nlid.study.worker import run_isolated

    text, est, test, _ = toy
    job = BenchJob.make(
        parse_protocol(text),
        tuple(parse_pipelines(["rfs"])),
        files={"toy:estimation": str(est), "toy:independent": str(test)},
        timeout=300,
    )
    assert BenchJob.from_dict(json.loads(json.dumps(job.to_dict()))) == job
    payload = run_isolated(job, use_subprocess=True)
    assert payload["row"]["status"] == "ok", payload["row"]
    (row,) = payload["result"]["rows"]
    assert row["pipeline"] == "rfs" and math.isfinite(row["rmse"])
    failed = run_isolated(job, timeout=0.01, use_subprocess=True)
    assert failed["row"]["status"] == "timeout" and failed["result"]["rows"] == []


def test_pipelines_are_parsed_once(monkeypatch):
    specs = parse_pipelines("rfs, discover, discover-refine, discover --refine, pysindy", identifiers=["rfs", "oe"])
    assert [s.name for s in specs] == ["rfs", "discover", "discover-refine", "pysindy"]
    with pytest.raises(InputError, match="names no pipeline"):
        parse_pipelines(" , ", identifiers=["rfs"])


def test_installing_an_optional_peer_makes_its_job_run_again(toy, monkeypatch):
    """A job records whether the optional package its pipeline needs is installed (its digest follows)."""
    import importlib.util

    text, _, _, _ = toy
    protocol = parse_protocol(text)
    specs = tuple(parse_pipelines(["sysidentpy"]))
    here = BenchJob.make(protocol, specs)
    assert here.installed == {"sysidentpy": importlib.util.find_spec("sysidentpy") is not None}
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "sysidentpy" else object())
    missing = BenchJob.make(protocol, specs)
    assert missing.installed == {"sysidentpy": False}
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: object())
    present = BenchJob.make(protocol, specs)
    assert present.digest() != missing.digest()
    assert BenchJob.make(protocol, tuple(parse_pipelines(["rfs"]))).installed == {}
