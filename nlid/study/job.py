"""The job protocol: what the worker runs isolated in a child process (:mod:`nlid.study.worker`).

A study's run (:class:`nlid.study.plan.RunSpec`) is one kind of job; ``nlid bench``'s
(:class:`nlid.benchmarking.jobs.BenchJob`) is another. The worker knows neither: it starts a child,
calls :meth:`Job.execute` there and, when the child produced nothing (a time limit, a crash), asks the
job for its :meth:`Job.failure` payload. A job is a frozen value that crosses process boundaries
(pickled by :mod:`nlid.runtime.isolation` and Dask).

The executors (:mod:`nlid.study.execute`) and the result store (:mod:`nlid.study.store`) see a job as
:class:`Scheduled`: its key, the job and the digest of its inputs (:class:`nlid.study.plan.Run` and
:class:`nlid.benchmarking.jobs.BenchRun`).

A payload is ``{"run_id", "row", "result", "reference", "arrays", ...}``: ``row`` is a flat
``{column: value}`` mapping with at least ``status`` and ``error``.
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

__all__ = ["Job", "Scheduled"]


@runtime_checkable
class Job(Protocol):
    """One unit of work the worker runs in a child with a time limit."""

    @property
    def run_id(self) -> str:
        """The job's key: unique in its study (or bench), stable across runs of it."""

    @property
    def timeout(self) -> float:
        """Seconds before the job's child is stopped."""

    @property
    def label(self) -> str:
        """How a failure message names the job (``"identifier 'rfs'"``, ``"job 'silverbox/rfs'"``)."""

    def execute(self, threads: int = 1) -> dict[str, Any]:
        """Do the work in this process and return its payload (never raises: a failure is a payload).

        ``threads``: how many threads the job's scores may use (:func:`nlid.runtime.parallel.thread_budget`).
        """

    def failure(self, status: str, error: str) -> dict[str, Any]:
        """The payload of the job when it produced nothing: ``status`` (``"failed"``, ``"timeout"``,
        ``"lost"``) and the one-line reason."""


@runtime_checkable
class Scheduled(Protocol):
    """A job as the executors and the result store see it."""

    @property
    def run_id(self) -> str:
        """The job's key (:attr:`Job.run_id`): the name of its stored result."""

    @property
    def spec(self) -> Job:
        """The job the worker runs."""

    @property
    def digest(self) -> str:
        """A digest of the job's inputs: a stored result with another digest is stale and runs again."""
