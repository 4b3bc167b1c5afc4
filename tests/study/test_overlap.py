"""A run's scores overlap the next run's identification (issue 36): one identification at a time, the same rows.

The jobs of :mod:`overlap_gates` (beside this file) say when they started, notify ``"identified"`` as a
study run does after its identification, then wait for the next job to have started. No test asserts a time:
the files say what happened in which order.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap

import pandas as pd
import pytest

from nlid.runtime.isolation import run_in_child
from nlid.study import LocalExecutor, ResultStore, parse_study, plan_study, run_study
from nlid.study import execute as execute_module
from nlid.study.worker import run_isolated

#: Columns that measure the machine, not the result.
MACHINE = ["seconds", "method_seconds", "peak_memory_mb"]
#: An independent held-out record, so that each run has a free run and its chaos check to score.
HELD_OUT = 'mass = "known"\nholdout = "independent"'


@pytest.fixture
def gates(monkeypatch):
    """The jobs of :mod:`overlap_gates`, with two cores seen by the executor (an idle core for the scores)."""
    monkeypatch.setattr(execute_module, "default_jobs", lambda: 2)
    import overlap_gates

    return overlap_gates


def _execute(gates, folder, n, **options):
    folder.mkdir()
    runs = [gates.Scheduled(gates.Gate(i, folder, n - 1, **options)) for i in range(n)]
    payloads = {}
    LocalExecutor(jobs=1).run(runs, lambda run, payload: payloads.__setitem__(run.run_id, payload))
    return [payloads[run.run_id] for run in runs]


def test_a_notice_reaches_the_parent_before_the_reply(gates):
    tags = []
    outcome = run_in_child(gates.notified, ("identified",), timeout=60, on_notice=tags.append)
    assert outcome.status == "ok" and outcome.value == 7
    assert tags == ["identified"]


def test_with_an_idle_core_the_next_run_identifies_while_this_one_scores_one_identification_at_a_time(gates, tmp_path):
    payloads = _execute(gates, tmp_path / "marks", 4)
    rows = [p["row"] for p in payloads]
    assert all(row["status"] == "ok" for row in rows), rows
    assert all(row["previous_identified"] for row in rows)  # never two identifications at once
    assert all(row["overlapped"] for row in rows)  # each run's next one started before it ended


@pytest.mark.parametrize("fail", ["raise", "die"])
def test_a_failure_after_the_notice_is_recorded_as_without_overlap(gates, tmp_path, fail):
    overlapped = _execute(gates, tmp_path / "marks", 2, fail=fail)
    (tmp_path / "alone").mkdir()
    alone = run_isolated(gates.Gate(1, tmp_path / "alone", 1, fail=fail))  # one child, no slot: today's path
    assert [p["row"]["status"] for p in overlapped] == ["failed", "failed"]
    assert overlapped[1]["row"]["error"] == alone["row"]["error"]  # the same job: the same words
    assert ("deliberate failure in the scores" if fail == "raise" else "exit code 5") in alone["row"]["error"]


def test_the_rows_and_stored_runs_are_those_of_runs_one_after_the_other(small_study, registry, tmp_path, monkeypatch):
    monkeypatch.setattr(execute_module, "default_jobs", lambda: 2)
    config = parse_study(small_study('["rfs", "echo"]', repetitions=2, extra=HELD_OUT), registry=registry)
    run_study(config, tmp_path / "overlap", executor=LocalExecutor(jobs=1), progress=False, report=False)
    run_study(config, tmp_path / "serial", executor=LocalExecutor(jobs=1, overlap=False), progress=False, report=False)
    runs = plan_study(config)
    frames = [ResultStore(tmp_path / name).results(runs).drop(columns=MACHINE) for name in ("overlap", "serial")]
    assert len(frames[0]) == 4 and (frames[0]["status"] == "ok").all()
    pd.testing.assert_frame_equal(frames[0], frames[1])
    names = sorted(p.name for p in (tmp_path / "serial" / "runs").glob("*.json"))
    assert names == sorted(p.name for p in (tmp_path / "overlap" / "runs").glob("*.json"))
    for name in names:
        one, two = (json.loads((tmp_path / tree / "runs" / name).read_text()) for tree in ("overlap", "serial"))
        for record in (one, two):
            for key in MACHINE:
                record["row"].pop(key)
            record["result"].pop("seconds", None)
        assert one == two, name


KILLER = """
import os, signal, sys
from nlid.study import LocalExecutor, load_study, run_study
from nlid.study import execute, worker

execute.default_jobs = lambda: 2
notices = []


def run_isolated(spec, *args, on_notice=None, **kwargs):
    def notice(tag):
        notices.append(tag)
        if len(notices) == 3:  # the third run has identified and not yet scored: the study dies here
            os.kill(os.getpid(), signal.SIGKILL)
        on_notice(tag)

    return worker.run_isolated(spec, *args, on_notice=notice, **kwargs)


execute.run_isolated = run_isolated
run_study(load_study(sys.argv[1]), sys.argv[2], executor=LocalExecutor(jobs=1), progress=False, report=False)
"""


def test_a_study_killed_between_identification_and_scores_redoes_that_run_on_resume(
    small_study, plugin_path, registry, tmp_path
):
    study = tmp_path / "small.toml"
    study.write_text(small_study('["rfs", "echo"]', repetitions=3))
    out = tmp_path / "out"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(plugin_path), *sys.path]))
    script = tmp_path / "killer.py"
    script.write_text(textwrap.dedent(KILLER))
    killed = subprocess.run([sys.executable, str(script), str(study), str(out)], env=env, capture_output=True)
    assert killed.returncode == -signal.SIGKILL, killed.stderr.decode()
    stored = list((out / "runs").glob("*.json"))
    assert len(stored) <= 2  # the third run's scores were never written
    for path in stored:  # no run half-written (a temporary file the kill may leave is swept by the next run)
        assert json.loads(path.read_text())["row"]["status"] == "ok"
    cmd = [sys.executable, "-m", "nlid.cli.main", "study", "run", str(study), "--out", str(out), "--jobs", "1"]
    resumed = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=300)
    assert resumed.returncode == 0, resumed.stderr
    assert f"{len(stored)} already done, {6 - len(stored)} to run" in resumed.stderr
    frame = pd.read_csv(out / "results.csv")
    assert len(frame) == 6 and (frame["status"] == "ok").all()
    assert not list((out / "runs").glob(".*.tmp"))
