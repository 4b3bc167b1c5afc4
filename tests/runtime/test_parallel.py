"""The shared pool (nlid.runtime.parallel): its size follows the cores and the load; kernel_threads pins BLAS."""

from __future__ import annotations

import numba
import pytest
from threadpoolctl import threadpool_info

from nlid.runtime import parallel


def test_workers_are_every_core_or_the_cores_less_the_other_processes_load(monkeypatch):
    monkeypatch.delenv(parallel.WORKERS_ENV, raising=False)
    monkeypatch.setattr(parallel, "cores", lambda: 4)
    assert parallel.workers() == 4
    assert parallel.workers(load=0.0) == 4
    assert parallel.workers(load=1.0) == 4  # this process's own thread
    assert parallel.workers(load=3.0) == 2  # two other processes keep two cores busy
    assert parallel.workers(load=20.0) == 1  # never fewer than one
    assert parallel.workers(load=2.0, own=0.0) == 2


def test_the_environment_fixes_the_pool(monkeypatch):
    monkeypatch.setenv(parallel.WORKERS_ENV, "3")
    assert parallel.workers(load=50.0) == 3
    monkeypatch.setenv(parallel.WORKERS_ENV, "zero")
    with pytest.raises(ValueError, match="NLID_WORKERS must be a positive integer"):
        parallel.workers()


def test_kernel_threads_sets_numba_and_blas_and_restores_them():
    before = numba.get_num_threads()
    with parallel.kernel_threads(1) as n:
        assert n == 1
        assert numba.get_num_threads() == 1
        assert all(pool["num_threads"] == 1 for pool in threadpool_info())
    assert numba.get_num_threads() == before


def test_kernel_threads_never_exceed_numbas_pool():
    with parallel.kernel_threads(10_000) as n:
        assert n == numba.config.NUMBA_NUM_THREADS == numba.get_num_threads()


def test_one_reading_of_the_thread_budget(monkeypatch):
    """threads() serves the kernels' budget (both) and the bias correction: a pin, else the pool size."""
    monkeypatch.setattr(parallel, "cores", lambda: 4)
    monkeypatch.delenv(parallel.WORKERS_ENV, raising=False)
    monkeypatch.delenv("NUMBA_NUM_THREADS", raising=False)
    assert parallel.pinned() is None and parallel.threads() == 4 and parallel.threads(3) == 3
    assert parallel.threads(8, load=3.0) == 2 and parallel.threads(0) == 1
    monkeypatch.setenv(parallel.WORKERS_ENV, "3")
    assert parallel.threads(8) == 3 and parallel._budget() == 3
    monkeypatch.setenv("NUMBA_NUM_THREADS", "1")  # a pinned run process: its pin wins over the pool size
    assert parallel.pinned() == 1 and parallel.threads(8) == 1 and parallel._budget() == 1
    with parallel.thread_budget(2):
        assert parallel._budget() == 2
