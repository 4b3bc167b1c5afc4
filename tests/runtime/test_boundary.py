"""The process boundary (issue 25, groups 1-3): whatever plugin code does, nlid gives one line and leaves nothing.

Checked by looking at the processes (psutil: the child's process group, this
process's descendants, every process carrying a run's marker), not by trust.
"""

from __future__ import annotations

import ctypes
import json
import os
import subprocess
import sys
import threading
import time
import warnings

import psutil
import pytest
from runtime_helpers import descendants_except_servers, marked_env, nlid_cli, wait_until_gone

from nlid.errors import InputError
from nlid.runtime.isolation import kill_children, run_in_child, start_method
from nlid.runtime.outcome import IsolationError, PluginWarning

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="POSIX process groups")


# --------------------------------------------------------------------------- targets (pickled by reference)
def _segfault():
    ctypes.string_at(0)


def _abort():
    os.abort()


def _sleep_forever():
    subprocess.Popen(["sleep", "100002"])
    while True:
        time.sleep(0.1)


def _leave_everything_behind():
    subprocess.Popen(["sleep", "100003"])
    subprocess.Popen(["sleep", "100004"], start_new_session=True)
    threading.Thread(target=time.sleep, args=(100000,), name="left-behind").start()
    return 5


def _prints():
    print("TARGET PRINTS")
    sys.stdout.flush()
    os.write(1, b"TARGET WRITES TO FD 1\n")
    return 1


def _warns():
    for _ in range(3):
        warnings.warn("careful", stacklevel=1)
    warnings.warn("deprecated thing", DeprecationWarning, stacklevel=1)
    return 2


def _interrupts():
    raise KeyboardInterrupt


def _big(size):
    return b"x" * size


def _returns_a_lambda():
    return lambda: 0


def _group_members(pgid: int) -> list[int]:
    """Live (not zombie) processes in process group ``pgid``."""
    found = []
    for proc in psutil.process_iter(["status"]):
        try:
            if proc.info["status"] != psutil.STATUS_ZOMBIE and os.getpgid(proc.pid) == pgid:
                found.append(proc.pid)
        except (psutil.Error, OSError):
            continue
    return found


def _group_gone(pgid: int, seconds: float = 10.0) -> bool:
    """No live process left in the group (killed processes take a moment to die)."""
    deadline = time.monotonic() + seconds
    while _group_members(pgid) and time.monotonic() < deadline:
        time.sleep(0.05)
    return not _group_members(pgid)


def _settle(seconds: float = 10.0) -> list[str]:
    deadline = time.monotonic() + seconds
    left = descendants_except_servers()
    while left and time.monotonic() < deadline:
        time.sleep(0.1)
        left = descendants_except_servers()
    return left


# --------------------------------------------------------------------------- the API
@pytest.mark.parametrize(
    "target, words",
    [(_segfault, "crashed: segmentation fault (SIGSEGV)"), (_abort, "crashed: aborted (SIGABRT)")],
)
def test_a_crash_is_one_line_naming_the_signal_and_leaves_no_process(target, words):
    outcome = run_in_child(target, timeout=120)
    assert outcome.status == "died"
    assert outcome.describe("identifier 'x'") == f"identifier 'x' {words}"
    assert _group_gone(outcome.pid)
    assert not _settle()


def test_a_child_at_its_time_limit_is_killed_with_its_process_group():
    outcome = run_in_child(_sleep_forever, timeout=1.5)
    assert outcome.status == "timeout"
    assert outcome.describe("identifier 'x'", 1.5) == (
        "identifier 'x' did not finish within the time limit of 1.5 s and was stopped"
    )
    assert _group_gone(outcome.pid)
    assert not _settle(), "the sleep the target started outlived it"


def test_threads_and_grandchildren_end_with_the_child_even_out_of_its_group():
    outcome = run_in_child(_leave_everything_behind, timeout=120)
    assert outcome.status == "ok" and outcome.value == 5
    assert outcome.threads == ("left-behind",)
    assert "left 1 thread(s) running (left-behind)" in outcome.warning_lines("identifier 'x'")[-1]
    assert _group_gone(outcome.pid)
    assert not _settle(), "a grandchild outlived the child"


def test_what_a_child_prints_goes_to_stderr_never_to_stdout(capfd):
    assert run_in_child(_prints, timeout=120).value == 1
    out, err = capfd.readouterr()
    assert "TARGET" not in out
    assert "TARGET PRINTS" in err and "TARGET WRITES TO FD 1" in err


def test_warnings_come_back_once_each_with_a_count_naming_the_plugin():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # the child applies this process's filters
        warnings.simplefilter("always", UserWarning)
        outcome = run_in_child(_warns, timeout=120)
    assert outcome.status == "ok"
    assert [(w.message, w.count) for w in outcome.warnings] == [("careful", 3)]
    with pytest.warns(PluginWarning) as record:
        outcome.reissue_warnings("identifier 'x'")
    assert len(record) == 1 and issubclass(record[0].category, UserWarning)
    assert str(record[0].message).startswith("identifier 'x': careful (test_boundary.py:") and " x3" in str(
        record[0].message
    )


def test_keyboard_interrupt_in_the_child_is_its_failure_without_a_traceback(capfd):
    outcome = run_in_child(_interrupts, timeout=120)
    assert outcome.status == "raised" and outcome.kind == "KeyboardInterrupt"
    assert outcome.describe("identifier 'x'") == "identifier 'x' raised KeyboardInterrupt"
    assert "Traceback" not in capfd.readouterr().err


def test_a_value_that_cannot_come_back_is_reported():
    outcome = run_in_child(_returns_a_lambda, timeout=120)
    assert outcome.status == "unsent"
    assert outcome.describe("identifier 'x'").startswith("identifier 'x' returned a result that cannot be sent back")


def test_large_work_and_large_replies_cross_whole():
    """Both ways through the socket in many pieces (a discovery's result is megabytes)."""
    size = 20_000_000
    outcome = run_in_child(_big, (size,), timeout=120)
    assert outcome.status == "ok" and len(outcome.value) == size
    assert run_in_child(len, (b"y" * size,), timeout=120).value == size


def test_work_that_cannot_be_sent_raises_isolation_error():
    with pytest.raises(IsolationError, match="cannot send the work to a child process"):
        run_in_child(_prints, (lambda: 0,))


def test_an_interrupted_caller_kills_its_children():
    box = {}
    thread = threading.Thread(target=lambda: box.update(outcome=run_in_child(_sleep_forever, timeout=300)))
    thread.start()
    deadline = time.monotonic() + 120
    while not any("sleep 100002" in p for p in descendants_except_servers()) and time.monotonic() < deadline:
        time.sleep(0.1)
    kill_children()
    thread.join(60)
    assert box["outcome"].status == "died" and box["outcome"].exitcode == -9
    assert not _settle()


def test_the_start_method_is_chosen_by_the_environment(monkeypatch):
    monkeypatch.setenv("NLID_START_METHOD", "spawn")
    assert start_method() == "spawn"
    monkeypatch.setenv("NLID_START_METHOD", "threads")
    with pytest.raises(InputError, match="NLID_START_METHOD='threads' is not a start method"):
        start_method()
    monkeypatch.delenv("NLID_START_METHOD")
    assert start_method() == ("forkserver" if hasattr(os, "fork") else "spawn")


@pytest.mark.slow
def test_the_spawn_fallback_keeps_the_time_limit_and_the_crash_report():
    assert run_in_child(_prints, timeout=120, method="spawn").value == 1
    hung = run_in_child(_sleep_forever, timeout=3, method="spawn")
    assert hung.status == "timeout" and _group_gone(hung.pid)
    crashed = run_in_child(_segfault, timeout=120, method="spawn")
    assert crashed.describe("identifier 'x'") == "identifier 'x' crashed: segmentation fault (SIGSEGV)"
    assert not _settle()


# --------------------------------------------------------------------------- the command line
@pytest.mark.slow
@pytest.mark.parametrize(
    "method, args, status, line",
    [
        ("rt-segv", [], 2, "nlid identify: error: identifier 'rt-segv' crashed: segmentation fault (SIGSEGV)"),
        ("rt-abort", [], 2, "nlid identify: error: identifier 'rt-abort' crashed: aborted (SIGABRT)"),
        (
            "rt-hang",
            ["--timeout", "3"],
            1,
            "nlid identify: error: identifier 'rt-hang' did not finish within the time limit of 3 s and was "
            "stopped (raise --timeout)",
        ),
        ("rt-kbint", [], 2, "nlid identify: error: identifier 'rt-kbint' raised KeyboardInterrupt"),
    ],
)
def test_identify_with_a_faulty_plugin_ends_with_one_line_and_no_process(
    hostile_path, record_csv, method, args, status, line
):
    env, mark = marked_env(hostile_path)
    proc = nlid_cli(["identify", str(record_csv), "--method", method, "--terms", "z^3", *args], env)
    assert (proc.returncode, proc.stderr.strip().splitlines()) == (status, [line])
    assert proc.stdout == ""
    assert not wait_until_gone(mark)


@pytest.mark.slow
def test_a_plugin_that_leaves_threads_and_processes_behind_leaves_nothing(hostile_path, record_csv):
    """subprocess.run returns only when no process holds nlid's stdout and stderr any more."""
    env, mark = marked_env(hostile_path)
    for method in ("rt-grandchild", "rt-threads"):
        proc = nlid_cli(["identify", str(record_csv), "--method", method, "--terms", "z^3", "--json"], env)
        assert proc.returncode == 0, proc.stderr
        assert json.loads(proc.stdout)["method"] == method
        assert not wait_until_gone(mark)
    assert proc.stderr.strip().splitlines() == [
        "nlid identify: warning: identifier 'rt-threads' left 1 thread(s) running (rt-forever); they ended with "
        "its process"
    ]


@pytest.mark.slow
def test_json_output_stays_clean_when_a_plugin_prints_and_warnings_are_one_line(hostile_path, record_csv):
    env, mark = marked_env(hostile_path, NLID_TEST_PRINT_AT_IMPORT="1")
    proc = nlid_cli(["identify", str(record_csv), "--method", "rt-print", "--terms", "z^3", "--json"], env)
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout)["method"] == "rt-print"
    assert "HOSTILE PLUGIN PRINTS" in proc.stderr and "HOSTILE PLUGIN WRITES TO FD 1" in proc.stderr
    proc = nlid_cli(["identify", str(record_csv), "--method", "rt-warn", "--terms", "z^3"], env)
    assert proc.returncode == 0, proc.stderr
    lines = [x for x in proc.stderr.splitlines() if "careful" in x or "warn(" in x]
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith(
        "nlid identify: warning: identifier 'rt-warn': this plugin is being careful (nlid_runtime_test_plugins.py:"
    )
    assert not wait_until_gone(mark)


@pytest.mark.slow
def test_discover_has_a_time_limit(hostile_path, record_csv):
    env, mark = marked_env(hostile_path)
    proc = nlid_cli(
        ["discover", str(record_csv), "--declared", "1, z, v", "--method", "rt-hang", "--timeout", "3", "--quiet"],
        env,
    )
    assert proc.returncode == 1
    assert proc.stderr.strip().splitlines() == [
        "nlid discover: error: the search with identifier 'rt-hang' did not finish within the time limit of 3 s "
        "and was stopped (raise --timeout)"
    ]
    assert not wait_until_gone(mark)


def test_the_default_time_limits_are_stated_in_the_help():
    from nlid.cli.isolated import parse_timeout
    from nlid.cli.main import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command").choices
    for command, default in (("identify", "600"), ("discover", "1800")):
        text = " ".join(sub[command].format_help().split())
        assert f"(default {default}; 0 or 'none': no limit)" in text, command
    assert parse_timeout(sub["identify"].parse_args(["x", "--timeout", "none"]).timeout) == float("inf")
    assert parse_timeout(sub["identify"].parse_args(["x", "--timeout", "0"]).timeout) == float("inf")
    assert parse_timeout(sub["identify"].parse_args(["x", "--timeout", "2.5"]).timeout) == 2.5
    assert parse_timeout(sub["identify"].parse_args(["x"]).timeout) == 600
    with pytest.raises(InputError, match="--timeout must be a number of seconds"):
        parse_timeout("-1")
