"""Executing one run: in this process (:func:`execute_run`) or isolated in a child (:func:`run_isolated`).

:func:`execute_run` rebuilds the records from the run's spec, identifies
(timing it and tracing its peak memory), computes the metrics
(:mod:`nlid.study.metrics`, :meth:`nlid.reference.Comparison.to_row`; the
columns are declared in :mod:`nlid.study.columns`) and, when the study has a
``[posterior]`` table, adds ``nlid.bayes.study_metrics(record, result,
reference, **options)`` to the row. It never raises: a failure is a payload with
``status = "failed"`` and the error message.

:func:`run_isolated` runs :func:`execute_run` in a child process so a hung or
crashing identifier can be stopped: the child is forked from nlid's fork
server (:func:`nlid.isolation.run_in_child`, shared with ``nlid identify
--timeout``), or, inside a daemonic process such as a default Dask worker
(which may not have ``multiprocessing`` children), started as ``python -m
nlid.study.child``. A child still running at the time limit is killed and the
run is recorded as timed out; a child that dies is recorded as failed with
its exit code or signal. Children die with their parent
(:func:`nlid.isolation.die_with_parent`). A spec of another kind than a
study's :class:`RunSpec` (``nlid bench``'s :class:`nlid.benchmarking.jobs.BenchJob`)
runs itself through the same isolation: it has ``run_id``, ``timeout``,
``execute()``, ``failure(status, error)`` and ``to_dict()``. The child gets the parent's
``sys.path`` and environment, so plugins visible to the parent are visible to
it.
"""

from __future__ import annotations

import json
import multiprocessing
import os
import shutil
import subprocess
import sys
import tempfile
import time
import traceback
import tracemalloc
from pathlib import Path
from typing import Any

import numpy as np

from .. import isolation
from ..errors import NlidError
from ..interface import to_jsonable
from ..pipeline import as_model, identify
from ..reference import compare
from ..registry import load_registry
from . import columns as col
from . import metrics
from .data import build_data
from .plan import RunSpec

__all__ = ["execute_run", "run_isolated", "kill_children", "failure_payload", "subprocess_main"]

#: Prefix of the temporary folders of runs started as ``python -m nlid.study.child`` (then the parent's pid).
RUN_FOLDER_PREFIX = "nlid-run-"


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
    row[key] = f"{row[key]} | {text}" if row[key] else text


def execute_run(spec: RunSpec) -> dict[str, Any]:
    """Run one identification and its metrics in this process (never raises).

    Returns
    -------
    dict
        ``{"run_id", "row", "result", "reference", "arrays"}``: the flat
        metrics row, the :class:`~nlid.identified.IdentifiedModel` as a
        dictionary, the reference values and the result's arrays.
    """
    if not isinstance(spec, RunSpec):  # another kind of job (nlid.benchmarking.jobs.BenchJob) runs itself
        return spec.execute()
    try:
        return _execute(spec)
    except NlidError as exc:
        return failure_payload(spec, "failed", str(exc))
    except Exception as exc:  # noqa: BLE001 - a run's failure is recorded, the study goes on
        payload = failure_payload(spec, "failed", f"{type(exc).__name__}: {exc}")
        payload["traceback"] = traceback.format_exc()
        return payload


def _execute(spec: RunSpec) -> dict[str, Any]:
    data = build_data(spec)
    model = as_model(spec.terms, without=spec.without, px_roots=spec.px_roots)
    registry = load_registry()
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
    try:
        row.update(metrics.holdout_metrics(data.heldout, result, spec.dataset.freerun, spec.dataset.freerun_rule))
    except NlidError as exc:
        row.update(metrics.holdout_metrics(None, result, False))
        _add_warning(row, f"held-out scores: {exc}")
    row.update(compare(result, data.reference).to_row())
    slices = spec.dataset.slices
    surface, extra_arrays = metrics.surface_metrics(data.record, result, slices)
    row.update(surface)
    if spec.posterior is not None:
        from .. import bayes  # type: ignore[attr-defined]  # issue 6; checked when the config is loaded

        # a posterior that cannot be reported (e.g. unconverged chains) is a warning: the run keeps its metrics
        try:
            extra = bayes.study_metrics(data.record, result, data.reference, **dict(spec.posterior))
        except NlidError as exc:
            extra = {}
            _add_warning(row, f"posterior: {exc}")
        row.update(extra)  # declared families (nlid.study.columns): they never collide with the columns above
    return {
        "run_id": spec.run_id,
        "row": to_jsonable(row),
        "result": result.to_dict(),
        "reference": to_jsonable(data.reference.to_dict()),
        "arrays": {**{k: np.asarray(v) for k, v in result.arrays.items()}, **extra_arrays},
    }


# --------------------------------------------------------------------------- isolation
def kill_children() -> None:
    """Kill every run child process this process started (on interrupt)."""
    isolation.kill_children()


def _died(spec: RunSpec, exitcode: int | None) -> dict[str, Any]:
    return failure_payload(spec, "failed", f"worker process died ({isolation.describe_exit(exitcode)})")


def run_isolated(spec: RunSpec, timeout: float | None = None, *, use_subprocess: bool | None = None) -> dict:
    """Run :func:`execute_run` in a child process, killed at the time limit (:func:`nlid.isolation.run_in_child`).

    Parameters
    ----------
    spec
        The run's spec (:class:`nlid.study.plan.Run`).
    timeout
        Seconds; default ``spec.timeout``.
    use_subprocess
        Force (``True``) or forbid (``False``) the ``python -m`` child; default:
        only inside a daemonic process.
    """
    timeout = float(spec.timeout if timeout is None else timeout)
    if use_subprocess is None:
        use_subprocess = bool(multiprocessing.current_process().daemon)
    if use_subprocess:
        return _run_subprocess(spec, timeout)
    outcome = isolation.run_in_child(execute_run, (spec,), timeout=timeout)
    if outcome.status == "ok":
        return outcome.value
    if outcome.status == "timeout":
        return failure_payload(spec, "timeout", f"stopped after the time limit of {timeout:g} s")
    return _died(spec, outcome.exitcode)


def _sweep_run_folders() -> None:
    """Remove run folders left in the temporary folder by parents that were killed."""
    for folder in Path(tempfile.gettempdir()).glob(f"{RUN_FOLDER_PREFIX}*"):
        try:
            pid = int(folder.name[len(RUN_FOLDER_PREFIX) :].split("-", 1)[0])
            os.kill(pid, 0)
        except ProcessLookupError:
            shutil.rmtree(folder, ignore_errors=True)
        except (ValueError, PermissionError, OSError):
            continue


def _run_subprocess(spec: RunSpec, timeout: float) -> dict[str, Any]:
    _sweep_run_folders()
    with tempfile.TemporaryDirectory(prefix=f"{RUN_FOLDER_PREFIX}{os.getpid()}-") as tmp:
        folder = Path(tmp)
        (folder / "spec.json").write_text(json.dumps(spec.to_dict()))
        env = dict(os.environ)
        env["PYTHONPATH"] = os.pathsep.join(p for p in sys.path if p)
        env[isolation.PARENT_ENV] = str(os.getpid())
        proc = subprocess.Popen(
            [sys.executable, "-m", "nlid.study.child", str(folder)], env=env, stdout=subprocess.DEVNULL
        )
        isolation.track(proc)
        try:
            proc.wait(timeout)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
            return failure_payload(spec, "timeout", f"stopped after the time limit of {timeout:g} s")
        finally:
            isolation.untrack(proc)
        out = folder / "payload.json"
        if proc.returncode != 0 or not out.is_file():
            return _died(spec, proc.returncode)
        payload = json.loads(out.read_text())
        arrays = folder / "arrays.npz"
        if arrays.is_file():
            with np.load(arrays, allow_pickle=False) as npz:
                payload["arrays"] = {k: npz[k] for k in npz.files}
        return payload


def subprocess_main(folder: str) -> int:
    """Run the spec in ``folder/spec.json``; write ``payload.json`` and ``arrays.npz`` there."""
    parent = os.environ.get(isolation.PARENT_ENV)
    isolation.die_with_parent(int(parent) if parent else None)
    path = Path(folder)
    data = json.loads((path / "spec.json").read_text())
    if data.get("kind") == "bench":
        from ..benchmarking.jobs import BenchJob

        spec: Any = BenchJob.from_dict(data)
    else:
        spec = RunSpec.from_dict(data)
    payload = execute_run(spec)
    arrays = payload.pop("arrays", {})
    if arrays:
        np.savez(path / "arrays.npz", **arrays)
    tmp = path / "payload.json.tmp"
    tmp.write_text(json.dumps(to_jsonable(payload)))
    os.replace(tmp, path / "payload.json")
    return 0
