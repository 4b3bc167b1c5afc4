"""Isolation that holds (issue 18, group 3): children die with a killed study, folders are locked."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from nlid.cli.main import main
from nlid.runtime.isolation import run_in_child, start_method
from nlid.runtime.outputs import STUDY_OUTPUTS, FolderBusyError, output_folder


def _children() -> dict[int, list[int]]:
    """``{parent pid: [child pids]}`` of every process visible in /proc."""
    out: dict[int, list[int]] = {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
        except OSError:
            continue
        ppid = int(stat.rsplit(")", 1)[1].split()[1])
        out.setdefault(ppid, []).append(int(entry.name))
    return out


def _descendants(pid: int) -> set[int]:
    tree = _children()
    found, todo = set(), [pid]
    while todo:
        for child in tree.get(todo.pop(), []):
            if child not in found:
                found.add(child)
                todo.append(child)
    return found


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="parent-death signals are Linux only")
def test_sigkill_of_a_study_takes_its_fork_server_and_runs_along(small_study, plugin_path, registry, tmp_path):
    study = tmp_path / "hang.toml"
    study.write_text(small_study('["hang"]', repetitions=1, duration=2.0, timeout=600))
    # pytest-xdist's deep tmp_path as TMPDIR: the fork server has no socket file (issue 25, group 1)
    private_tmp = tmp_path / "tmp"
    private_tmp.mkdir()
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(plugin_path), *sys.path]), TMPDIR=str(private_tmp))
    cmd = [
        sys.executable,
        "-m",
        "nlid.cli.main",
        "study",
        "run",
        str(study),
        "--out",
        str(tmp_path / "out"),
        "--jobs",
        "1",
        "--no-progress",
    ]
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 120
        family: set[int] = set()
        # the run child is up: a grandchild of the study (forked by the fork server) or a child (spawn)
        wanted = 1 if start_method() == "spawn" else 2
        while time.monotonic() < deadline:
            family = _descendants(proc.pid)
            if len(family) >= wanted:
                break
            assert proc.poll() is None, "the study ended early"
            time.sleep(0.2)
        else:
            pytest.fail("the run process never started")
        family = _descendants(proc.pid)
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait(30)
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline and any(_alive(p) for p in family):
        time.sleep(0.2)
    assert not [p for p in family if _alive(p)], "processes outlived the killed study"
    assert not list(private_tmp.iterdir()), "the study left something in the temporary folder"


def test_a_second_writer_of_a_folder_is_refused_naming_the_first(tmp_path):
    folder = tmp_path / "out"
    with output_folder(folder, STUDY_OUTPUTS):
        with pytest.raises(FolderBusyError, match=f"is being written by nlid process {os.getpid()}"):
            with output_folder(folder, STUDY_OUTPUTS):
                pass
    with output_folder(folder, STUDY_OUTPUTS):  # released when the first writer is done
        pass


def test_study_run_into_a_folder_being_written_exits_2(small_study, registry, tmp_path, capsys):
    study = tmp_path / "s.toml"
    study.write_text(small_study('["rfs"]', repetitions=1, duration=2.0))
    folder = tmp_path / "out"
    with output_folder(folder, STUDY_OUTPUTS):
        status = main(["study", "run", str(study), "--out", str(folder), "--no-progress"])
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and len(err) == 1 and "is being written by nlid process" in err[0], err
    assert not (folder / "runs").exists() or not list((folder / "runs").iterdir())


def _child_state() -> tuple[bool, bool, int]:
    import numba

    return "nlid.simulation" in sys.modules, "nlid_nsi" in sys.modules, numba.config.NUMBA_NUM_THREADS


def test_a_run_child_starts_warm_with_one_thread_per_library():
    """The fork server loaded the simulator and the plugins, and pinned numba/BLAS to one thread (issue 14).

    A spawned child (``NLID_START_METHOD=spawn``) starts cold by design, with the same thread pins.
    """
    outcome = run_in_child(_child_state, timeout=120, pin_threads=True)
    assert outcome.status == "ok"
    simulator, plugin, threads = outcome.value
    if start_method() == "forkserver":
        assert simulator and plugin
    if "NUMBA_NUM_THREADS" not in os.environ:
        assert threads == 1
