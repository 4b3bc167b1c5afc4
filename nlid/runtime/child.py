"""The child's side of an isolated call (:func:`nlid.runtime.isolation.run_in_child`).

A child is forked from nlid's fork server (:mod:`nlid.runtime.forkserver`) or
started as ``python -m nlid.runtime.child`` (the spawn start method). Either
way :func:`serve`:

* sends what the plugin prints to stderr (file descriptor 1 becomes a copy
  of 2, so nothing a plugin prints reaches ``--json`` output) and gives it an
  empty stdin;
* reads the request (the function, its arguments, the parent's ``sys.path``,
  environment, working folder and warning filters) and takes the parent's
  settings;
* calls the function, recording the warnings it issues and catching whatever
  it raises (``SystemExit`` and ``KeyboardInterrupt`` included);
* sends the reply: the value or the error, the warnings (each once, with a
  count) and the threads left running;
* and ends its whole process group at once with ``SIGKILL``: threads and
  grandchildren a plugin left behind (a ``sleep`` it started, a resource
  tracker) end with it, silently.

Messages are pickled, between nlid's own processes only, and framed with an
8-byte length.
"""

from __future__ import annotations

import contextlib
import os
import pickle
import signal
import struct
import sys
from typing import Any

from .process import descendants_of

__all__ = ["serve", "read_message", "write_message", "notify", "HEADER", "NOTICE"]

#: The frame header: the length of the pickled message.
HEADER = struct.Struct("!Q")
#: Distinct warnings sent back (the rest are counted in the last one's line).
MAX_WARNINGS = 20
#: Longest warning message sent back (characters).
MAX_MESSAGE = 400
#: The byte a spawned child writes once it has loaded and read its request (the parent's time limit starts
#: then, as a forked child's starts when the fork server, already loaded, forks it). A reply's frame header
#: starts with a zero byte, so the two never mix.
READY = b"\x01"
#: The bit of a frame header that marks a notice (:func:`notify`), not the reply: a reply is never 2**63 bytes.
NOTICE = 1 << 63

#: Where :func:`notify` writes (the data socket of a forked child while its call runs), or ``None``.
_notice_fd: int | None = None


def read_exact(fd: int, size: int) -> bytes | None:
    """``size`` bytes from ``fd``, or ``None`` at end of file."""
    parts, got = [], 0
    while got < size:
        chunk = os.read(fd, min(size - got, 1 << 20))
        if not chunk:
            return None
        parts.append(chunk)
        got += len(chunk)
    return b"".join(parts)


def read_message(fd: int) -> bytes | None:
    """One framed message, or ``None`` at end of file."""
    head = read_exact(fd, HEADER.size)
    if head is None:
        return None
    return read_exact(fd, HEADER.unpack(head)[0])


def write_message(fd: int, data: bytes) -> None:
    """Write one framed message."""
    view = memoryview(HEADER.pack(len(data)) + data)
    while view:
        view = view[os.write(fd, view) :]


def notify(tag: str) -> None:
    """Tell the parent, before the reply, that the call reached ``tag`` (``"identified"``, say).

    In a child forked from nlid's fork server the notice goes, framed with the :data:`NOTICE` bit, on the data
    socket ahead of the reply (:func:`nlid.runtime.isolation.run_in_child`'s ``on_notice``); anywhere else (in
    the parent, in a spawned child) it does nothing. It never raises: a parent that gave up finds out from
    the reply.
    """
    fd = _notice_fd
    if fd is None:
        return
    data = tag.encode()
    with contextlib.suppress(OSError):
        view = memoryview(HEADER.pack(NOTICE | len(data)) + data)
        while view:
            view = view[os.write(fd, view) :]


def frame(data: bytes) -> bytes:
    """``data`` with its header."""
    return HEADER.pack(len(data)) + data


def _redirect(stderr_fd: int | None) -> None:
    """stdout and stderr to ``stderr_fd`` (the parent's stderr), stdin from the null device."""
    if stderr_fd is not None:
        os.dup2(stderr_fd, 2)
        os.close(stderr_fd)
    os.dup2(2, 1)
    null = os.open(os.devnull, os.O_RDONLY)
    os.dup2(null, 0)
    os.close(null)


def _apply(request: dict[str, Any]) -> None:
    """Take the parent's import path, environment and working folder."""
    import tempfile

    sys.path[:] = request["path"]
    env = request.get("env")
    if env is not None:
        os.environ.clear()
        os.environ.update(env)
    if request.get("pin_threads"):
        from .process import pin_threads

        pin_threads(os.environ)
    tempfile.tempdir = None  # honour the parent's TMPDIR
    cwd = request.get("cwd")
    if cwd:
        with contextlib.suppress(OSError):
            os.chdir(cwd)


def _summarise(caught: list[Any]) -> list[dict[str, Any]]:
    """Each distinct warning once, with its count (at most :data:`MAX_WARNINGS`)."""
    import builtins

    seen: dict[tuple, dict[str, Any]] = {}
    for w in caught:
        message = str(w.message)
        if len(message) > MAX_MESSAGE:
            message = message[: MAX_MESSAGE - 1] + "…"
        key = (w.category, message, w.filename, w.lineno)
        if key in seen:
            seen[key]["count"] += 1
            continue
        if len(seen) == MAX_WARNINGS:
            continue
        base = next((c.__name__ for c in w.category.__mro__ if getattr(builtins, c.__name__, None) is c), "UserWarning")
        seen[key] = {
            "category": w.category.__name__,
            "base": base if base != "Warning" else "UserWarning",
            "message": message,
            "filename": str(w.filename),
            "lineno": int(w.lineno or 0),
            "count": 1,
        }
    return list(seen.values())


def _call(request: dict[str, Any]) -> dict[str, Any]:
    import threading
    import traceback
    import warnings

    from ..errors import describe_exception

    reply: dict[str, Any]
    with warnings.catch_warnings(record=True) as caught:
        filters = request.get("filters")
        if filters is not None:
            warnings.filters[:] = filters
        try:
            value = request["target"](*request["args"])
        except BaseException as exc:  # noqa: BLE001 - every way out is reported to the parent
            reply = {
                "status": "raised",
                "kind": type(exc).__name__,
                "error": describe_exception(exc),
                "traceback": traceback.format_exc(),
            }
        else:
            reply = {"status": "ok", "value": value}
    reply["warnings"] = _summarise(caught)
    main = threading.main_thread()
    reply["threads"] = [t.name for t in threading.enumerate() if t is not main and t.is_alive()]
    return reply


def _send(out_fd: int, reply: dict[str, Any]) -> None:
    try:
        data = pickle.dumps(reply, protocol=pickle.HIGHEST_PROTOCOL)
    except BaseException as exc:  # noqa: BLE001 - an unpicklable value is the plugin's fault
        reduced = {k: v for k, v in reply.items() if k not in ("value",)}
        reduced.update(status="unsent", error=f"{type(exc).__name__}: {exc}")
        data = pickle.dumps(reduced, protocol=pickle.HIGHEST_PROTOCOL)
    with contextlib.suppress(OSError):  # the parent gave up on this run
        write_message(out_fd, data)


def _end() -> None:
    """End this process and everything it started (its process group), at once."""
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(OSError, ValueError, AttributeError):
            stream.flush()
    for pid in descendants_of(os.getpid()):  # also those a plugin started in a session of their own
        with contextlib.suppress(OSError):
            os.kill(pid, signal.SIGKILL)
    if hasattr(os, "killpg") and os.getpgid(0) == os.getpid():
        os.killpg(0, signal.SIGKILL)
    os._exit(0)


def serve(channel: Any = None, *, stderr_fd: int | None = None, ready: bool = False) -> None:
    """Run one request and end the process (never returns).

    Parameters
    ----------
    channel
        The data socket (forked child), or ``None``: the request on stdin and
        the reply on stdout (spawned child).
    stderr_fd
        The parent's stderr (forked child), where the child's stdout and
        stderr go.
    ready
        Write :data:`READY` once the request is read and applied, before
        the call (a spawned child: the parent starts its time limit then).
    """
    global _notice_fd
    try:
        if channel is None:
            if sys.platform == "win32":  # pragma: no cover - Windows
                import msvcrt

                msvcrt.setmode(0, os.O_BINARY)
                msvcrt.setmode(1, os.O_BINARY)
            in_fd, out_fd = os.dup(0), os.dup(1)
        else:
            in_fd = out_fd = channel.fileno()
        _redirect(stderr_fd)
        try:
            raw = read_message(in_fd)
            if raw is None:
                _end()  # the parent gave up before sending the work
            request = pickle.loads(raw)
            _apply(request)
        except BaseException as exc:  # noqa: BLE001 - reported to the parent, which raises
            _send(out_fd, {"status": "setup", "error": f"{type(exc).__name__}: {exc}", "warnings": [], "threads": []})
            _end()
        if ready:
            try:
                os.write(out_fd, READY)
            except OSError:
                _end()  # the parent gave up
        _notice_fd = None if channel is None else out_fd  # a spawned child's stdout carries the reply alone
        _send(out_fd, _call(request))
    finally:
        _end()


def main() -> None:
    """``python -m nlid.runtime.child``: a spawned child (die with the parent where the platform allows)."""
    from .process import die_with

    parent = os.environ.get("NLID_ISOLATION_PARENT")
    if parent and parent.isdigit():
        die_with(int(parent))
    # load what a fork server would have loaded before forking, so the time limit (from READY) covers the same
    from .preload import PRELOAD_ENV, warm_up_quietly

    warm_up_quietly(os.environ.get(PRELOAD_ENV, "none"))
    serve(ready=True)


if __name__ == "__main__":
    main()
