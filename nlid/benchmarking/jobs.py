"""One bench job: a benchmark x its pipelines, run in its own process by the study executors.

A :class:`BenchJob` is a frozen value (the benchmark file's text, the pipelines, the data
source, the user files with their checksums), so it crosses process boundaries like a study's
run spec. It is a :class:`nlid.study.job.Job` (``run_id``, ``timeout``, ``label``, ``execute``,
``failure``): :func:`nlid.study.worker.run_isolated` runs :meth:`BenchJob.execute` in a child with
the time limit, and :class:`nlid.study.store.ResultStore` persists its payload as soon as it
finishes (its digest tells whether a stored result still belongs to the job).

:meth:`BenchJob.execute` loads the estimation part, fits every pipeline on it
(:func:`nlid.benchmarking.pipelines.fit_pipelines`), and only then loads each test set and scores each
fitted model on it under the test set's rule: the test sets are read after every decision is
made, and the decisions are recorded (``choices``) so a test can show they do not depend on them.
"""

from __future__ import annotations

import hashlib
import json
import time
import traceback
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .. import scoring
from ..base.jsonable import to_jsonable
from ..data.io import check_path, file_sha256
from ..data.record import Record
from ..errors import DataError, NlidError
from .data import load_estimation, load_test, noise_floor
from .declarations import Protocol, TestSet
from .fitted import Fitted
from .pipelines import PEER, PipelineSpec, fit_pipelines
from .protocol import parse_protocol
from .truth import TRUTH_KIND

__all__ = ["BenchJob", "BenchRun", "score_model"]

#: Job kind in a spec's JSON (:meth:`BenchJob.to_dict`).
KIND = "bench"
#: Optional packages by the pipeline that needs them: a job records whether each is installed, so
#: installing one makes a job that skipped its row run again.
OPTIONAL = {"sysidentpy": "sysidentpy"}


def _installed(pipelines: tuple[PipelineSpec, ...]) -> dict[str, bool]:
    import importlib.util

    return {
        package: importlib.util.find_spec(package) is not None
        for name, package in OPTIONAL.items()
        if any(p.name == name for p in pipelines)
    }


def _score(fit: Any, record: Record, rule: str) -> tuple[Any, str, str, int]:
    """``(scores, rule applied in words, rule applied as a spec, scored samples)`` of an nlid model.

    The one call of :func:`nlid.scoring.score` with the protocol's transient rule.
    """
    scores = scoring.score(fit, record, rule=scoring.rule_from_spec(rule))
    samples = scores.freerun_scored_samples
    return scores, scores.freerun_rule or rule, rule, int(samples) if samples else record.n


def score_model(fitted: Fitted, record: Record, rule: str) -> dict[str, Any]:
    """The free-run scores of one fitted model on one test record under ``rule`` (RMSE in the unit of ``z``)."""
    if fitted.kind == "peer":  # every peer model has free_run(record, rule) -> PeerScore
        s = fitted.model.free_run(record, rule)
        return {
            "rmse": s.rmse,
            "nrmse_percent": s.nrmse_percent,
            "fit_percent": s.fit_percent,
            "rule": s.rule,
            "rule_applied": rule,
            "scored_samples": s.scored_samples,
            "note": s.note,
        }
    scores, text, applied, samples = _score(fitted.model, record, rule)
    note = "" if scores.freerun_note in ("", None) else str(scores.freerun_note)
    return {
        "rmse": float(scores.freerun_rmse),
        "nrmse_percent": float(scores.freerun_nrmse_percent),
        "fit_percent": float(scores.freerun_fit_percent),
        "rule": text,
        "rule_applied": applied,
        "scored_samples": samples,
        "note": note,
    }


def _sha256(path: str) -> str:
    p = Path(path)
    if p.is_dir():
        return "folder:" + ",".join(sorted(f"{c.name}={_sha256(str(c))}" for c in p.iterdir() if c.is_file()))
    return file_sha256(check_path(p, what="test file"))


@dataclass(frozen=True)
class BenchJob:
    """Everything a worker needs to run the pipelines of one benchmark (frozen; JSON round-trips).

    Attributes
    ----------
    run_id
        ``benchmark/pipeline+pipeline``.
    benchmark
        The benchmark's name.
    protocol_text
        The benchmark file's text (the job re-reads it: a changed file changes the digest).
    pipelines
        The pipelines of the job (one per job since issue 31: each discovery is judged by its own fits).
    source
        ``"auto"``, ``"local"`` or ``"package"`` (:mod:`nlid.benchmarking.data`).
    files
        ``{"benchmark:test": path}`` of user-supplied sets.
    checksums
        ``{"benchmark:test": sha256}`` of those files (part of the digest).
    timeout
        Seconds before the job is stopped.
    installed
        ``{package: installed}`` of the optional packages its pipelines need (part of the digest).
    """

    run_id: str
    benchmark: str
    protocol_text: str
    pipelines: tuple[PipelineSpec, ...]
    source: str = "auto"
    files: Mapping[str, str] = field(default_factory=dict)
    checksums: Mapping[str, str] = field(default_factory=dict)
    timeout: float = 1800.0
    installed: Mapping[str, bool] = field(default_factory=dict)

    @classmethod
    def make(
        cls,
        protocol: Protocol,
        pipelines: tuple[PipelineSpec, ...],
        *,
        source: str = "auto",
        files: Mapping[str, str] | None = None,
        timeout: float = 1800.0,
    ) -> BenchJob:
        """A job for one benchmark; ``files`` are the user files of *this* benchmark.

        Raises
        ------
        InputError
            A time limit that is not a positive number of seconds (refused before anything runs).
        """
        from ..identification.pipeline import check_timeout

        timeout = check_timeout(timeout)
        mine = {k: v for k, v in (files or {}).items() if k.split(":", 1)[0] == protocol.name}
        run_id = f"{protocol.name}/{'+'.join(p.name.replace(' ', '') for p in pipelines)}"
        return cls(
            run_id,
            protocol.name,
            protocol.text,
            pipelines,
            source,
            dict(mine),
            {k: _sha256(v) for k, v in mine.items()},
            float(timeout),
            _installed(pipelines),
        )

    # -- the JSON a child process reads (nlid.study.worker) and the digest
    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-able values (what a spawned child and the result store read back)."""
        return {
            "kind": KIND,
            "run_id": self.run_id,
            "benchmark": self.benchmark,
            "protocol_text": self.protocol_text,
            "pipelines": [p.to_dict() for p in self.pipelines],
            "source": self.source,
            "files": dict(self.files),
            "checksums": dict(self.checksums),
            "timeout": self.timeout,
            "installed": dict(self.installed),
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> BenchJob:
        """Inverse of :meth:`to_dict`."""
        return cls(
            data["run_id"],
            data["benchmark"],
            data["protocol_text"],
            tuple(PipelineSpec.from_dict(p) for p in data["pipelines"]),
            data.get("source", "auto"),
            dict(data.get("files") or {}),
            dict(data.get("checksums") or {}),
            float(data.get("timeout", 1800.0)),
            dict(data.get("installed") or {}),
        )

    def digest(self) -> str:
        """SHA-256 of the job without its time limit and file paths (first 16 hex digits)."""
        data = {k: v for k, v in self.to_dict().items() if k not in ("timeout", "files")}
        return hashlib.sha256(json.dumps(data, sort_keys=True).encode()).hexdigest()[:16]

    # -- the job protocol (nlid.study.job.Job): what the worker calls
    @property
    def label(self) -> str:
        """How a failure message names the job: ``"job 'silverbox/rfs'"``."""
        return f"job {self.run_id!r}"

    def failure(self, status: str, error: str) -> dict[str, Any]:
        """The payload of a job that produced nothing (its rows say why)."""
        row = {"run_id": self.run_id, "benchmark": self.benchmark, "status": status, "error": error}
        return {
            "run_id": self.run_id,
            "row": row,
            "result": {"rows": [], "fits": [], "noise_floors": {}},
            "reference": None,
            "arrays": {},
        }

    def execute(self, threads: int = 1) -> dict[str, Any]:
        """Fit the pipelines on the estimation part, then score them on every test set (never raises).

        ``threads`` is the protocol's thread budget (:meth:`nlid.study.job.Job.execute`); a bench job does not use
        it: its pipelines and scores run as they always did.
        """
        try:
            return self._execute()
        except NlidError as exc:
            return self.failure("failed", str(exc))
        except Exception as exc:  # noqa: BLE001 - a job's failure is recorded, the bench goes on
            payload = self.failure("failed", f"{type(exc).__name__}: {exc}")
            payload["traceback"] = traceback.format_exc()
            return payload

    def _execute(self) -> dict[str, Any]:
        start = time.perf_counter()
        protocol = parse_protocol(self.protocol_text, f"<{self.benchmark}>")
        estimation, offsets = load_estimation(
            protocol, source=self.source, path=self.files.get(f"{protocol.name}:estimation")
        )
        outcomes = fit_pipelines(estimation, protocol, self.pipelines)
        fits = [f for f in outcomes if isinstance(f, Fitted)]
        skipped = [(spec, why) for spec, why in zip(self.pipelines, outcomes, strict=True) if isinstance(why, str)]
        # only now are the test sets read: every decision above was made without them
        rows: list[dict[str, Any]] = []
        for spec, why in skipped:
            if spec.kind != TRUTH_KIND:  # no truth declared: the benchmark's truth is unknown, no row is missing
                rows += [_skipped_row(protocol, test, spec.name, spec.kind, why) for test in protocol.tests]
        floors: dict[str, float] = {}
        ranges: dict[str, dict[str, Any]] = {}
        fitted_range = scoring.value_range(estimation.z)
        for test in protocol.tests:
            if test.noise_floor is not None:
                floors[test.name] = noise_floor(estimation, test.noise_floor)
            try:
                record = load_test(
                    protocol, test, offsets, source=self.source, path=self.files.get(f"{protocol.name}:{test.name}")
                )
            except DataError as exc:
                rows += [self._row(protocol, test, f, None, "not run", str(exc)) for f in fits]
                continue
            reach = scoring.range_excess(fitted_range, record.z)
            said = reach.describe("the test")
            ranges[test.name] = {"beyond": reach.beyond, "outside": reach.outside, "text": said}
            first = len(rows)
            for fitted in fits:
                try:
                    scores = score_model(fitted, record, test.rule)
                    status = "ok" if np.isfinite(scores["rmse"]) else "no figure"
                    rows.append(self._row(protocol, test, fitted, scores, status, scores["note"], _where(record)))
                except NlidError as exc:
                    rows.append(self._row(protocol, test, fitted, None, "failed", str(exc)))
            for r in rows[first:]:
                r["extrapolation"] = said
        result = {
            "rows": rows,
            "fits": [_fit_dict(f) for f in fits],
            "skipped": {spec.name: why for spec, why in skipped},
            "noise_floors": floors,
            "ranges": ranges,
            "estimation": {"samples": estimation.n, "source": estimation.meta.get("source", "")},
            "offsets": {"f": offsets.f, "z": offsets.z},
        }
        row = {
            "run_id": self.run_id,
            "benchmark": self.benchmark,
            "status": "ok",
            "error": "",
            "seconds": time.perf_counter() - start,
        }
        return {"run_id": self.run_id, "row": row, "result": to_jsonable(result), "reference": None, "arrays": {}}

    def _row(
        self,
        protocol: Protocol,
        test: TestSet,
        fitted: Fitted,
        scores: Mapping[str, Any] | None,
        status: str,
        note: str,
        data_source: str = "",
    ) -> dict[str, Any]:
        s = dict(scores or {})
        return {
            **fitted.prior.to_row(),
            "benchmark": protocol.name,
            "test": test.name,
            "kind": fitted.kind,
            "pipeline": fitted.pipeline,
            "method": fitted.method,
            "model": _model_text(fitted, protocol.mass_unit),
            "rmse": s.get("rmse", np.nan),
            "nrmse_percent": s.get("nrmse_percent", np.nan),
            "fit_percent": s.get("fit_percent", np.nan),
            "parameters": fitted.parameters,
            "seconds": fitted.seconds,
            "rule": s.get("rule", ""),
            "rule_applied": s.get("rule_applied", ""),
            "rule_declared": test.rule,
            "scored_samples": s.get("scored_samples"),
            "status": status,
            "note": note,
            "data": data_source,
        }


def _skipped_row(protocol: Protocol, test: TestSet, pipeline: str, kind: str, why: str) -> dict[str, Any]:
    """The row of a pipeline that could not run here (an optional peer not installed, no truth declared)."""
    return {
        "benchmark": protocol.name,
        "test": test.name,
        "kind": "peer" if kind == "peer" else "nlid",
        "pipeline": pipeline,
        "method": "",
        "model": "",
        "rmse": np.nan,
        "nrmse_percent": np.nan,
        "fit_percent": np.nan,
        "parameters": None,
        "seconds": None,
        "rule": "",
        "rule_applied": "",
        "rule_declared": test.rule,
        "scored_samples": None,
        "status": "skipped",
        "note": why,
        "data": "",
    }


def _where(record: Record) -> str:
    """Where a record was read from, with the data folder written as ``$NLID_DATA_DIR`` (no machine's path)."""
    import os

    source = str(record.meta.get("source", ""))
    folder = os.environ.get("NLID_DATA_DIR")
    if folder:
        root = str(Path(folder).expanduser().resolve())
        if source.startswith(root + os.sep):
            return "$NLID_DATA_DIR" + source[len(root) :]
    return source if not Path(source).is_absolute() else Path(source).name


def _model_text(fitted: Fitted, mass_unit: str = "kg") -> str:
    if fitted.kind == "peer":
        equations = list(getattr(fitted.model, "equations", []) or [])
        if fitted.pipeline == PEER:
            return f"{fitted.parameters} non-zero coefficients in (z', v')"
        return equations[0] if equations else ""
    fit = fitted.model
    how = "estimated" if fit.mass_estimated else "given"
    mass = f"m = {fit.mass:.4g} {mass_unit} ({how})" if fit.mass is not None else ""
    return ", ".join(fit.terms) + (f"; {mass}" if mass else "")


def _fit_dict(fitted: Fitted) -> dict[str, Any]:
    out = {
        "pipeline": fitted.pipeline,
        "kind": fitted.kind,
        "method": fitted.method,
        "parameters": fitted.parameters,
        "seconds": fitted.seconds,
        "choices": fitted.choices,
        "details": fitted.details,
    }
    out["prior"] = fitted.prior.to_row()
    if fitted.kind in ("nlid", TRUTH_KIND):  # the true system's coefficients are shown as a fit's
        fit = fitted.model
        se = fit.standard_errors or {}
        out["coefficients"] = {k: float(v) for k, v in fit.coefficients.items()}
        out["standard_errors"] = {k: (None if se.get(k) is None else float(se[k])) for k in fit.coefficients}
        out["mass"] = None if fit.mass is None else float(fit.mass)
        out["mass_estimated"] = bool(fit.mass_estimated)
        out["warnings"] = list(fit.warnings)
    return out


@dataclass(frozen=True)
class BenchRun:
    """A job as the study executors and the result store see it (:class:`nlid.study.job.Scheduled`)."""

    run_id: str
    spec: BenchJob
    digest: str

    @classmethod
    def of(cls, job: BenchJob) -> BenchRun:
        """The run of a job (its digest computed once)."""
        return cls(job.run_id, job, job.digest())
