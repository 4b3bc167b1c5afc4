"""Executing one run: in this process (:func:`execute_run`) or isolated in a child (:func:`run_isolated`).

:func:`execute_run` rebuilds the records from the run's spec, identifies
(timing it and tracing its peak memory), computes the metrics
(the core's typed values flattened by :mod:`nlid.study.metrics` into the
columns declared in :mod:`nlid.study.columns`) and, when the study has a
``[posterior]`` table, adds ``nlid.bayes.posterior_metrics(record, result,
reference, **options)`` to the row. It never raises: a failure is a payload with
``status = "failed"`` and the error message, and so is a result that could not
be stored as JSON (a plugin's diagnostics holding an object, say).

:func:`run_isolated` runs :func:`execute_run` in a child process
(:func:`nlid.runtime.isolation.run_in_child`, shared with ``nlid identify``),
forked from nlid's warm fork server, or started as a fresh interpreter with
the spawn start method (Windows, ``NLID_START_METHOD=spawn``). Whatever the
plugin does, the run ends as a payload: a child still running at the time
limit is killed with its process group and the run is recorded as
``timeout``; a child that crashes (``"identifier 'x' crashed: segmentation
fault (SIGSEGV)"``), raises through everything, or returns what cannot be
sent back is recorded as ``failed`` with that reason; warnings the plugin
issued and threads it left running go to the row's ``warnings``. Only a
failure of the machinery itself (no child could be started) raises
(:class:`~nlid.runtime.outcome.IsolationError`), so a study never records
every run as failed for a reason that is not theirs.
A spec of another kind than a study's :class:`RunSpec` (``nlid bench``'s
:class:`nlid.benchmarking.jobs.BenchJob`) runs itself through the same
isolation: it has ``run_id``, ``timeout``, ``execute()``, ``failure(status,
error)`` and ``to_dict()``.
"""

from __future__ import annotations

import time
import traceback
import tracemalloc
from typing import Any

import numpy as np

from ..base.jsonable import to_jsonable
from ..contract.registry import load_registry
from ..errors import NlidError
from ..identification.pipeline import as_model, identify
from ..identified.reference import compare
from ..runtime import isolation, parallel
from . import columns as col
from . import metrics
from .data import build_data
from .plan import RunSpec
from .store import INFRASTRUCTURE

__all__ = ["execute_run", "run_isolated", "kill_children", "failure_payload", "json_problem"]


def _base_row(spec: RunSpec) -> dict[str, Any]:
    return {
        col.RUN_ID.key(): spec.run_id,
        col.DATASET.key(): spec.dataset.name,
        col.MODEL.key(): spec.model,
        col.METHOD.key(): spec.method,
        col.REPETITION.key(): spec.repetition,
        col.SEED.key(): spec.seed,
        col.STATUS.key(): "ok",
        col.ERROR.key(): "",
    }


def failure_payload(spec: RunSpec, status: str, error: str) -> dict[str, Any]:
    """The payload of a run that produced no result."""
    if not isinstance(spec, RunSpec):  # a job of another kind (nlid.benchmarking) says what its failure looks like
        return spec.failure(status, error)
    row = _base_row(spec)
    row[col.STATUS.key()] = status
    row[col.ERROR.key()] = error
    return {"run_id": spec.run_id, "row": row, "result": None, "reference": None, "arrays": {}}


def _add_warning(row: dict[str, Any], text: str) -> None:
    """Append a warning to the row's ``warnings`` column (``" | "``-separated)."""
    key = col.WARNINGS.key()
    row[key] = f"{row[key]} | {text}" if row.get(key) else text


def execute_run(spec: RunSpec, threads: int = 1) -> dict[str, Any]:
    """Run one identification and its metrics in this process (never raises).

    ``threads``: how many threads the run's scores may use (:func:`nlid.runtime.parallel.thread_budget`: the
    free run and its chaos check at once with two); the numbers do not depend on it.

    Returns
    -------
    dict
        ``{"run_id", "row", "result", "reference", "arrays", "timings"}``: the
        flat metrics row, the :class:`~nlid.identified.model.IdentifiedModel` as a
        dictionary, the reference values, the result's arrays, and the wall
        time in seconds of each part of the run (``data``, ``identify``,
        ``scores``, ``metrics``, ``posterior``, ``payload``; not stored: the
        row's ``seconds`` is the identification's).
    """
    if not isinstance(spec, RunSpec):  # another kind of job (nlid.benchmarking.jobs.BenchJob) runs itself
        return spec.execute()
    try:
        with parallel.thread_budget(threads):
            payload = _execute(spec)
    except NlidError as exc:
        return failure_payload(spec, "failed", str(exc))
    except Exception as exc:  # noqa: BLE001 - a run's failure is recorded, the study goes on
        payload = failure_payload(spec, "failed", f"{type(exc).__name__}: {exc}")
        payload["traceback"] = traceback.format_exc()
        return payload
    problem = json_problem({k: payload[k] for k in ("row", "result", "reference")})
    objects = [k for k, v in payload["arrays"].items() if v.dtype.hasobject]
    if objects and not problem:
        problem = f"arrays[{objects[0]!r}] holds Python objects, not numbers"
    if problem:
        why = f"identifier {spec.method!r} returned a result that cannot be stored: {problem}"
        return failure_payload(spec, "failed", why)
    return payload


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


def _execute(spec: RunSpec) -> dict[str, Any]:
    if spec.dataset.source.kind == "preset":
        from .structures import execute_structure_run, is_structure_preset

        if is_structure_preset(spec.dataset.source.name):  # several DOFs: nlid.study.structures
            return execute_structure_run(spec, _base_row(spec))
    clock = [time.perf_counter()]
    timings: dict[str, float] = {}  # the run's fixed costs beside the identification (benchmarks/bench_scaling.py)

    def lap(name: str) -> None:
        now = time.perf_counter()
        timings[name] = now - clock[0]
        clock[0] = now

    data = build_data(spec)
    model = as_model(spec.terms, without=spec.without, px_roots=spec.px_roots)
    registry = load_registry()
    lap("data")
    tracemalloc.start()
    start = time.perf_counter()
    try:
        result = identify(
            data.record, model, spec.method, mass=data.mass, options=dict(spec.options), registry=registry
        )
        seconds = time.perf_counter() - start
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    lap("identify")
    row = _base_row(spec)
    row[col.SECONDS.key()] = seconds
    row[col.PEAK_MEMORY.key()] = peak / 1e6
    row[col.METHOD_SECONDS.key()] = result.seconds
    row[col.SAMPLES.key()] = data.record.n
    row[col.Z_MIN.key()] = float(data.record.z.min())
    row[col.Z_MAX.key()] = float(data.record.z.max())
    row[col.EPS.key()] = result.eps_percent
    row[col.FORCE_RESIDUAL.key()] = result.force_residual_percent
    row[col.WARNINGS.key()] = " | ".join(result.warnings)
    for flag in result.flags:  # what physics forbids (nlid.identified.plausibility): never silent in a study
        _add_warning(row, f"NOT TRUSTED: {flag}")
    try:
        row.update(metrics.holdout_metrics(data.heldout, result, spec.dataset.freerun, spec.dataset.freerun_rule))
    except NlidError as exc:
        row.update(metrics.holdout_metrics(None, result, False))
        _add_warning(row, f"held-out scores: {exc}")
    lap("scores")
    row.update(metrics.comparison_columns(compare(result, data.reference)))
    slices = spec.dataset.slices
    surface, extra_arrays = metrics.surface_metrics(data.record, result, slices)
    row.update(surface)
    lap("metrics")
    if spec.posterior is not None:
        from .. import bayes  # type: ignore[attr-defined]  # issue 6; checked when the config is loaded

        # a posterior that cannot be reported (e.g. unconverged chains) is a warning: the run keeps its metrics
        try:
            extra = metrics.posterior_columns(
                bayes.posterior_metrics(data.record, result, data.reference, **dict(spec.posterior))
            )
        except NlidError as exc:
            extra = {}
            _add_warning(row, f"posterior: {exc}")
        row.update(extra)  # declared families (nlid.study.columns): they never collide with the columns above
        lap("posterior")
    if spec.response is not None:
        try:
            row.update(metrics.response_metrics(result, data.reference, **dict(spec.response)))
        except NlidError as exc:  # a response that cannot be computed is a warning: the run keeps its metrics
            _add_warning(row, f"response: {exc}")
        lap("response")
    payload = {
        "run_id": spec.run_id,
        "row": to_jsonable(row),
        "result": result.to_dict(),
        "reference": to_jsonable(data.reference.to_dict()),
        "arrays": {**{k: np.asarray(v) for k, v in result.arrays.items()}, **extra_arrays},
        "timings": timings,
    }
    lap("payload")
    return payload


# --------------------------------------------------------------------------- isolation
def kill_children() -> None:
    """Kill every run child process this process started, with their process groups (on interrupt)."""
    isolation.kill_children()


def run_isolated(
    spec: RunSpec, timeout: float | None = None, *, use_subprocess: bool | None = None, threads: int = 1
) -> dict:
    """Run :func:`execute_run` in a child process killed at its time limit (``isolation.run_in_child``).

    Parameters
    ----------
    spec
        The run's spec (:class:`nlid.study.plan.RunSpec`).
    timeout
        Seconds; default ``spec.timeout``.
    use_subprocess
        ``True``: a fresh interpreter (the spawn start method), whatever
        :func:`nlid.runtime.isolation.start_method` says; default: that.
    threads
        Threads the run's scores may use (:func:`execute_run`; its identification and libraries stay on one).

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
    label = f"identifier {spec.method!r}" if isinstance(spec, RunSpec) else f"job {spec.run_id!r}"
    for _attempt in range(2):  # a fork server that died under the run (the OOM killer): once more, on a new one
        outcome = isolation.run_in_child(
            execute_run, (spec, threads), timeout=timeout, pin_threads=True, method="spawn" if use_subprocess else None
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
