"""Executors: where a study's runs execute.

Both executors call :func:`nlid.study.worker.run_isolated` for each run, so a
run always executes in its own child process with its time limit (forked from
nlid's warm fork server, or a fresh interpreter with the spawn start method),
and both hand each finished run back to the caller (``on_done(run, payload)``)
in the calling thread as soon as it finishes, where it is persisted at once.

:class:`LocalExecutor`
    A pool of ``jobs`` threads on this machine (default: every core), each
    waiting on one child process at a time.
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
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor
from concurrent.futures import wait as wait_futures
from typing import Any

from ..errors import InputError
from ..runtime.isolation import start_fork_server
from .job import Scheduled
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
    """Run processes on this machine, ``jobs`` at a time.

    Parameters
    ----------
    jobs
        Concurrent runs (default: :func:`default_jobs`).
    """

    name = "local"

    def __init__(self, jobs: int | None = None) -> None:
        self.jobs = jobs

    def run(self, runs: Sequence[Scheduled], on_done: OnDone) -> None:
        """Execute ``runs``, calling ``on_done`` in this thread as each finishes."""
        if not runs:
            return
        jobs = self.jobs or default_jobs()
        start_fork_server(pin_threads=True)  # it loads the plugins while the pool starts
        pool = ThreadPoolExecutor(max_workers=min(jobs, len(runs)), thread_name_prefix="nlid-run")
        try:
            # fewer runs than cores: each run's scores may use the idle cores (the same numbers)
            threads = max(1, default_jobs() // min(jobs, len(runs)))
            pending = {pool.submit(run_isolated, run.spec, threads=threads): run for run in runs}
            while pending:
                done, _ = wait_futures(pending, timeout=0.5, return_when=FIRST_COMPLETED)
                for fut in done:
                    on_done(pending.pop(fut), fut.result())
        except BaseException:
            pool.shutdown(wait=False, cancel_futures=True)
            kill_children()
            raise
        pool.shutdown(wait=True)


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
