"""Reading and writing records: CSV, NPZ (never with pickle) and MATLAB .mat.

Column maps
-----------
A column map says which column (or variable) of a file becomes which channel,
optionally scaled: ``"f=vir*gtau, z=qm"`` or ``"f=-acc*0.265, z=disp/1000"``.
Files, pandas DataFrames, xarray Datasets and mappings of arrays share its
rules: a reader yields a table of named columns (:func:`read_table` for files)
and one function maps the columns to a record
(:meth:`Record.from_table <nlid.record.Record.from_table>`); the grammar and
the rules are in :mod:`nlid.columnmap` (:class:`ColumnExpr` and
:func:`parse_columns` are re-exported here).

Metadata sidecar
----------------
:func:`write_csv` and :func:`write_npz` also write ``<file>.meta.json`` with
the record's metadata that other tools cannot carry in a CSV column: how the
force was held between samples (``force_hold``), the mass and g, the source,
and for simulated records the truth, seed and noise. :func:`read_record` reads
it back when it is present (plain JSON; only the keys in :data:`META_KEYS` are
taken).
"""

from __future__ import annotations

import json
import reprlib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from .columnmap import ColumnExpr, frame_table, parse_columns
from .errors import DataError, InputError
from .interface import to_jsonable
from .outputs import META_KEYS, check_sidecar, sidecar_path
from .record import Record

__all__ = [
    "ColumnExpr",
    "parse_columns",
    "read_record",
    "read_table",
    "write_csv",
    "write_npz",
    "SUFFIXES",
    "META_KEYS",
    "sidecar_path",
]

#: File types understood by :func:`read_record`.
SUFFIXES = (".csv", ".txt", ".npz", ".mat")


def read_table(path: str | Path) -> dict[str, np.ndarray]:
    """Read every column/variable of a CSV, NPZ or MAT file into arrays.

    Raises
    ------
    DataError
        If the file is missing, unreadable or of an unknown type.
    """
    path = Path(path)
    if len(path.name) > 255 or len(str(path)) > 4095:  # longer than file systems allow (is_dir() would raise)
        raise DataError(f"cannot read {reprlib.repr(str(path))}: not a file name (too long)")
    if path.is_dir():
        raise DataError(f"{path} is a folder, not a data file")
    if not path.is_file():
        raise DataError(f"file not found: {path}" if not path.exists() else f"{path} is not a regular file")
    suffix = path.suffix.lower()
    try:
        if suffix in (".csv", ".txt"):
            import pandas as pd

            frame = pd.read_csv(
                path, sep=None if suffix == ".txt" else ",", engine="python" if suffix == ".txt" else "c"
            )
            return frame_table(frame, str(path))
        if suffix == ".npz":
            import zipfile

            if not zipfile.is_zipfile(path):
                raise DataError(f"cannot read {path}: not an NPZ (zip) archive")
            with np.load(path, allow_pickle=False) as data:
                return {k: np.asarray(data[k]) for k in data.files}
        if suffix == ".mat":
            from scipy import io as sio

            try:
                data = sio.loadmat(path)
            except NotImplementedError:
                raise DataError(f"{path}: MATLAB v7.3 (HDF5) files are not supported; save with -v7") from None
            return {
                k: np.asarray(v).squeeze() if np.asarray(v).ndim > 1 else np.asarray(v)
                for k, v in data.items()
                if not k.startswith("__")
            }
    except DataError:
        raise
    except ValueError as exc:
        if "pickle" in str(exc).lower():
            raise DataError(f"{path}: contains pickled objects, which nlid never loads") from None
        raise DataError(f"cannot read {path}: {exc}") from None
    except Exception as exc:  # noqa: BLE001 - any reader failure is a data error
        raise DataError(f"cannot read {path}: {type(exc).__name__}: {exc}") from None
    raise DataError(f"cannot read {path}: unknown file type {suffix!r} (use {', '.join(SUFFIXES)})")


def _read_sidecar(path: Path) -> dict[str, Any]:
    side = sidecar_path(path)
    if not side.is_file():
        return {}
    try:
        data = json.loads(side.read_text())
    except (OSError, ValueError, RecursionError) as exc:
        raise DataError(f"cannot read the metadata file {side}: {exc}") from None
    if not isinstance(data, dict):
        raise DataError(f"{side}: expected a JSON object")
    return {k: data[k] for k in META_KEYS if k in data}


def _write_sidecar(record: Record, path: Path) -> None:
    meta = {k: record.meta[k] for k in META_KEYS if k in record.meta}
    meta["force_hold"] = record.force_hold
    sidecar_path(path).write_text(json.dumps(to_jsonable(meta), indent=1, allow_nan=False) + "\n")


def read_record(
    path: str | Path,
    columns: str | Mapping[str, str] | None = None,
    *,
    fs: float | None = None,
    meta: Mapping[str, Any] | None = None,
    units: Mapping[str, str] | None = None,
) -> Record:
    """Read a record from a CSV, NPZ or MAT file.

    Parameters
    ----------
    path
        The file.
    columns
        Column map (see module docstring); unmapped channels are taken from
        same-named columns.
    fs
        Sampling frequency in Hz when the file has no time column.
    meta, units
        Passed to :class:`~nlid.record.Record`.

    Raises
    ------
    DataError
        For a missing file or column, a non-numeric or non-finite value, a
        non-uniform time axis, or a missing sampling frequency.
    """
    path = Path(path)
    table = read_table(path)
    meta = {"source": str(path), **_read_sidecar(path), **dict(meta or {})}
    return Record.from_table(table, columns, fs=fs, meta=meta, units=units, source=path)


def write_csv(record: Record, path: str | Path, channels: tuple[str, ...] | None = None) -> Path:
    """Write ``t`` and the channels to CSV (12 significant digits), and the metadata sidecar.

    Parameters
    ----------
    channels
        Channels to write (default: all present). ``t`` is always first.
    """
    import pandas as pd

    channels = channels or record.channels
    missing = [c for c in channels if getattr(record, c, None) is None]
    if missing:
        raise InputError(f"record has no channel {missing[0]!r}")
    frame = pd.DataFrame({"t": record.t, **{c: getattr(record, c) for c in channels}})
    path = Path(path)
    check_sidecar(path)
    frame.to_csv(path, index=False, float_format="%.12g")
    _write_sidecar(record, path)
    return path


def write_npz(record: Record, path: str | Path) -> Path:
    """Write the channels, ``t`` and ``fs`` to an NPZ file (no pickled objects), and the metadata sidecar."""
    path = Path(path)
    check_sidecar(path)
    arrays = {c: getattr(record, c) for c in record.channels}
    np.savez(path, t=record.t, fs=np.array(record.fs), **arrays)
    _write_sidecar(record, path)
    return path
