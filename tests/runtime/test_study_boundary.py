"""One bad plugin never sinks a study (issue 25 group 3), and a study runs from any folder (group 1)."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest
from runtime_helpers import descendants_except_servers, marked_env, marked_processes, nlid_cli, wait_until_gone

from nlid.runtime.isolation import start_method
from nlid.study import LocalExecutor, parse_study, run_study
from nlid.study.worker import failure_payload, json_problem

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="POSIX process groups")

STUDY = """
[study]
name = "hostile"
seed = 3
repetitions = 1
timeout = {timeout}
identifiers = {identifiers}

[[datasets]]
name = "short"
preset = "paper-numerical"
overrides = {{ duration = 3.0 }}
noise = {{ z = 0.02 }}
terms = "z^3, z^2, v*|v|"
"""


def _long_folder(base: Path, name: str, length: int = 200) -> Path:
    """A folder under ``base`` whose path is at least ``length`` characters long."""
    folder = base / name
    while len(str(folder)) < length:
        folder = folder / ("d" * min(60, length - len(str(folder)) + 1))
    folder.mkdir(parents=True)
    return folder


@pytest.mark.slow
def test_a_crashing_a_hanging_and_a_non_json_plugin_do_not_sink_the_study(hostile_path, tmp_path):
    # the limit must leave rfs time on a loaded 2-core machine; rt-hang never finishes
    names = ["rfs", "rt-segv", "rt-hang", "rt-nonjson", "rt-grandchild", "rt-kbint"]
    config = parse_study(STUDY.format(timeout=15, identifiers=json.dumps(names)))
    outcome = run_study(config, tmp_path / "out", executor=LocalExecutor(jobs=2), progress=False)
    frame = pd.read_csv(tmp_path / "out" / "results.csv").set_index("method")
    assert sorted(frame.index) == sorted(names)
    assert frame.loc["rfs", "status"] == "ok" and frame.loc["rt-grandchild", "status"] == "ok"
    assert frame.loc["rt-segv", "status"] == "failed"
    assert frame.loc["rt-segv", "error"] == "identifier 'rt-segv' crashed: segmentation fault (SIGSEGV)"
    assert frame.loc["rt-hang", "status"] == "timeout"
    assert frame.loc["rt-hang", "error"] == "stopped after the time limit of 15 s"
    assert frame.loc["rt-kbint", "error"] == "identifier 'rt-kbint' raised KeyboardInterrupt"
    # the core may instead drop an unusable diagnostic with a warning (issue 25 group 4); either way the run
    # is recorded with a reason naming it and the study goes on
    nonjson = frame.loc["rt-nonjson"]
    if nonjson["status"] == "ok":
        assert "fit" in str(nonjson["warnings"]), nonjson.to_dict()
    else:
        assert nonjson["status"] == "failed"
        assert nonjson["error"].startswith("identifier 'rt-nonjson' returned a result that cannot be stored: ")
        assert "['diagnostics']['fit'] is a object, not a JSON value" in nonjson["error"]
    assert (tmp_path / "out" / "report.html").is_file() and (tmp_path / "out" / "summary.md").is_file()
    assert "| rt-segv | 0/1 (1 failed) |" in outcome.summary
    deadline = time.monotonic() + 10
    while descendants_except_servers() and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not descendants_except_servers()


def test_a_result_that_cannot_be_stored_is_that_runs_failure(tmp_path):
    """The study layer's own guard, whatever the core checked before: the run is recorded failed."""
    text = STUDY.format(timeout=60, identifiers='["rfs"]')
    config = parse_study(text)

    class Hands:
        name = "fake"

        def run(self, runs, on_done):
            for run in runs:
                payload = failure_payload(run.spec, "ok", "")
                payload["result"] = {"diagnostics": {"fit": object()}}
                on_done(run, payload)

    run_study(config, tmp_path / "out", executor=Hands(), progress=False, report=False)
    record = json.loads(next((tmp_path / "out" / "runs").glob("*.json")).read_text())
    assert record["row"]["status"] == "failed"
    assert record["row"]["error"].startswith("identifier 'rfs' returned a result that cannot be stored: TypeError")
    assert json_problem({"a": [1.0, {"b": object()}]}) == "['a'][1]['b'] is a object, not a JSON value"
    assert json_problem({"a": float("inf")}) is None  # to_jsonable writes non-finite numbers as null


@pytest.mark.slow
def test_a_study_and_identify_run_from_a_200_character_folder_with_a_200_character_tmpdir(
    hostile_path, record_csv, tmp_path
):
    work = _long_folder(tmp_path, "work")
    tmp = _long_folder(tmp_path, "tmp")
    (work / "s.toml").write_text(STUDY.format(timeout=120, identifiers='["rfs"]'))
    env, mark = marked_env(hostile_path, TMPDIR=str(tmp))
    proc = nlid_cli(["identify", str(record_csv), "--terms", "z^3", "--timeout", "120", "--json"], env, cwd=work)
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout)["method"] == "rfs"
    proc = nlid_cli(["study", "run", "s.toml", "--out", "out", "--no-progress"], env, cwd=work)
    assert proc.returncode == 0, proc.stderr
    assert (pd.read_csv(work / "out" / "results.csv")["status"] == "ok").all()
    assert not wait_until_gone(mark)
    assert not list(tmp.iterdir()), "something was left in the temporary folder"


@pytest.mark.slow
def test_a_sigkill_right_at_the_start_leaves_no_process_and_nothing_in_the_temporary_folder(hostile_path, tmp_path):
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    (tmp_path / "s.toml").write_text(STUDY.format(timeout=600, identifiers='["rt-hang"]'))
    env, mark = marked_env(hostile_path, TMPDIR=str(tmp))
    # at once (while it starts), and once a run is going (with its fork server, unless spawned)
    for wait_for in (1, 2 if start_method() == "spawn" else 3):
        cmd = [sys.executable, "-m", "nlid.cli.main", "study", "run", "s.toml", "--out", f"out{wait_for}"]
        proc = subprocess.Popen(cmd, env=env, cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        deadline = time.monotonic() + 120
        while len(marked_processes(mark)) < wait_for and time.monotonic() < deadline:
            assert proc.poll() is None, "the study ended early"
            time.sleep(0.05)
        proc.send_signal(signal.SIGKILL)
        proc.wait(30)
        assert not wait_until_gone(mark, 30), "processes outlived the killed study"
        assert not list(tmp.iterdir()), "the killed study left something in the temporary folder"
