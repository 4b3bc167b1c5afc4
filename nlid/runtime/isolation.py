"""Running code in a child process that can be stopped, and that never outlives nlid.

:func:`run_in_child` calls a function in a child forked from a
``multiprocessing`` fork server that has nlid imported (cheap to start): a
child still running at its time limit is killed, a child that dies is
reported with its exit code or signal, and its return value comes back
through a pipe. Studies run every identification this way
(:func:`nlid.study.worker.run_isolated`) and so does ``nlid identify
--timeout`` (:func:`nlid.pipeline.identify` with ``timeout=``).

Children die with their parent, even when the parent is killed with
``SIGKILL`` and cannot clean up: on Linux every child and the fork server ask
the kernel for a signal when their parent dies (``prctl(PR_SET_PDEATHSIG)``,
:func:`die_with_parent`), the fork server then removes the temporary folder
of its socket (``pymp-*``) before it exits, and a run child forked from it
closes its copy of the fork server's "parent alive" pipe so the fork server
sees the parent go. :func:`kill_children` stops every live child at once
(on Ctrl-C or ``SIGTERM``).
"""

from __future__ import annotations

import ctypes
import multiprocessing
import os
import signal
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from multiprocessing.connection import wait
from typing import Any

__all__ = [
    "ChildResult",
    "run_in_child",
    "kill_children",
    "die_with_parent",
    "describe_exit",
    "start_fork_server",
    "PARENT_ENV",
    "FORKSERVER_ENV",
]

#: Environment variable holding the pid of the process that started the fork server (or a subprocess child).
PARENT_ENV = "NLID_ISOLATION_PARENT"
#: Environment variable the fork server sets to its own pid (inherited by the children it forks).
FORKSERVER_ENV = "NLID_FORKSERVER_PID"
#: Modules the fork server imports once (children start with them loaded): its own set-up (parent
#: death, one thread per numerical library), the study worker, then the plugins and compiled kernels.
PRELOAD = ["nlid.runtime.forkserver", "nlid.study.worker", "nlid.runtime.preload"]

_LIVE: set[Any] = set()
_LIVE_LOCK = threading.Lock()
_PR_SET_PDEATHSIG = 1


@dataclass(frozen=True)
class ChildResult:
    """What became of a child.

    Attributes
    ----------
    status
        ``"ok"`` (it returned :attr:`value`), ``"timeout"`` (killed at the
        time limit) or ``"died"`` (it ended without returning).
    value
        The function's return value (``status == "ok"``).
    exitcode
        The child's exit code (negative: killed by that signal).
    seconds
        Wall time.
    """

    status: str
    value: Any = None
    exitcode: int | None = None
    seconds: float = 0.0


def describe_exit(exitcode: int | None) -> str:
    """``"exit code 3"`` or ``"signal 11 (SIGSEGV)"``."""
    if exitcode is None:
        return "an unknown exit status"
    if exitcode < 0:
        try:
            return f"signal {-exitcode} ({signal.Signals(-exitcode).name})"
        except ValueError:
            return f"signal {-exitcode}"
    return f"exit code {exitcode}"


def die_with_parent(expected_parent: int | None = None, sig: int = signal.SIGKILL) -> bool:
    """Ask the kernel to send ``sig`` to this process when its parent dies (Linux; elsewhere a no-op).

    Parameters
    ----------
    expected_parent
        The pid the parent should have: if the parent is already gone (this
        process was re-parented before the request took effect), exit at once.
    sig
        The signal.

    Returns
    -------
    bool
        Whether the request took effect.
    """
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        ok = libc.prctl(_PR_SET_PDEATHSIG, int(sig), 0, 0, 0) == 0
    except (OSError, AttributeError):  # pragma: no cover - no libc prctl
        return False
    if expected_parent and os.getppid() != expected_parent:
        os._exit(1)
    return ok


def start_fork_server() -> None:
    """Start nlid's fork server now, from this thread, if it is not running.

    Call it from the main thread before starting worker threads: the fork
    server's parent-death signal is tied to the thread that started it.
    """
    _context()
    from multiprocessing import forkserver

    forkserver.ensure_running()


def _context() -> Any:
    ctx = multiprocessing.get_context("forkserver")
    ctx.set_forkserver_preload(PRELOAD)
    os.environ[PARENT_ENV] = str(os.getpid())
    return ctx


def _close_alive_pipe() -> None:
    """Close this child's copy of the fork server's "parent alive" pipe (so the fork server sees the parent die)."""
    try:
        from multiprocessing import forkserver

        fd = getattr(forkserver._forkserver, "_forkserver_alive_fd", None)
        if fd is not None:
            os.close(fd)
            forkserver._forkserver._forkserver_alive_fd = None
    except (OSError, AttributeError):
        pass


def _child_entry(target: Callable[..., Any], args: tuple, conn: Any, path: list[str], env: dict[str, str]) -> None:
    """The child: die with the fork server, take the parent's path and environment, run, send the value."""
    server = os.environ.get(FORKSERVER_ENV)
    die_with_parent(int(server) if server else None)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    _close_alive_pipe()
    sys.path[:] = path
    os.environ.clear()
    os.environ.update(env)
    value = target(*args)
    try:
        conn.send(value)
    except OSError:  # the parent is gone: nothing to report to
        pass
    finally:
        conn.close()


def kill_children() -> None:
    """Kill every child process this process started (on interrupt)."""
    with _LIVE_LOCK:
        live = list(_LIVE)
    for proc in live:
        try:
            proc.kill()
        except (OSError, ValueError):
            pass


def track(proc: Any) -> None:
    """Count a child started another way (e.g. ``subprocess``) among those :func:`kill_children` kills."""
    with _LIVE_LOCK:
        _LIVE.add(proc)


def untrack(proc: Any) -> None:
    """Undo :func:`track`."""
    with _LIVE_LOCK:
        _LIVE.discard(proc)


def run_in_child(target: Callable[..., Any], args: tuple = (), *, timeout: float | None = None) -> ChildResult:
    """Call ``target(*args)`` in a child process, killed at the time limit.

    ``target``, ``args`` and the return value cross the process boundary
    pickled (between nlid's own processes; no user file is unpickled). The
    child gets this process's ``sys.path`` and environment, so plugins
    visible here are visible there.

    Parameters
    ----------
    target
        A module-level function.
    args
        Its arguments.
    timeout
        Seconds (``None``: no limit).

    Raises
    ------
    RuntimeError
        Inside a daemonic process, which may not have children.
    """
    if multiprocessing.current_process().daemon:
        raise RuntimeError("a daemonic process cannot start isolated children")
    ctx = _context()
    receiver, sender = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=_child_entry, args=(target, args, sender, list(sys.path), dict(os.environ)), daemon=False)
    start = time.perf_counter()
    with _LIVE_LOCK:
        proc.start()
        _LIVE.add(proc)
    sender.close()
    try:
        ready = wait([receiver, proc.sentinel], timeout)
        if receiver in ready:
            try:
                value = receiver.recv()
            except EOFError:
                proc.join(5)
                result = ChildResult("died", exitcode=proc.exitcode)
            else:
                result = ChildResult("ok", value=value)
        elif ready:
            proc.join(5)
            result = ChildResult("died", exitcode=proc.exitcode)
        else:
            proc.kill()
            result = ChildResult("timeout")
        proc.join(5)
        if proc.is_alive():
            proc.kill()
            proc.join()
    finally:
        receiver.close()
        with _LIVE_LOCK:
            _LIVE.discard(proc)
    exitcode = result.exitcode if result.exitcode is not None else proc.exitcode
    return ChildResult(result.status, result.value, exitcode, time.perf_counter() - start)
