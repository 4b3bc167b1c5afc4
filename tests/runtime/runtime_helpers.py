"""Helpers of the tests of nlid's process boundary: a census of processes, the command line in a subprocess."""

from __future__ import annotations

import os
import subprocess
import sys
import time
import uuid
from pathlib import Path

import psutil


def marked_env(hostile_path: Path, **extra: str) -> tuple[dict[str, str], str]:
    """An environment for a command-line run, with the plugins on its path and a unique marker.

    Every process the run starts inherits the marker, so :func:`marked_processes`
    finds whatever it left behind.
    """
    mark = uuid.uuid4().hex
    env = dict(os.environ, NLID_TEST_MARK=mark, **extra)
    env["PYTHONPATH"] = os.pathsep.join([str(hostile_path), *sys.path])
    return env, mark


def marked_processes(mark: str) -> list[str]:
    """Live processes whose environment holds ``NLID_TEST_MARK=mark`` (``"pid: command"``)."""
    found = []
    for proc in psutil.process_iter(["pid", "cmdline", "status"]):
        try:
            if proc.info["status"] == psutil.STATUS_ZOMBIE:
                continue
            if proc.environ().get("NLID_TEST_MARK") == mark:
                found.append(f"{proc.pid}: {' '.join(proc.info['cmdline'] or [])}")
        except (psutil.Error, OSError):
            continue
    return found


def wait_until_gone(mark: str, seconds: float = 15.0) -> list[str]:
    """The marked processes still alive after up to ``seconds``."""
    deadline = time.monotonic() + seconds
    left = marked_processes(mark)
    while left and time.monotonic() < deadline:
        time.sleep(0.2)
        left = marked_processes(mark)
    return left


def nlid_cli(args: list[str], env: dict[str, str], cwd: Path | str | None = None, timeout: float = 300):
    """Run ``python -m nlid.cli.main ARGS``; the completed process (text output)."""
    return subprocess.run(
        [sys.executable, "-m", "nlid.cli.main", *args],
        env=env,
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=timeout,
        stdin=subprocess.DEVNULL,
    )


def descendants_except_servers() -> list[str]:
    """Descendants of this process that are not nlid's fork servers (``"pid: command"``).

    This interpreter's own ``multiprocessing`` resource tracker is left out too: the standard library starts it
    once, at the first spawned process of the interpreter (here: another test's spawn pool in the same pytest
    worker, e.g. tests/bayes/test_calibration.py), and keeps it for the interpreter's lifetime; no code under test
    left it behind.
    """
    from multiprocessing import resource_tracker

    tracker = getattr(resource_tracker._resource_tracker, "_pid", None)
    out = []
    for proc in psutil.Process().children(recursive=True):
        try:
            cmd = " ".join(proc.cmdline())
            if proc.status() == psutil.STATUS_ZOMBIE or "nlid.runtime.forkserver" in cmd or proc.pid == tracker:
                continue
            out.append(f"{proc.pid}: {cmd}")
        except psutil.Error:
            continue
    return out
