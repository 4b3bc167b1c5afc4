"""Expanding a study into runs with stable ids and derived seeds.

A run is one dataset x model x identifier x repetition. Its id,
``dataset/model/identifier/rK``, does not depend on the order runs are listed
or executed in, and neither does its seed: the record of repetition ``K`` of a
simulated dataset is simulated with :func:`derive_seed` ``(study seed,
record_key)``, where :func:`record_key` names the preset, its overrides and
``K``, so every identifier and term set sees the same record (and datasets
that differ only in their noise level share the motion); the held-out record
uses ``record_key + "/holdout"``. Results are therefore identical whichever
executor ran the study and in whatever order.

Each run carries a ``spec``: plain JSON-able values saying everything a worker
process needs (the dataset entry, the terms, the identifier and its options,
the seeds, the time limit). Its digest tells whether a stored result still
belongs to the current configuration.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from typing import Any

from ..interface import to_jsonable
from .config import StudyConfig

__all__ = ["Run", "plan_study", "derive_seed", "record_key"]


def derive_seed(study_seed: int, key: str) -> int:
    """A 32-bit seed from the study seed and a stable key (SHA-256, order-independent)."""
    digest = hashlib.sha256(f"{int(study_seed)}:{key}".encode()).digest()
    return int.from_bytes(digest[:4], "little")


def record_key(preset: str, overrides: dict[str, Any], repetition: int) -> str:
    """The key of a simulated record: preset, overrides and repetition (not the noise, not the dataset name).

    Datasets simulating the same preset with the same overrides therefore
    share their records (force and noise streams, the noise scaled to each
    level): a noise sweep compares the levels on the same motion.
    """
    return f"{preset}:{json.dumps(to_jsonable(overrides), sort_keys=True)}/r{repetition}"


@dataclass(frozen=True)
class Run:
    """One identification of a study.

    Attributes
    ----------
    run_id
        ``dataset/model/identifier/rK``.
    spec
        What the worker needs (plain values).
    digest
        SHA-256 of ``spec`` without the time limit (first 16 hex digits).
    """

    run_id: str
    dataset: str
    model: str
    method: str
    repetition: int
    seed: int
    spec: dict[str, Any]
    digest: str


def plan_study(config: StudyConfig) -> list[Run]:
    """Every run of a study, in a stable order (dataset, model, identifier, repetition)."""
    runs = []
    for ds in config.datasets:
        data = ds.to_dict()
        for model in ds.models:
            for method in config.identifiers:
                over = ds.methods.get(method, {})
                options = {**config.options.get(method, {}), **over.get("options", {})}
                terms = over.get("terms", model.terms)
                without = over.get("without", model.without)
                px_roots = over.get("px_roots", model.px_roots)
                for rep in range(ds.repetitions):
                    key = record_key(ds.source, ds.overrides, rep)
                    seed = derive_seed(config.seed, key) if ds.simulated else None
                    holdout_seed = derive_seed(config.seed, f"{key}/holdout") if ds.simulated else None
                    run_id = f"{ds.name}/{model.name}/{method}/r{rep}"
                    spec = to_jsonable(
                        {
                            "run_id": run_id,
                            "study": config.name,
                            "dataset": data,
                            "model": model.name,
                            "terms": terms,
                            "without": without,
                            "px_roots": px_roots,
                            "method": method,
                            "options": options,
                            "repetition": rep,
                            "seed": seed,
                            "holdout_seed": holdout_seed,
                            "timeout": ds.timeout,
                            "posterior": config.posterior,
                        }
                    )
                    text = json.dumps({k: v for k, v in spec.items() if k != "timeout"}, sort_keys=True)
                    digest = hashlib.sha256(text.encode()).hexdigest()[:16]
                    runs.append(Run(run_id, ds.name, model.name, method, rep, seed or 0, spec, digest))
    return runs
