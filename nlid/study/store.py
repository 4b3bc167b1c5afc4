"""Persisted study results: one JSON file per finished run, written atomically.

Layout of a study's output folder::

    study.toml            the configuration as run
    runs/<run>.json       one finished run: spec digest, row, result, reference
    arrays/<run>.npz      the result's arrays (singular values, FRF, ...), if any
    results.csv           every row (rebuilt from runs/ by :meth:`ResultStore.results`)

A run's JSON is written to a temporary file in the same folder, flushed to
disk and renamed over the final name (atomic on POSIX), after its arrays: a
killed study loses at most the runs in flight, never leaves half a file, and
a run counts as done only when its JSON exists with the digest of the current
spec (so a changed configuration re-runs what it changed). A temporary file
is removed when the write fails or is interrupted, and one a killed study
left is removed by the next run (:func:`nlid.runtime.outputs.sweep_temporary`).
"""

from __future__ import annotations

import hashlib
import json
import os
import re
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..base.jsonable import to_jsonable
from ..errors import InputError
from ..runtime.outputs import atomic_write, temporary

if TYPE_CHECKING:
    import pandas as pd

    from .job import Scheduled

__all__ = ["ResultStore", "safe_name", "INFRASTRUCTURE"]

#: Key of a payload set when nlid's own machinery failed under the run (its fork server died): such a payload is
#: not stored, so the run counts as not done and a resume runs it again.
INFRASTRUCTURE = "infrastructure"

_UNSAFE = re.compile(r"[^A-Za-z0-9_.+-]+")


def safe_name(run_id: str) -> str:
    """A file name for a run id (readable, with a short hash against collisions)."""
    readable = _UNSAFE.sub("_", run_id.replace("/", "__"))
    return f"{readable}-{hashlib.sha256(run_id.encode()).hexdigest()[:8]}"


def _atomic_write(path: Path, data: bytes) -> None:
    atomic_write(path, data)  # a temporary file renamed over it; removed on an error or a signal


class ResultStore:
    """The output folder of a study.

    Parameters
    ----------
    folder
        Created if missing.
    """

    def __init__(self, folder: str | os.PathLike[str]) -> None:
        self.folder = Path(folder)
        self.runs_dir = self.folder / "runs"
        self.arrays_dir = self.folder / "arrays"
        try:
            self.runs_dir.mkdir(parents=True, exist_ok=True)
            self.arrays_dir.mkdir(exist_ok=True)
        except OSError as exc:
            raise InputError(f"cannot create the output folder {self.folder}: {exc.strerror}") from None

    def path(self, run_id: str) -> Path:
        """The JSON file of a run."""
        return self.runs_dir / f"{safe_name(run_id)}.json"

    def load(self, run_id: str) -> dict[str, Any] | None:
        """The stored record of a run, or ``None``."""
        path = self.path(run_id)
        if not path.is_file():
            return None
        try:
            return json.loads(path.read_text())
        except (OSError, ValueError, RecursionError):
            return None

    def is_done(self, run: Scheduled) -> bool:
        """True if the run is stored with the digest of its current spec."""
        stored = self.load(run.run_id)
        return stored is not None and stored.get("digest") == run.digest

    def save(self, run: Scheduled, payload: dict[str, Any]) -> bool:
        """Persist a finished run (arrays first, then the JSON that marks it done); ``False`` when not stored.

        A payload marked :data:`INFRASTRUCTURE` (nlid's fork server died under the run) is not stored: the
        run is not the identifier's failure, and a resume runs it again.
        """
        if payload.get(INFRASTRUCTURE):
            return False
        arrays = payload.get("arrays") or {}
        name = safe_name(run.run_id)
        if arrays:
            npz = self.arrays_dir / f"{name}.npz"
            with temporary(npz, ".npz") as tmp:
                np.savez(tmp, **{k: np.asarray(v) for k, v in arrays.items()})
                os.replace(tmp, npz)
        record = {
            "run_id": run.run_id,
            "digest": run.digest,
            "row": payload["row"],
            "result": payload.get("result"),
            "reference": payload.get("reference"),
            "arrays": sorted(arrays),
            "traceback": payload.get("traceback"),
        }
        text = json.dumps(to_jsonable(record), allow_nan=False, indent=1)
        _atomic_write(self.path(run.run_id), text.encode())
        return True

    def records(self, runs: Iterable[Scheduled]) -> list[dict[str, Any]]:
        """Stored records of the given runs (in their order), skipping missing or stale ones."""
        return self.snapshot(runs)[0]

    def snapshot(self, runs: Iterable[Scheduled]) -> tuple[list[dict[str, Any]], list[str]]:
        """The stored records of the given runs (as :meth:`records`) and a digest of each record's file.

        Each file is read once; the digests (SHA-256 of the file's bytes) say whether anything a report
        shows changed since it was written (:func:`nlid.study.report.report_digest`).
        """
        records, digests = [], []
        for run in runs:
            try:
                data = self.path(run.run_id).read_bytes()
                stored = json.loads(data)
            except (OSError, ValueError, RecursionError):
                continue
            if isinstance(stored, dict) and stored.get("digest") == run.digest:
                records.append(stored)
                digests.append(hashlib.sha256(data).hexdigest())
        return records, digests

    def arrays(self, run_id: str) -> dict[str, np.ndarray]:
        """The stored arrays of a run (empty if none)."""
        path = self.arrays_dir / f"{safe_name(run_id)}.npz"
        if not path.is_file():
            return {}
        with np.load(path, allow_pickle=False) as npz:
            return {k: npz[k] for k in npz.files}

    def results(self, runs: Iterable[Scheduled]) -> pd.DataFrame:
        """Every stored row of the given runs as a table (plan order)."""
        import pandas as pd  # not for a study that only reads its store

        rows = [r["row"] for r in self.records(runs)]
        frame = pd.DataFrame(rows)
        return frame

    def write_results(self, runs: Iterable[Scheduled], frame: pd.DataFrame | None = None) -> Path:
        """Write ``results.csv`` (``frame``: the runs' rows when the caller has them) and return its path."""
        frame = self.results(runs) if frame is None else frame
        path = self.folder / "results.csv"
        _atomic_write(path, frame.to_csv(index=False).encode())
        return path

    def write_text(self, path: str | os.PathLike[str], text: str) -> None:
        """Write an output file of the study atomically (a killed writer leaves the old file)."""
        _atomic_write(Path(path), text.encode("utf-8"))
