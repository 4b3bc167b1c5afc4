"""Persistence: a study killed half-way resumes without redoing finished runs."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import pandas as pd
import pytest

from nlid.study import ResultStore, parse_study, plan_study, run_study


def _snapshot(folder):
    return {p.name: (p.stat().st_mtime_ns, p.read_bytes()) for p in (folder / "runs").glob("*.json")}


@pytest.mark.slow
def test_killed_study_resumes_without_redoing_finished_runs(small_study, plugin_path, registry, tmp_path):
    study = tmp_path / "slow.toml"
    study.write_text(
        small_study('["echo"]', repetitions=6, duration=2.0, extra="[datasets.methods.echo]\noptions = { sleep = 0.5 }")
    )
    out = tmp_path / "out"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(plugin_path), *sys.path]))
    cmd = [sys.executable, "-m", "nlid.cli.main", "study", "run", str(study), "--out", str(out), "--jobs", "1"]
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and len(list((out / "runs").glob("*.json"))) < 2:
        assert proc.poll() is None, proc.stderr.read()
        time.sleep(0.05)
    proc.send_signal(signal.SIGKILL)
    proc.wait(30)
    proc.stderr.close()
    assert proc.returncode == -signal.SIGKILL
    before = _snapshot(out)
    assert 2 <= len(before) < 6, "the study should have been killed half-way"
    for name, (_, data) in before.items():
        assert json.loads(data)["row"]["status"] == "ok", name  # complete files only
    assert not list((out / "runs").glob(".*.tmp"))

    resumed = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=300)
    assert resumed.returncode == 0, resumed.stderr
    assert f"{len(before)} already done, {6 - len(before)} to run" in resumed.stderr
    after = _snapshot(out)
    assert len(after) == 6
    for name, stamp in before.items():
        assert after[name] == stamp, f"{name} was redone"
    frame = pd.read_csv(out / "results.csv")
    assert len(frame) == 6 and (frame["status"] == "ok").all()
    assert sorted(frame["repetition"]) == list(range(6))


def test_rerun_redoes_and_a_changed_config_invalidates(small_study, registry, tmp_path):
    config = parse_study(small_study('["echo"]', repetitions=2, duration=2.0), registry=registry)
    first = run_study(config, tmp_path, progress=False, report=False)
    again = run_study(config, tmp_path, progress=False, report=False)
    assert (first.executed, again.executed, again.skipped) == (2, 0, 2)
    assert run_study(config, tmp_path, progress=False, report=False, rerun=True).executed == 2
    changed = parse_study(
        small_study('["echo"]', repetitions=3, duration=2.0, extra='without = "1"'), registry=registry
    )
    outcome = run_study(changed, tmp_path, progress=False, report=False)
    assert outcome.executed == 3, "a changed model must not reuse stored runs"
    rows = ResultStore(tmp_path).results(plan_study(changed))
    assert "coef:1" not in rows.columns and len(rows) == 3
