"""nlid's fork server: ``python -m nlid.runtime.forkserver FD``, started by :mod:`nlid.runtime.isolation`.

A small program of nlid's own (no ``multiprocessing`` internals, no socket
file): it imports nlid and the plugins once, then forks one child per run
request, so a run starts warm in a few milliseconds. Its main module is this
one, never the user's script, so a script without an ``if __name__ ==
"__main__"`` guard (or one read from stdin) is never imported again.

The protocol, over the anonymous ``AF_UNIX`` socket pair whose end is ``FD``
(no path, so no ``AF_UNIX path too long`` whatever ``TMPDIR`` or the working
folder is):

* the parent sends one byte with two descriptors attached (``SCM_RIGHTS``): a
  *status* socket and a *data* socket of that run;
* the server forks; the child runs :func:`nlid.runtime.child.serve` on the
  data socket (the request and the reply travel there, straight between the
  parent and the child) in a session and process group of its own;
* the server writes the child's pid to the status socket at once, and its
  exit code (negative: killed by that signal) when it has reaped it; then it
  kills the rest of the child's process group (grandchildren a plugin left).

It ends, killing every run's process group, when the parent closes its end of
the socket or dies (the socket closes; on Linux the parent-death signal says
so as well). It runs in a session of its own and ignores ``SIGINT``: the
terminal's Ctrl-C reaches nlid alone, which ends the server (no traceback
from it). On Linux it is also a *child subreaper*: a grandchild that left
its run's process group is re-parented to the server, which kills it when
the run ends.

Set-up, before numpy is imported: with ``NLID_PIN_THREADS=1`` (studies: one
run per core) it pins the thread pools of the numerical libraries (BLAS,
OpenMP, numba) to one thread, keeping variables the user set. The preload
(:mod:`nlid.runtime.preload`) runs with stdout and stderr silenced (a plugin
that prints at import is heard once, from the parent) and under an alarm: a
plugin that hangs at import delays the server by at most
:data:`PRELOAD_LIMIT` seconds.
"""

from __future__ import annotations

import contextlib
import os
import select
import signal
import socket
import struct
import sys

from .preload import PRELOAD_ENV, warm_up_quietly
from .process import _PR_SET_CHILD_SUBREAPER, _prctl, children_of, die_with, pin_threads

__all__ = [
    "PIN_ENV",
    "main",
]

#: ``"1"``: pin the numerical libraries to one thread per run (studies).
PIN_ENV = "NLID_PIN_THREADS"


class _Server:
    def __init__(self, sock: socket.socket, parent: int) -> None:
        self.sock = sock
        self.parent = parent
        self.runs: dict[int, socket.socket] = {}  # run child pid -> its status socket
        self.wake_r, self.wake_w = os.pipe()
        os.set_blocking(self.wake_r, False)
        os.set_blocking(self.wake_w, False)

    # ------------------------------------------------------------------ life
    def shutdown(self) -> None:
        """Kill every run's process group and leave."""
        for pid in list(self.runs):
            with contextlib.suppress(OSError):
                os.killpg(pid, signal.SIGKILL)
        os._exit(0)

    def on_parent_death(self, signum: int, frame: object) -> None:
        if os.getppid() != self.parent:  # the parent process is gone (not just the thread that started us)
            self.shutdown()

    # ------------------------------------------------------------------ loop
    def serve(self) -> None:
        signal.set_wakeup_fd(self.wake_w)
        signal.signal(signal.SIGCHLD, lambda *a: None)
        while True:
            try:
                ready, _, _ = select.select([self.sock, self.wake_r], [], [])
            except InterruptedError:  # pragma: no cover - PEP 475 retries
                continue
            if self.wake_r in ready:
                with contextlib.suppress(OSError):
                    while os.read(self.wake_r, 512):
                        pass
                self.reap()
            if self.sock in ready:
                self.accept()

    def accept(self) -> None:
        try:
            message, fds, _, _ = socket.recv_fds(self.sock, 1, 3)
        except OSError:
            message, fds = b"", []
        if not message:  # the parent closed its end or died
            self.shutdown()
        if len(fds) < 2:
            for fd in fds:
                os.close(fd)
            return
        status = socket.socket(fileno=fds[0])
        data_fd, stderr_fd = fds[1], (fds[2] if len(fds) > 2 else None)
        pid = os.fork()
        if pid == 0:
            self.become_child(status, data_fd, stderr_fd)
        for fd in (data_fd, stderr_fd):
            if fd is not None:
                os.close(fd)
        with contextlib.suppress(OSError):  # the parent gave up on the run: the child finds out on its data socket
            status.sendall(struct.pack("!q", pid))
        self.runs[pid] = status

    def become_child(self, status: socket.socket, data_fd: int, stderr_fd: int | None) -> None:
        server = os.getppid()
        try:
            os.setsid()  # its own session and process group: killed as a group, deaf to the terminal's Ctrl-C
            signal.set_wakeup_fd(-1)
            for sig in (signal.SIGCHLD, signal.SIGTERM):
                signal.signal(sig, signal.SIG_DFL)
            signal.signal(signal.SIGINT, signal.default_int_handler)
            for sock in (self.sock, status, *self.runs.values()):
                sock.close()
            os.close(self.wake_r)
            os.close(self.wake_w)
            die_with(server)
            from .child import serve

            serve(socket.socket(fileno=data_fd), stderr_fd=stderr_fd)
        finally:
            os._exit(70)  # serve() never returns; this only runs if the set-up itself failed

    def reap(self) -> None:
        ended = False
        while True:
            try:
                pid, status = os.waitpid(-1, os.WNOHANG)
            except ChildProcessError:
                break
            if pid == 0:
                break
            code = os.waitstatus_to_exitcode(status)
            sock = self.runs.pop(pid, None)
            if sock is None:
                continue  # an orphan re-parented to us (subreaper), now reaped
            ended = True
            with contextlib.suppress(OSError):
                os.killpg(pid, signal.SIGKILL)  # what the run left in its process group
            with contextlib.suppress(OSError):
                sock.sendall(struct.pack("!q", code))
            sock.close()
        if ended:
            self.kill_strays()

    def kill_strays(self) -> None:
        """Kill children of the server that are not runs: grandchildren that escaped their run's group (Linux)."""
        for pid in children_of(os.getpid()):
            if pid not in self.runs:
                with contextlib.suppress(OSError):
                    os.kill(pid, signal.SIGKILL)


def main(fd: int) -> None:
    """Serve run requests on the socket ``fd`` (see the module docstring)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is nlid's to handle: it ends the server by closing the socket
    parent = os.getppid()
    if os.environ.get(PIN_ENV) == "1":
        pin_threads(os.environ)
    sock = socket.socket(fileno=fd)
    server = _Server(sock, parent)
    signal.signal(signal.SIGTERM, server.on_parent_death)
    _prctl(_PR_SET_CHILD_SUBREAPER, 1)
    die_with(parent, signal.SIGTERM)
    import warnings

    # the server forks by design: its only other threads are idle pools of the numerical libraries
    warnings.filterwarnings("ignore", message=r".*use of fork\(\) may lead to deadlocks", category=DeprecationWarning)
    warm_up_quietly(os.environ.get(PRELOAD_ENV, "full"), idle=lambda: not select.select([sock], [], [], 0)[0])
    server.serve()


if __name__ == "__main__":
    main(int(sys.argv[1]))
