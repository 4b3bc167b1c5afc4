"""Imported once by nlid's fork server (:mod:`nlid.runtime.isolation`): die with the parent, and clean up.

The fork server asks for ``SIGTERM`` when the thread that started it ends
(``prctl(PR_SET_PDEATHSIG)``). If that thread ended but the parent process
lives on, the signal is ignored (the kernel sends it again when the process
itself dies); once the parent process is gone, the fork server removes its
socket and the temporary folder holding it (``pymp-*``, which the killed
parent could not remove) if nothing else is left there, and exits; the run
children it forked, which asked for ``SIGKILL`` when it dies, die with it.

The kernel closes the dead parent's end of the fork server's "alive" pipe
before it sends the signal, so the fork server may see the pipe close first
and leave through ``SystemExit``; an exit handler then does the same clean-up
(a fork server with few preloaded modules exits before the signal arrives).

It also pins the thread pools of the numerical libraries (BLAS, OpenMP,
numba) to one thread, before anything imports numpy: every run forked from
the server inherits them, so N runs on N cores do not fight over the cores.
Variables the user set are kept.

Importing this module anywhere but in the fork server does nothing.
"""

from __future__ import annotations

import atexit
import contextlib
import os
import signal
import time

from .isolation import FORKSERVER_ENV, PARENT_ENV, die_with_parent


def _parent_gone(expected: int) -> bool:
    return os.getppid() != expected


def _remove_socket() -> None:
    from multiprocessing import forkserver

    address = forkserver._forkserver._forkserver_address
    if isinstance(address, str) and os.path.basename(os.path.dirname(address)).startswith("pymp-"):
        # the socket is ours; the folder may be shared (a spawned process inherits its parent's
        # temporary folder), so it goes only if nothing else is left in it
        with contextlib.suppress(OSError):
            os.unlink(address)
        with contextlib.suppress(OSError):
            os.rmdir(os.path.dirname(address))


def _on_parent_death(signum: int, frame: object) -> None:
    if not _parent_gone(_PARENT):
        return  # the starting thread ended; the parent process is alive
    try:
        _remove_socket()
    finally:
        os._exit(0)


def _at_exit() -> None:
    """The "alive" pipe closed: the parent is exiting; once it is gone (re-parented), clean up as above."""
    deadline = time.monotonic() + 1.0
    while not _parent_gone(_PARENT) and time.monotonic() < deadline:
        time.sleep(0.01)
    if _parent_gone(_PARENT):
        _remove_socket()


def _in_fork_server() -> bool:
    """True while ``multiprocessing.forkserver.main`` imports its preload modules (and nowhere else)."""
    import sys

    frame = sys._getframe(1)
    while frame is not None:
        code = frame.f_code
        if code.co_name == "main" and code.co_filename.replace("\\", "/").endswith("multiprocessing/forkserver.py"):
            return True
        frame = frame.f_back
    return False


#: Thread-pool sizes of the numerical libraries, read when they load (one thread per run process).
THREAD_ENV = (
    "OMP_NUM_THREADS",
    "OPENBLAS_NUM_THREADS",
    "MKL_NUM_THREADS",
    "VECLIB_MAXIMUM_THREADS",
    "NUMEXPR_NUM_THREADS",
    "NUMBA_NUM_THREADS",
)

_PARENT = int(os.environ.get(PARENT_ENV, "0") or 0)
if _PARENT and _PARENT != os.getpid() and FORKSERVER_ENV not in os.environ and _in_fork_server():
    os.environ[FORKSERVER_ENV] = str(os.getpid())
    for _name in THREAD_ENV:
        os.environ.setdefault(_name, "1")
    signal.signal(signal.SIGTERM, _on_parent_death)
    atexit.register(_at_exit)
    die_with_parent(_PARENT, signal.SIGTERM)
