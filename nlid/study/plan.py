"""Expanding a study into runs with stable ids, derived seeds and frozen run specs.

A run is one dataset x model x identifier x repetition. Its id,
``dataset/model/identifier/rK``, does not depend on the order runs are listed
or executed in, and neither does its seed: the record of repetition ``K`` of a
simulated dataset is simulated with :func:`derive_seed` ``(study seed,
record_key)``, where :func:`record_key` names the preset, its overrides and
``K``, so every identifier and term set sees the same record (and datasets
that differ only in their noise level share the motion); the held-out record
uses ``record_key + "/holdout"``. Results are therefore identical whichever
executor ran the study and in whatever order.

Each run carries a :class:`RunSpec`: a frozen value (a :class:`~nlid.study.job.Job`
the worker runs) saying everything a worker process needs (the typed dataset entry, the terms, the identifier and
its options, the seeds, the time limit). It crosses process boundaries as
itself (pickled by :mod:`nlid.runtime.isolation` and Dask, all plain frozen
dataclasses) or as JSON (:meth:`RunSpec.to_dict` / :meth:`RunSpec.from_dict`,
the layout of the stored run). Its digest tells whether a stored
result still belongs to the current configuration.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from ..base.frozen import FrozenDict, freeze
from ..base.jsonable import to_jsonable
from .config import DatasetConfig, StudyConfig
from .run import execute_spec, spec_failure

__all__ = ["Run", "RunSpec", "plan_study", "derive_seed", "record_key"]


def derive_seed(study_seed: int, key: str) -> int:
    """A 32-bit seed from the study seed and a stable key (SHA-256, order-independent)."""
    digest = hashlib.sha256(f"{int(study_seed)}:{key}".encode()).digest()
    return int.from_bytes(digest[:4], "little")


def record_key(preset: str, overrides: Mapping[str, Any], repetition: int) -> str:
    """The key of a simulated record: preset, overrides and repetition (not the noise, not the dataset name).

    Datasets simulating the same preset with the same overrides therefore
    share their records (force and noise streams, the noise scaled to each
    level): a noise sweep compares the levels on the same motion.
    """
    return f"{preset}:{json.dumps(to_jsonable(dict(overrides)), sort_keys=True)}/r{repetition}"


@dataclass(frozen=True)
class RunSpec:
    """Everything a worker needs to execute one run (frozen).

    Attributes
    ----------
    run_id
        ``dataset/model/identifier/rK``.
    study
        The study's name.
    dataset
        The typed dataset entry (:class:`~nlid.study.config.DatasetConfig`).
    model
        The term set's name; ``terms``, ``without``, ``px_roots`` say what it is
        (after the identifier's overrides).
    method, options
        The identifier and its options.
    repetition, seed, holdout_seed
        Which record (``seed`` is ``None`` for measured data).
    timeout
        Seconds before the run is stopped.
    posterior
        The ``[posterior]`` settings, or ``None``.
    response
        The ``[response]`` settings, or ``None`` (not part of the digest when ``None``: the runs of a
        study without it keep their digests).
    """

    run_id: str
    study: str
    dataset: DatasetConfig
    model: str
    terms: str
    without: str
    px_roots: tuple[float, float] | None
    method: str
    options: Mapping[str, Any] = field(default_factory=FrozenDict)
    repetition: int = 0
    seed: int | None = None
    holdout_seed: int | None = None
    timeout: float = 600.0
    posterior: Mapping[str, Any] | None = None
    response: Mapping[str, Any] | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "options", freeze(dict(self.options)))
        if self.posterior is not None:
            object.__setattr__(self, "posterior", freeze(dict(self.posterior)))
        if self.response is not None:
            object.__setattr__(self, "response", freeze(dict(self.response)))
        if self.px_roots is not None:
            object.__setattr__(self, "px_roots", (float(self.px_roots[0]), float(self.px_roots[1])))

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-able values (the layout the digest is computed from)."""
        response = {} if self.response is None else {"response": dict(self.response)}
        return to_jsonable(
            {
                "run_id": self.run_id,
                "study": self.study,
                "dataset": self.dataset.to_dict(),
                "model": self.model,
                "terms": self.terms,
                "without": self.without,
                "px_roots": self.px_roots,
                "method": self.method,
                "options": dict(self.options),
                "repetition": self.repetition,
                "seed": self.seed,
                "holdout_seed": self.holdout_seed,
                "timeout": self.timeout,
                "posterior": None if self.posterior is None else dict(self.posterior),
                **response,
            }
        )

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> RunSpec:
        """Inverse of :meth:`to_dict`."""
        roots = data.get("px_roots")
        return cls(
            run_id=data["run_id"],
            study=data["study"],
            dataset=DatasetConfig.from_dict(data["dataset"]),
            model=data["model"],
            terms=data["terms"],
            without=data["without"],
            px_roots=None if roots is None else (float(roots[0]), float(roots[1])),
            method=data["method"],
            options=data.get("options") or {},
            repetition=int(data["repetition"]),
            seed=data.get("seed"),
            holdout_seed=data.get("holdout_seed"),
            timeout=float(data["timeout"]),
            posterior=data.get("posterior"),
            response=data.get("response"),
        )

    def digest(self) -> str:
        """SHA-256 of the spec without the time limit (first 16 hex digits)."""
        text = json.dumps({k: v for k, v in self.to_dict().items() if k != "timeout"}, sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    # -- the job protocol (nlid.study.job.Job): what the worker calls
    @property
    def label(self) -> str:
        """How a failure message names the run: ``"identifier 'rfs'"``."""
        return f"identifier {self.method!r}"

    def execute(self, threads: int = 1) -> dict[str, Any]:
        """Identify and score the run in this process (:func:`nlid.study.run.execute_spec`; never raises)."""
        return execute_spec(self, threads)

    def failure(self, status: str, error: str) -> dict[str, Any]:
        """The payload of the run when it produced nothing (:func:`nlid.study.run.spec_failure`)."""
        return spec_failure(self, status, error)


@dataclass(frozen=True)
class Run:
    """One identification of a study.

    Attributes
    ----------
    run_id
        ``dataset/model/identifier/rK``.
    spec
        What the worker needs (:class:`RunSpec`).
    digest
        :meth:`RunSpec.digest`.
    """

    run_id: str
    dataset: str
    model: str
    method: str
    repetition: int
    seed: int
    spec: RunSpec
    digest: str


def plan_study(config: StudyConfig) -> list[Run]:
    """Every run of a study, in a stable order (dataset, model, identifier, repetition)."""
    runs = []
    for ds in config.datasets:
        for model in ds.models:
            for method in config.identifiers:
                over = ds.methods.get(method, {})
                options = {**config.options.get(method, {}), **over.get("options", {})}
                terms = over.get("terms", model.terms)
                without = over.get("without", model.without)
                px_roots = over.get("px_roots", model.px_roots)
                for rep in range(ds.repetitions):
                    seed = holdout_seed = None
                    if ds.simulated:
                        key = record_key(ds.source.name, ds.source.overrides, rep)  # type: ignore[union-attr]
                        seed = derive_seed(config.seed, key)
                        holdout_seed = derive_seed(config.seed, f"{key}/holdout")
                    spec = RunSpec(
                        run_id=f"{ds.name}/{model.name}/{method}/r{rep}",
                        study=config.name,
                        dataset=ds,
                        model=model.name,
                        terms=terms,
                        without=without,
                        px_roots=px_roots,
                        method=method,
                        options=options,
                        repetition=rep,
                        seed=seed,
                        holdout_seed=holdout_seed,
                        timeout=ds.timeout,
                        posterior=config.posterior,
                        response=config.response,
                    )
                    runs.append(Run(spec.run_id, ds.name, model.name, method, rep, seed or 0, spec, spec.digest()))
    return runs
