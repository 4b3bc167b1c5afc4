"""Imported once by nlid's fork server (:mod:`nlid.isolation`): die with the parent, and clean up.

The fork server asks for ``SIGTERM`` when the thread that started it ends
(``prctl(PR_SET_PDEATHSIG)``). If that thread ended but the parent process
lives on, the signal is ignored (the kernel sends it again when the process
itself dies); once the parent process is gone, the fork server removes its
socket and the temporary folder holding it (``pymp-*``, which the killed
parent could not remove) if nothing else is left there, and exits; the run
children it forked, which asked for ``SIGKILL`` when it dies, die with it.

Importing this module anywhere but in the fork server does nothing.
"""

from __future__ import annotations

import contextlib
import os
import signal

from .isolation import FORKSERVER_ENV, PARENT_ENV, die_with_parent


def _parent_gone(expected: int) -> bool:
    return os.getppid() != expected


def _on_parent_death(signum: int, frame: object) -> None:
    if not _parent_gone(_PARENT):
        return  # the starting thread ended; the parent process is alive
    try:
        from multiprocessing import forkserver

        address = forkserver._forkserver._forkserver_address
        if isinstance(address, str) and os.path.basename(os.path.dirname(address)).startswith("pymp-"):
            # the socket is ours; the folder may be shared (a spawned process inherits its parent's
            # temporary folder), so it goes only if nothing else is left in it
            with contextlib.suppress(OSError):
                os.unlink(address)
            with contextlib.suppress(OSError):
                os.rmdir(os.path.dirname(address))
    finally:
        os._exit(0)


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


_PARENT = int(os.environ.get(PARENT_ENV, "0") or 0)
if _PARENT and _PARENT != os.getpid() and FORKSERVER_ENV not in os.environ and _in_fork_server():
    os.environ[FORKSERVER_ENV] = str(os.getpid())
    signal.signal(signal.SIGTERM, _on_parent_death)
    die_with_parent(_PARENT, signal.SIGTERM)
