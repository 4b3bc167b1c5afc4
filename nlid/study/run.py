"""One study run: its spec executed in this process into a row and a payload (:meth:`RunSpec.execute`).

:func:`execute_spec` rebuilds the records from the run's spec, identifies
(timing it and tracing its peak memory), computes the metrics (the core's typed
values flattened by :mod:`nlid.study.metrics` into the columns declared in
:mod:`nlid.study.columns`) and, when the study has a ``[posterior]`` table, adds
``nlid.bayes.posterior_metrics(record, result, reference, **options)`` to the row.
It never raises: a failure is a payload with ``status = "failed"`` and the error
message (:func:`spec_failure`), and so is a result that could not be stored as
JSON (a plugin's diagnostics holding an object, say). The worker
(:mod:`nlid.study.worker`) runs it isolated in a child, as it runs any
:class:`~nlid.study.job.Job`.
"""

from __future__ import annotations

import time
import traceback
from typing import TYPE_CHECKING, Any

import numpy as np

from ..base.jsonable import to_jsonable
from ..contract.registry import load_registry
from ..errors import NlidError
from ..identification.pipeline import as_model, identify
from ..identified.reference import compare
from ..runtime import child, parallel
from . import columns as col
from . import metrics
from .data import build_data
from .worker import _add_warning, json_problem

if TYPE_CHECKING:
    from .plan import RunSpec

__all__ = ["execute_spec", "spec_failure", "IDENTIFIED"]

#: The notice a run child sends when its identification is done (:func:`nlid.runtime.child.notify`).
IDENTIFIED = "identified"


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


def spec_failure(spec: RunSpec, status: str, error: str) -> dict[str, Any]:
    """The payload of a run that produced no result (:meth:`RunSpec.failure`)."""
    row = _base_row(spec)
    row[col.STATUS.key()] = status
    row[col.ERROR.key()] = error
    return {"run_id": spec.run_id, "row": row, "result": None, "reference": None, "arrays": {}}


def execute_spec(spec: RunSpec, threads: int = 1) -> dict[str, Any]:
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
    try:
        with parallel.thread_budget(threads):
            payload = _execute(spec)
    except NlidError as exc:
        return spec_failure(spec, "failed", str(exc))
    except Exception as exc:  # noqa: BLE001 - a run's failure is recorded, the study goes on
        payload = spec_failure(spec, "failed", f"{type(exc).__name__}: {exc}")
        payload["traceback"] = traceback.format_exc()
        return payload
    problem = json_problem({k: payload[k] for k in ("row", "result", "reference")})
    objects = [k for k, v in payload["arrays"].items() if v.dtype.hasobject]
    if objects and not problem:
        problem = f"arrays[{objects[0]!r}] holds Python objects, not numbers"
    if problem:
        why = f"identifier {spec.method!r} returned a result that cannot be stored: {problem}"
        return spec_failure(spec, "failed", why)
    return payload


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
    options = dict(spec.options)
    result, cost = metrics.timed_identification(
        lambda: identify(data.record, model, spec.method, mass=data.mass, options=options, registry=registry),
        data.record,
    )
    lap("identify")
    child.notify(IDENTIFIED)  # the executor may start the next run's identification while this run scores
    row = {**_base_row(spec), **cost}
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
