"""Process-level settings shared by nlid's fork server and its children: thread pools, parent death.

Neither needs anything of nlid: this module sits below :mod:`nlid.runtime.forkserver` and
:mod:`nlid.runtime.child`, which both use it.
"""

from __future__ import annotations

import os
import signal
import sys

__all__ = ["THREAD_ENV", "pin_threads", "die_with", "children_of", "descendants_of"]

#: Thread-pool sizes of the numerical libraries, read when they load (one thread per run process).
THREAD_ENV = (
    "OMP_NUM_THREADS",
    "OPENBLAS_NUM_THREADS",
    "MKL_NUM_THREADS",
    "VECLIB_MAXIMUM_THREADS",
    "NUMEXPR_NUM_THREADS",
    "NUMBA_NUM_THREADS",
)
_PR_SET_PDEATHSIG = 1
_PR_SET_CHILD_SUBREAPER = 36


def pin_threads(env: dict[str, str] | os._Environ[str]) -> None:
    """One thread per numerical library, unless the user chose otherwise."""
    for name in THREAD_ENV:
        env.setdefault(name, "1")


def _prctl(option: int, value: int) -> bool:
    if not sys.platform.startswith("linux"):
        return False
    try:
        import ctypes

        return ctypes.CDLL(None, use_errno=True).prctl(option, value, 0, 0, 0) == 0
    except (OSError, AttributeError):  # pragma: no cover - no libc prctl
        return False


def die_with(parent: int, sig: int = signal.SIGKILL) -> bool:
    """Ask the kernel for ``sig`` when this process's parent dies (Linux; elsewhere a no-op).

    Exits at once if the parent (pid ``parent``) is already gone. Returns
    whether the request took effect.
    """
    ok = _prctl(_PR_SET_PDEATHSIG, int(sig))
    if os.getppid() != parent:
        os._exit(1)
    return ok


def children_of(pid: int) -> list[int]:
    """Direct children of ``pid`` (Linux ``/proc``; elsewhere none)."""
    found: list[int] = []
    try:
        for task in os.listdir(f"/proc/{pid}/task"):
            with open(f"/proc/{pid}/task/{task}/children") as fh:
                found += [int(p) for p in fh.read().split()]
    except OSError:
        return found
    return found


def descendants_of(pid: int) -> list[int]:
    """Every living descendant of ``pid``, whatever session or process group it moved to (Linux; elsewhere none)."""
    out: list[int] = []
    todo = children_of(pid)
    while todo:
        child = todo.pop()
        out.append(child)
        todo += children_of(child)
    return out
