"""Executors: where a study's runs execute.

Both executors call :func:`nlid.study.worker.run_isolated` for each run, so a
run always executes in its own child process with its time limit (forked from
nlid's warm fork server, or a fresh interpreter with the spawn start method),
and both hand each finished run back to the caller (``on_done(run, payload)``)
in the calling thread as soon as it finishes, where it is persisted at once.

:class:`LocalExecutor`
    ``jobs`` identifications at a time on this machine (default: every core), each
    run in a child process; with fewer jobs than cores, a run's scores overlap the
    next run's identification on an idle core.
:class:`DaskExecutor`
    The same function submitted to a Dask distributed cluster
    (``pip install "nlid[dask]"``): an existing scheduler by address, or a
    ``LocalCluster`` of ``jobs`` single-threaded worker processes started for
    the study. Each worker starts its own fork server for its runs (a plain
    subprocess, so the daemonic workers of an outside cluster may too).

Results do not depend on the executor: every run's data and seed come from
its spec alone (:mod:`nlid.study.plan`).
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor
from concurrent.futures import wait as wait_futures
from typing import Any

from ..errors import InputError
from ..runtime.isolation import start_fork_server
from .job import Scheduled
from .run import IDENTIFIED
from .worker import kill_children, run_isolated

__all__ = ["LocalExecutor", "DaskExecutor", "make_executor", "default_jobs"]

OnDone = Callable[[Scheduled, dict[str, Any]], None]


def default_jobs() -> int:
    """Every core this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


class LocalExecutor:
    """Run processes on this machine: ``jobs`` identifications at a time.

    With fewer identifications at a time than cores, a run that has identified (its child's notice,
    :data:`nlid.study.run.IDENTIFIED`) frees its slot: the next run starts identifying while it computes its
    scores on an idle core, in the same child as before. ``--jobs 1`` on two cores thus means one
    identification at a time, not one core. Each run is still computed whole in its own child, so the rows,
    the stored files and the failures are those of runs executed one after the other; a run's ``seconds``
    is still its identification alone.

    Parameters
    ----------
    jobs
        Identifications at the same time (default: :func:`default_jobs`).
    overlap
        Let a run's scores overlap the next identification on the idle cores (default); ``False``: one
        child per slot from start to end.
    """

    name = "local"

    def __init__(self, jobs: int | None = None, *, overlap: bool = True) -> None:
        self.jobs = jobs
        self.overlap = overlap

    def run(self, runs: Sequence[Scheduled], on_done: OnDone) -> None:
        """Execute ``runs``, calling ``on_done`` in this thread as each finishes."""
        if not runs:
            return
        jobs = self.jobs or default_jobs()
        start_fork_server(pin_threads=True)  # it loads the plugins while the pool starts
        active = min(jobs, len(runs))
        # children still scoring beside the identifying ones: as many as there are idle cores (at most one each)
        scoring = min(active, default_jobs() - active, len(runs) - active) if self.overlap else 0
        workers = active + max(0, scoring)
        pool = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="nlid-run")
        slots = threading.Semaphore(active)  # identifications under way
        stopping = threading.Event()
        try:
            # fewer children than cores: each run's scores may use the idle cores (the same numbers)
            threads = max(1, default_jobs() // workers)
            pending = {pool.submit(_run_in_slot, run.spec, slots, stopping, threads): run for run in runs}
            while pending:
                done, _ = wait_futures(pending, timeout=0.5, return_when=FIRST_COMPLETED)
                for fut in done:
                    on_done(pending.pop(fut), fut.result())
        except BaseException:
            stopping.set()  # a worker waiting for a slot starts nothing more
            pool.shutdown(wait=False, cancel_futures=True)
            kill_children()
            raise
        pool.shutdown(wait=True)


def _run_in_slot(spec: Any, slots: threading.Semaphore, stopping: threading.Event, threads: int) -> dict[str, Any]:
    """:func:`run_isolated` once a slot is free; the slot is freed when the run has identified, or ends."""
    slots.acquire()
    lock = threading.Lock()
    held = [True]

    def release(tag: str = IDENTIFIED) -> None:
        with lock:
            if held[0] and tag == IDENTIFIED:
                held[0] = False
                slots.release()

    try:
        if stopping.is_set():
            return spec.failure("failed", "interrupted")  # never stored: the study is stopping
        return run_isolated(spec, threads=threads, on_notice=release)
    finally:
        release()


class DaskExecutor:
    """Run on a Dask distributed cluster.

    Parameters
    ----------
    scheduler
        Scheduler address (``tcp://host:8786``); ``None`` starts a
        ``LocalCluster`` for the study.
    jobs
        Workers of the ``LocalCluster`` (default: :func:`default_jobs`).
    """

    name = "dask"

    def __init__(self, scheduler: str | None = None, jobs: int | None = None) -> None:
        self.scheduler = scheduler
        self.jobs = jobs

    def run(self, runs: Sequence[Scheduled], on_done: OnDone) -> None:
        """Execute ``runs``, calling ``on_done`` in this thread as each finishes."""
        if not runs:
            return
        try:
            import dask
            from distributed import Client, LocalCluster, as_completed
        except ImportError:
            raise InputError('the dask executor needs Dask: pip install "nlid[dask]"') from None
        cluster = None
        if self.scheduler:
            try:
                client = Client(self.scheduler, timeout="20s")
            except (OSError, TimeoutError, ValueError) as exc:
                raise InputError(f"cannot connect to the Dask scheduler at {self.scheduler}: {exc}") from None
        else:
            with dask.config.set({"distributed.worker.daemon": False}):
                cluster = LocalCluster(
                    n_workers=self.jobs or default_jobs(),
                    threads_per_worker=1,
                    processes=True,
                    dashboard_address=":0",
                )
            client = Client(cluster)
        try:
            futures = {
                client.submit(run_isolated, run.spec, pure=False, key=f"nlid-{run.digest}-{i}"): run
                for i, run in enumerate(runs)
            }
            for fut in as_completed(futures):
                on_done(futures[fut], fut.result())
        finally:
            client.close()
            if cluster is not None:
                cluster.close()


def make_executor(name: str, *, jobs: int | None = None, scheduler: str | None = None) -> Any:
    """An executor by name (``"local"`` or ``"dask"``)."""
    if jobs is not None and jobs < 1:
        raise InputError(f"jobs= must be at least 1, got {jobs}")
    if name == "local":
        if scheduler:
            raise InputError("scheduler= needs executor='dask'")
        return LocalExecutor(jobs)
    if name == "dask":
        return DaskExecutor(scheduler, jobs)
    raise InputError(f"unknown executor {name!r}; choose local or dask")
