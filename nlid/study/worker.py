"""Running a job: in this process (:func:`execute_run`) or isolated in a child (:func:`run_isolated`).

A job is anything that follows :class:`nlid.study.job.Job`: a study's run
(:class:`nlid.study.plan.RunSpec`, executed by :mod:`nlid.study.run`) or
``nlid bench``'s :class:`nlid.benchmarking.jobs.BenchJob`. The worker calls
its methods and knows no kind of job.

:func:`run_isolated` runs :func:`execute_run` in a child process
(:func:`nlid.runtime.isolation.run_in_child`, shared with ``nlid identify``),
forked from nlid's warm fork server, or started as a fresh interpreter with
the spawn start method (Windows, ``NLID_START_METHOD=spawn``). Whatever the
plugin does, the run ends as a payload: a child still running at the time
limit is killed with its process group and the run is recorded as
``timeout``; a child that crashes (``"identifier 'x' crashed: segmentation
fault (SIGSEGV)"``), raises through everything, or returns what cannot be
sent back is recorded as ``failed`` with that reason (the job's
:meth:`~nlid.study.job.Job.failure` payload); warnings the plugin
issued and threads it left running go to the row's ``warnings``. Only a
failure of the machinery itself (no child could be started) raises
(:class:`~nlid.runtime.outcome.IsolationError`), so a study never records
every run as failed for a reason that is not theirs.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from ..base.jsonable import to_jsonable
from ..runtime import isolation
from . import columns as col
from .store import INFRASTRUCTURE

if TYPE_CHECKING:
    from .job import Job

__all__ = ["execute_run", "run_isolated", "kill_children", "failure_payload", "json_problem"]


def failure_payload(job: Job, status: str, error: str) -> dict[str, Any]:
    """The payload of a job that produced no result (:meth:`Job.failure <nlid.study.job.Job.failure>`)."""
    return job.failure(status, error)


def _add_warning(row: dict[str, Any], text: str) -> None:
    """Append a warning to the row's ``warnings`` column (``" | "``-separated)."""
    key = col.WARNINGS.key()
    row[key] = f"{row[key]} | {text}" if row.get(key) else text


def execute_run(job: Job, threads: int = 1) -> dict[str, Any]:
    """Run one job in this process (:meth:`Job.execute <nlid.study.job.Job.execute>`; never raises).

    ``threads``: how many threads the job's scores may use (:func:`nlid.runtime.parallel.thread_budget`: a
    study run's free run and its chaos check at once with two); the numbers do not depend on it.

    Returns
    -------
    dict
        The job's payload: for a study run (:func:`nlid.study.run.execute_spec`)
        ``{"run_id", "row", "result", "reference", "arrays", "timings"}``.
    """
    return job.execute(threads)


def json_problem(value: Any, where: str = "") -> str | None:
    """Why ``value`` (after :func:`~nlid.base.jsonable.to_jsonable`) is not plain JSON, or ``None``.

    ``"result['diagnostics']['fit'] is a Foo, not a JSON value"``: the first
    offending entry.
    """
    value = to_jsonable(value)
    if value is None or isinstance(value, (str, bool, int)):
        return None
    if isinstance(value, float):
        return None if np.isfinite(value) else f"{where or 'the value'} is {value}"
    if isinstance(value, dict):
        for key, item in value.items():
            found = json_problem(item, f"{where}[{key!r}]")
            if found:
                return found
        return None
    if isinstance(value, list):
        for i, item in enumerate(value):
            found = json_problem(item, f"{where}[{i}]")
            if found:
                return found
        return None
    return f"{where or 'the value'} is a {type(value).__name__}, not a JSON value"


# --------------------------------------------------------------------------- isolation
def kill_children() -> None:
    """Kill every run child process this process started, with their process groups (on interrupt)."""
    isolation.kill_children()


def run_isolated(
    spec: Job,
    timeout: float | None = None,
    *,
    use_subprocess: bool | None = None,
    threads: int = 1,
    on_notice: Callable[[str], None] | None = None,
) -> dict:
    """Run :func:`execute_run` in a child process killed at its time limit (``isolation.run_in_child``).

    Parameters
    ----------
    spec
        The job (:class:`nlid.study.job.Job`: a study's :class:`~nlid.study.plan.RunSpec`, a bench job).
    timeout
        Seconds; default ``spec.timeout``.
    use_subprocess
        ``True``: a fresh interpreter (the spawn start method), whatever
        :func:`nlid.runtime.isolation.start_method` says; default: that.
    threads
        Threads the run's scores may use (:func:`execute_run`; its identification and libraries stay on one).
    on_notice
        Called in this thread with each notice the child sends before its reply
        (:func:`nlid.runtime.child.notify`: a study run sends ``"identified"`` when its identification is
        done and its scores begin); a forked child only.

    Returns
    -------
    dict
        The run's payload (:func:`execute_run`), or a failure payload saying
        why the run produced nothing.

        A run whose fork server died under it (twice: it is tried again at once) has the status
        ``"lost"`` and ``payload[INFRASTRUCTURE]`` set: nlid's failure, not the run's, which
        :meth:`nlid.study.store.ResultStore.save` does not store.

    Raises
    ------
    IsolationError
        No child process could be started (not the run's fault).
    """
    timeout = float(spec.timeout if timeout is None else timeout)
    label = spec.label
    for _attempt in range(2):  # a fork server that died under the run (the OOM killer): once more, on a new one
        outcome = isolation.run_in_child(
            execute_run,
            (spec, threads),
            timeout=timeout,
            pin_threads=True,
            method="spawn" if use_subprocess else None,
            on_notice=on_notice,
        )
        if not outcome.infrastructure:
            break
    if outcome.infrastructure:  # not the run's result: not stored (ResultStore.save), so a resume runs it again
        payload = failure_payload(spec, "lost", outcome.describe(label, timeout))
        payload[INFRASTRUCTURE] = True
        return payload
    if outcome.status == "ok":
        payload = outcome.value
    elif outcome.status == "timeout":
        payload = failure_payload(spec, "timeout", f"stopped after the time limit of {timeout:g} s")
    else:
        payload = failure_payload(spec, "failed", outcome.describe(label, timeout))
        if outcome.traceback:
            payload["traceback"] = outcome.traceback
    for line in outcome.warning_lines(label):
        _add_warning(payload["row"], line)
    return payload
