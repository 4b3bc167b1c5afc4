"""Running code in a child process that can be stopped, that cannot take nlid down, and that never outlives it.

:func:`run_in_child` calls a function in a child process and returns a
:class:`ChildResult`: its value, or what went wrong, in words a user can act
on (:meth:`ChildResult.describe`): ``"identifier 'x' crashed: segmentation
fault (SIGSEGV)"``, ``"... did not finish within the time limit of 600 s and
was stopped"``, ``"... raised ValueError: ..."``. Studies run every
identification this way (:func:`nlid.study.worker.run_isolated`), and so do
``nlid identify`` and ``nlid discover`` (with a default time limit), and
:func:`nlid.identify` when given ``timeout=``.

Start methods (:func:`start_method`)
    ``forkserver`` (POSIX; the default there): the child is forked from
    nlid's own fork server (:mod:`nlid.runtime.forkserver`), which has nlid
    and the plugins loaded, so a child costs a few milliseconds. The server
    talks to this process over an anonymous socket pair: no socket file, so
    no ``AF_UNIX path too long`` and no ``pymp-*`` folder, whatever the
    temporary or working folder. ``spawn`` (Windows, or
    ``NLID_START_METHOD=spawn``): each child is a fresh ``python -m
    nlid.runtime.child``, killed at its time limit just the same; it loads
    what the fork server would have loaded and then says it is ready, and
    the time limit counts from then, as it does from a fork (so a limit
    bounds the work, not the interpreter's start-up). Neither
    imports the user's ``__main__`` again, so scripts need no ``if __name__
    == "__main__"`` guard, and a script read from stdin works.

The child (:mod:`nlid.runtime.child`)
    runs in a session and process group of its own (deaf to the terminal's
    Ctrl-C, which stops this process, which then kills the child); prints to
    stderr, never to this process's stdout; records its warnings, which come
    back as one :class:`PluginWarning` each (:meth:`ChildResult.reissue_warnings`);
    and ends its whole process group when it has replied, so threads and
    grandchildren a plugin leaves behind end with it. A child at its time
    limit, or whose caller is interrupted, is killed with its process group.

Dying with nlid
    On Linux the fork server and every child ask the kernel for a signal when
    their parent dies, so even a ``SIGKILL`` of nlid leaves no process
    behind; the fork server also ends when this process closes its socket.
    Elsewhere the fork server ends with its socket and kills the children's
    groups; a child of a SIGKILLed nlid runs until it finishes.
"""

from __future__ import annotations

import atexit
import contextlib
import math
import os
import pickle
import select
import signal
import socket
import subprocess
import sys
import threading
import time
import warnings
from collections.abc import Callable
from typing import Any

from ..errors import InputError
from .child import HEADER, NOTICE, READY, frame
from .forkserver import PIN_ENV
from .outcome import _CATEGORIES, ChildResult, IsolationError, result_from_reply
from .preload import PRELOAD_ENV, PRELOAD_LIMIT
from .process import pin_threads

__all__ = [
    "run_in_child",
    "kill_children",
    "start_fork_server",
    "start_method",
    "track",
    "untrack",
    "START_METHOD_ENV",
    "PARENT_ENV",
]

#: Environment variable choosing the start method: ``forkserver`` or ``spawn`` (default: the platform's best).
START_METHOD_ENV = "NLID_START_METHOD"
#: Environment variable holding the pid of the nlid process that started a fork server or a spawned child.
PARENT_ENV = "NLID_ISOLATION_PARENT"
#: Longest wait for the fork server to start a child (s): its preload is bounded by ``PRELOAD_LIMIT``.
START_LIMIT = PRELOAD_LIMIT + 60.0
#: After its reply (or after being killed), how long a child may take to be reported ended (s).
END_LIMIT = 10.0

_LIVE: dict[int, Any] = {}  # pid -> "group" (forked child) or its Popen (spawned child, or tracked)
_LIVE_LOCK = threading.Lock()


# --------------------------------------------------------------------------- start method
def _fork_server_possible() -> bool:
    return (
        sys.platform != "win32"
        and hasattr(os, "fork")
        and hasattr(socket, "AF_UNIX")
        and hasattr(socket, "send_fds")
        and hasattr(os, "killpg")
    )


def start_method() -> str:
    """``"forkserver"`` or ``"spawn"``: the environment variable :data:`START_METHOD_ENV`, else the platform's best.

    Raises
    ------
    InputError
        The variable names no start method, or one this platform lacks.
    """
    value = os.environ.get(START_METHOD_ENV, "").strip().lower()
    if value in ("", "auto"):
        return "forkserver" if _fork_server_possible() else "spawn"
    if value == "spawn":
        return "spawn"
    if value in ("forkserver", "fork-server"):
        if not _fork_server_possible():
            raise InputError(f"{START_METHOD_ENV}={value}: the fork server needs POSIX; use spawn on this platform")
        return "forkserver"
    raise InputError(f"{START_METHOD_ENV}={value!r} is not a start method; choose forkserver or spawn")


def _child_env(pinned: bool) -> dict[str, str]:
    """The environment of a fork server or spawned child: this one, with this process's import path."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(os.path.abspath(p) if p else os.getcwd() for p in sys.path)
    env[PARENT_ENV] = str(os.getpid())
    if pinned:
        env[PIN_ENV] = "1"
    else:
        env.pop(PIN_ENV, None)
    return env


def _stderr_fd() -> int | None:
    """This process's stderr file descriptor, if it has one."""
    try:
        os.fstat(2)
    except OSError:
        return None
    return 2


# --------------------------------------------------------------------------- the fork server
class _ServerGone(Exception):
    pass


class _ForkServer:
    """One running ``python -m nlid.runtime.forkserver`` and the socket to it."""

    def __init__(self, pinned: bool, preload: str) -> None:
        self.owner = os.getpid()
        self.lock = threading.Lock()
        self.broken = False
        mine, theirs = socket.socketpair()
        env = _child_env(pinned)
        env[PRELOAD_ENV] = preload
        err = _stderr_fd()
        try:
            # a session of its own: the terminal's Ctrl-C (SIGINT to the foreground process group) stops nlid,
            # which then ends the server; the server never sees it (no KeyboardInterrupt traceback from it)
            self.proc = subprocess.Popen(
                [sys.executable, "-m", "nlid.runtime.forkserver", str(theirs.fileno())],
                pass_fds=(theirs.fileno(),),
                stdin=subprocess.DEVNULL,
                stdout=err if err is not None else subprocess.DEVNULL,
                env=env,
                start_new_session=True,
            )
        except OSError as exc:
            mine.close()
            raise IsolationError(f"cannot start nlid's fork server ({sys.executable}): {exc}") from None
        finally:
            theirs.close()
        self.sock = mine

    def usable(self) -> bool:
        return not self.broken and self.owner == os.getpid() and self.proc.poll() is None

    def close(self) -> None:
        if self.owner != os.getpid():  # inherited through a fork of this process: not ours to stop
            return
        with contextlib.suppress(OSError):
            self.sock.close()
        with contextlib.suppress(OSError):
            self.proc.kill()
        with contextlib.suppress(OSError, subprocess.TimeoutExpired):
            self.proc.wait(5)

    def fork(self) -> tuple[int, socket.socket, socket.socket]:
        """A new child: its pid, the status socket (exit code) and the data socket (request and reply)."""
        status, status_theirs = socket.socketpair()
        data, data_theirs = socket.socketpair()
        fds = [status_theirs.fileno(), data_theirs.fileno()]
        err = _stderr_fd()
        if err is not None:
            fds.append(err)
        try:
            with self.lock:
                socket.send_fds(self.sock, [b"F"], fds)
        except OSError:
            status.close()
            data.close()
            raise _ServerGone from None
        finally:
            status_theirs.close()
            data_theirs.close()
        status.settimeout(START_LIMIT)  # the server may still be loading the plugins
        try:
            head = status.recv(8, socket.MSG_WAITALL)
        except OSError:
            head = b""
        if len(head) != 8:
            status.close()
            data.close()
            raise _ServerGone
        status.settimeout(None)
        return int.from_bytes(head, "big", signed=True), status, data


_SERVERS: dict[bool, _ForkServer] = {}
_SERVERS_LOCK = threading.Lock()
_PRELOAD_FAILED: set[bool] = set()


def _server(pinned: bool) -> _ForkServer:
    with _SERVERS_LOCK:
        server = _SERVERS.get(pinned)
        if server is None or not server.usable():
            if server is not None:
                server.close()
            preload = "none" if pinned in _PRELOAD_FAILED else ("full" if pinned else "core")
            server = _SERVERS[pinned] = _ForkServer(pinned, preload)
        return server


def start_fork_server(pin_threads: bool = True) -> None:
    """Start nlid's fork server now, if the start method is ``forkserver`` and it is not running.

    It loads the plugins while this process goes on (``nlid study run``
    starts it before reading the study). ``pin_threads``: one thread per
    numerical library in each child (studies, which run one child per core).
    """
    if start_method() == "forkserver":
        _server(bool(pin_threads))


def _shutdown_servers() -> None:
    kill_children()
    with _SERVERS_LOCK:
        for server in _SERVERS.values():
            server.close()
        _SERVERS.clear()


atexit.register(_shutdown_servers)


# --------------------------------------------------------------------------- children
def kill_children() -> None:
    """Kill every child process this process started, with its process group (on interrupt)."""
    with _LIVE_LOCK:
        live = list(_LIVE.items())
    for pid, what in live:
        _kill(pid, what)


def _kill(pid: int, what: Any) -> None:
    """Kill a child and its process group."""
    if hasattr(os, "killpg"):
        try:
            os.killpg(pid, signal.SIGKILL)
        except ProcessLookupError:  # not yet a group leader (just forked), or already gone
            with contextlib.suppress(OSError):
                os.kill(pid, signal.SIGKILL)
        except OSError:
            pass
    if isinstance(what, subprocess.Popen):
        with contextlib.suppress(OSError):
            what.kill()


def track(proc: Any) -> None:
    """Count a child started another way (e.g. ``subprocess``) among those :func:`kill_children` kills."""
    with _LIVE_LOCK:
        _LIVE[proc.pid] = proc


def untrack(proc: Any) -> None:
    """Undo :func:`track`."""
    with _LIVE_LOCK:
        _LIVE.pop(proc.pid, None)


def _request(target: Callable[..., Any], args: tuple, pinned: bool) -> bytes:
    try:
        filters: Any = list(warnings.filters)
        pickle.dumps(filters)
    except Exception:  # noqa: BLE001 - a filter on a class of the user's __main__: the child keeps its own
        filters = None
    try:
        cwd = os.getcwd()
    except OSError:
        cwd = None
    request = {
        "target": target,
        "args": tuple(args),
        "path": list(sys.path),
        "env": dict(os.environ),
        "cwd": cwd,
        "filters": filters,
        "pin_threads": pinned,
    }
    try:
        return frame(pickle.dumps(request, protocol=pickle.HIGHEST_PROTOCOL))
    except Exception as exc:  # noqa: BLE001 - e.g. a lambda or an open file among the arguments
        raise IsolationError(f"cannot send the work to a child process: {type(exc).__name__}: {exc}") from None


def _run_forked(
    payload: bytes, timeout: float | None, pinned: bool, on_notice: Callable[[str], None] | None = None
) -> ChildResult:
    for _attempt in range(3):
        server = _server(pinned)
        try:
            pid, status, data = server.fork()
            break
        except _ServerGone:
            # the server died or hung while loading (a plugin that crashes or hangs at import?): the next one
            # loads nothing, and every child imports what it needs itself
            server.broken = True
            server.close()
            _PRELOAD_FAILED.add(pinned)
    else:
        raise IsolationError(
            f"nlid's fork server could not start a child process; set {START_METHOD_ENV}=spawn to start each "
            "child as a fresh interpreter"
        )
    with _LIVE_LOCK:
        _LIVE[pid] = "group"
    start = time.perf_counter()
    deadline = None if timeout is None else start + timeout
    reply: bytes | None = None
    exitcode: int | None = None
    ended = timed_out = False
    try:
        with contextlib.suppress(OSError):  # the child died before reading its work: its exit code says why
            data.sendall(payload)
        data_open = True
        while reply is None and not ended:
            remaining = None if deadline is None else max(0.0, deadline - time.perf_counter())
            ready, _, _ = select.select([status, data] if data_open else [status], [], [], remaining)
            if not ready:
                timed_out = True
                break
            if data in ready:
                reply, data_open = _read_reply(data, remaining, on_notice)
            if status in ready:
                exitcode, ended = _exit_code(status), True
                while reply is None and data_open and select.select([data], [], [], 0)[0]:
                    reply, data_open = _read_reply(data, END_LIMIT, on_notice)  # it replied and ended before we read
        if not ended:
            if timed_out:
                _kill(pid, "group")
            status.settimeout(END_LIMIT)  # a child that replied ends itself at once
            with contextlib.suppress(OSError):
                exitcode, ended = _exit_code(status), True
        # the server reports every child's exit code; a closed status socket without one means the server died
        lost = ended and exitcode is None and not timed_out
        if lost:
            server.broken = True
    finally:
        if not ended:
            _kill(pid, "group")  # interrupted (Ctrl-C) or the end was not reported: stop it and its group
        with _LIVE_LOCK:
            _LIVE.pop(pid, None)
        status.close()
        data.close()
    return result_from_reply(reply, exitcode, time.perf_counter() - start, timed_out, pid, lost)


def _recv_exact(sock: socket.socket, size: int) -> bytes | None:
    buf = bytearray(size)
    view, got = memoryview(buf), 0
    while got < size:
        n = sock.recv_into(view[got:], min(size - got, 1 << 20))
        if not n:
            return None
        got += n
    return bytes(buf)


def _read_reply(
    data: socket.socket, remaining: float | None, on_notice: Callable[[str], None] | None = None
) -> tuple[bytes | None, bool]:
    """The child's next message: ``(reply, open)``.

    A notice (:func:`nlid.runtime.child.notify`) is handed to ``on_notice`` and leaves the socket open for the
    reply: ``(None, True)``. Otherwise ``(reply, False)``, the reply ``None`` when the child ended without one
    or stopped sending it for longer than the limit.
    """
    data.settimeout(None if remaining is None else max(END_LIMIT, remaining))
    try:
        head = _recv_exact(data, HEADER.size)
        if head is None:
            return None, False
        size = HEADER.unpack(head)[0]
        if size & NOTICE:
            tag = _recv_exact(data, size & ~NOTICE)
            if tag is None:
                return None, False
            if on_notice is not None:
                on_notice(tag.decode(errors="replace"))
            return None, True
        return _recv_exact(data, size), False
    except OSError:  # socket.timeout included
        return None, False


def _exit_code(status: socket.socket) -> int | None:
    """The exit code the fork server reports (``None``: the server itself is gone)."""
    head = status.recv(8, socket.MSG_WAITALL)
    if len(head) != 8:
        return None
    return int.from_bytes(head, "big", signed=True)


def _run_spawned(payload: bytes, timeout: float | None, pinned: bool) -> ChildResult:
    env = _child_env(pinned)
    if pinned:
        pin_threads(env)
    # the child loads what the fork server would have loaded, then says READY: the time limit starts there
    env[PRELOAD_ENV] = "none" if pinned in _PRELOAD_FAILED else ("full" if pinned else "core")
    options: dict[str, Any] = {}
    if sys.platform == "win32":  # pragma: no cover - Windows
        options["creationflags"] = subprocess.CREATE_NEW_PROCESS_GROUP
    else:
        options["start_new_session"] = True
    try:
        proc = subprocess.Popen(
            [sys.executable, "-m", "nlid.runtime.child"],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            env=env,
            **options,
        )
    except OSError as exc:
        raise IsolationError(f"cannot start a child process ({sys.executable}): {exc}") from None
    track(proc)
    start = time.perf_counter()
    out: list[bytes] = []
    loaded = threading.Event()

    def write() -> None:
        with contextlib.suppress(OSError, ValueError):
            proc.stdin.write(payload)
            proc.stdin.close()

    def read() -> None:
        try:
            with contextlib.suppress(OSError, ValueError):
                first = proc.stdout.read(1)
                if first == READY:
                    start_work[0] = time.perf_counter()
                    loaded.set()
                    first = b""
                out.append(first + proc.stdout.read())
        finally:
            loaded.set()  # ended (or replied without calling: a failed setup)

    start_work = [start]

    threads = [threading.Thread(target=f, daemon=True, name=f"nlid-child-{f.__name__}") for f in (write, read)]
    for t in threads:
        t.start()
    timed_out = False
    try:
        try:
            if not loaded.wait(START_LIMIT):
                raise subprocess.TimeoutExpired(proc.args, START_LIMIT)
            proc.wait(None if timeout is None else max(0.0, start_work[0] + timeout - time.perf_counter()))
        except subprocess.TimeoutExpired:
            timed_out = True
            _kill(proc.pid, proc)
            proc.wait()
    finally:
        if proc.returncode is None:  # interrupted
            _kill(proc.pid, proc)
            with contextlib.suppress(subprocess.TimeoutExpired):
                proc.wait(END_LIMIT)
        untrack(proc)
    if hasattr(os, "killpg"):  # what the child left in its process group (a grandchild holding the reply pipe)
        with contextlib.suppress(OSError):
            os.killpg(proc.pid, signal.SIGKILL)
    for t in threads:
        t.join(END_LIMIT)
    with contextlib.suppress(OSError):
        proc.stdout.close()
    raw = out[0] if out else b""
    reply = None
    if len(raw) >= 8:
        size = int.from_bytes(raw[:8], "big")
        if len(raw) >= 8 + size:
            reply = raw[8 : 8 + size]
    return result_from_reply(reply, proc.returncode, time.perf_counter() - start_work[0], timed_out, proc.pid)


def run_in_child(
    target: Callable[..., Any],
    args: tuple = (),
    *,
    timeout: float | None = None,
    pin_threads: bool = False,
    method: str | None = None,
    on_notice: Callable[[str], None] | None = None,
) -> ChildResult:
    """Call ``target(*args)`` in a child process, killed at the time limit.

    ``target``, ``args`` and the return value cross the process boundary
    pickled (between nlid's own processes; no user file is unpickled). The
    child gets this process's ``sys.path``, environment, working folder and
    warning filters, so plugins visible here are visible there.

    Parameters
    ----------
    target
        A module-level function (of a module, not of the user's ``__main__``).
    args
        Its arguments.
    timeout
        Seconds (``None`` or ``math.inf``: no limit).
    pin_threads
        One thread per numerical library in the child (studies: one child per core).
    method
        ``"forkserver"`` or ``"spawn"``; default :func:`start_method`.
    on_notice
        Called in this thread with the tag of each :func:`nlid.runtime.child.notify` the target makes, as it
        makes it (a study's run: ``"identified"``, so the next run may start while this one scores). Only a
        forked child sends notices; a spawned one sends none (``on_notice`` is then never called).

    Returns
    -------
    ChildResult
        Never raises for what the target does: a raise, a crash, a hang or
        an unpicklable value is a status.

    Raises
    ------
    IsolationError
        The work could not be sent to a child, or no child could be started.
    """
    if timeout is not None and (timeout != timeout or timeout <= 0):
        raise InputError(f"timeout= must be a positive number of seconds, got {timeout!r}")
    if timeout is not None and math.isinf(timeout):
        timeout = None
    if method not in (None, "forkserver", "spawn"):
        raise InputError(f"method= must be 'forkserver' or 'spawn', got {method!r}")
    chosen = method or start_method()
    if chosen == "forkserver" and not _fork_server_possible():
        raise InputError("method='forkserver' needs POSIX; use 'spawn' on this platform")
    payload = _request(target, args, bool(pin_threads))
    if chosen == "forkserver":
        return _run_forked(payload, timeout, bool(pin_threads), on_notice)
    return _run_spawned(payload, timeout, bool(pin_threads))


# PluginUserWarning, ... (defined in nlid.runtime.outcome) stay importable from here.
globals().update({cls.__name__: cls for cls in _CATEGORIES.values()})
__all__ += [f"Plugin{name}" for name in _CATEGORIES]
