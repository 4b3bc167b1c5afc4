"""One pool for nlid's parallel work: its size, and the rule that keeps BLAS out of the kernels' cores.

nlid runs parallel work in three places: the compiled kernels that run segments in parallel
(:func:`nlid.simulation.simulate_segments`, numba threads: ``oe`` and the scores), the numerical
libraries' own thread pools (BLAS, OpenMP), and the study and bench executors (``--jobs`` processes,
each pinned to one thread by :func:`nlid.runtime.process.pin_threads`). On a shared machine the first two
fight: an OpenBLAS pool of two on a loaded 2-core machine made a 3000 x 9 QR 150 times slower than one
thread (measured: 1.8 s against 12 ms at a load of 8): its threads spin between calls.

:func:`workers` is the one pool size. :func:`kernel_threads` runs a block with the compiled kernels on
that many threads and BLAS and OpenMP on one (the matrices between two kernel calls are small), so the
threads of one process never exceed the pool; inside a pinned run process the kernels get one thread.

By default the pool is every usable core, whatever the load: measured on the shared 2-core machine at a
load of 13-16, ``oe`` on a paper-numerical record took 37-42 s on two kernel threads and 50-58 s on one
(BLAS on one thread in both): the scheduler shares the cores between runnable threads, so a process with
fewer threads gets less of them. What made ``oe`` slow under load was the BLAS pool, not the kernels'
threads. ``workers(load=...)`` gives the load-aware size (the cores less the other processes' load) to a
caller that wants to leave room to others; ``NLID_WORKERS`` fixes the size.

Examples
--------
>>> from nlid.runtime.parallel import kernel_threads, workers
>>> n = workers()                         # every core, or NLID_WORKERS
>>> with kernel_threads() as n:           # doctest: +SKIP
...     run = simulate_segments(...)      # numba on n threads, BLAS on one
"""

from __future__ import annotations

import contextlib
import os
import threading
from collections.abc import Callable, Iterator
from typing import Any

from ..errors import InputError

__all__ = ["cores", "workers", "pinned", "threads", "kernel_threads", "WORKERS_ENV", "both", "thread_budget"]

#: Environment variable that fixes the pool size (a positive integer), e.g. for benchmarks.
WORKERS_ENV = "NLID_WORKERS"


def cores() -> int:
    """The cores this process may run on (its CPU affinity; elsewhere the machine's count)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def workers(load: float | None = None, *, own: float = 1.0) -> int:
    """The pool size: ``NLID_WORKERS`` when set, else every usable core, or fewer when ``load`` is given.

    Parameters
    ----------
    load
        The machine's load (runnable processes, e.g. ``os.getloadavg()[0]``) to leave room for; default:
        none (every core, the measured fastest: see the module docstring).
    own
        The part of ``load`` that is this process's own (its main thread, running now).

    Returns
    -------
    int
        ``NLID_WORKERS`` when set; else :func:`cores`, or with ``load`` ``round(cores - max(load - own, 0))``
        clipped to ``[1, cores]`` (1 when two other processes keep a 2-core machine busy).

    Raises
    ------
    InputError
        If ``NLID_WORKERS`` is set and is not a positive integer (a ``ValueError``).
    """
    n = cores()
    fixed = os.environ.get(WORKERS_ENV, "").strip()
    if fixed:
        try:
            value = int(fixed)
        except ValueError:
            value = 0
        if value < 1:
            raise InputError(f"{WORKERS_ENV} must be a positive integer, got {fixed!r}")
        return value
    if load is None:
        return n
    others = max(float(load) - float(own), 0.0)
    return int(min(n, max(1, round(n - others))))


def pinned() -> int | None:
    """The threads a run process's numerical libraries are pinned to (``NUMBA_NUM_THREADS``, as
    :func:`nlid.runtime.process.pin_threads` sets it), or ``None`` when they are not pinned."""
    value = os.environ.get("NUMBA_NUM_THREADS", "").strip()
    return int(value) if value.isdigit() and int(value) > 0 else None


def threads(at_most: int | None = None, *, load: float | None = None) -> int:
    """The threads this process's parallel work may use: the one reading of nlid's thread budget.

    Parameters
    ----------
    at_most
        No more than this many (the pieces of work there are), at least one.
    load
        The machine's load to leave room for (:func:`workers`); default: none.

    Returns
    -------
    int
        In a pinned run process (a study's run: one run per core, :func:`pinned`) its pinned count;
        otherwise :func:`workers` (``NLID_WORKERS`` when set, else the cores, less the others' load when
        ``load`` is given); clipped to ``[1, at_most]``.

    Raises
    ------
    InputError
        If ``NLID_WORKERS`` is set and is not a positive integer.
    """
    n = pinned() or workers(load)
    return max(1, n if at_most is None else min(n, int(at_most)))


@contextlib.contextmanager
def kernel_threads(n: int | None = None) -> Iterator[int]:
    """Run a block with the compiled kernels on ``n`` threads and BLAS/OpenMP on one.

    Parameters
    ----------
    n
        Kernel threads (default: :func:`workers`), at most numba's thread count (1 in a run process that
        :func:`nlid.runtime.process.pin_threads` pinned).

    Yields
    ------
    int
        The kernel threads in effect.
    """
    import numba
    from threadpoolctl import threadpool_limits

    wanted = workers() if n is None else int(n)
    threads = max(1, min(wanted, int(numba.config.NUMBA_NUM_THREADS)))
    before = numba.get_num_threads()
    numba.set_num_threads(threads)
    try:
        with threadpool_limits(limits=1):
            yield threads
    finally:
        numba.set_num_threads(before)


#: The threads :func:`both` may use; ``None``: numba's thread count (1 in a pinned run process), else every core.
_BUDGET: list[int | None] = [None]


@contextlib.contextmanager
def thread_budget(n: int) -> Iterator[int]:
    """Run a block with ``n`` threads for :func:`both` (a study's run process given more than its own core).

    A study executor that runs fewer runs at once than there are cores gives each run ``cores // jobs``
    (:class:`nlid.study.execute.LocalExecutor`); a pinned run process otherwise has one.
    """
    before = _BUDGET[0]
    _BUDGET[0] = max(1, int(n))
    try:
        yield _BUDGET[0]
    finally:
        _BUDGET[0] = before


def _budget() -> int:
    return _BUDGET[0] if _BUDGET[0] is not None else threads()


def both(first: Callable[[], Any], second: Callable[[], Any]) -> tuple[Any, Any]:
    """``(first(), second())``: at once on two threads when the thread budget has two (:func:`thread_budget`).

    For two independent calls into compiled code that releases the GIL (the two free runs of a score's
    chaos check, :func:`nlid.scoring.free_run_error`): the same results as one after the other. An
    exception of ``first`` is raised before one of ``second``, as in sequence; the thread is always joined
    (a run leaves no thread behind).
    """
    if _budget() < 2:
        return first(), second()
    out: list[Any] = [None, None]

    def call() -> None:
        try:
            out[1] = (True, second())
        except BaseException as exc:  # noqa: BLE001 - re-raised in the calling thread
            out[1] = (False, exc)

    thread = threading.Thread(target=call, name="nlid-both", daemon=True)
    thread.start()
    try:
        value = first()
    finally:
        thread.join()
    ok, result = out[1]
    if not ok:
        raise result
    return value, result
