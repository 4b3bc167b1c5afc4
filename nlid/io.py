"""Reading and writing records: CSV, NPZ (never with pickle), MATLAB .mat (v4 to v7.3), HDF5 and Parquet.

File types
----------
==========================  ==========================================================================
``.csv``, ``.txt``          a header row of column names (``.txt``: any delimiter), read with pandas
``.npz``                    numpy arrays, read without pickle
``.mat`` (v4 to v7)         MATLAB variables, read with scipy
``.mat`` (v7.3)             MATLAB's HDF5 format, read with h5py (optional: ``pip install 'nlid[hdf5]'``);
                            arrays are turned back from HDF5's row-major order to MATLAB's shape, and
                            a struct's fields are named ``s/field``
``.h5``, ``.hdf5``          every dataset is a column, named by its path without the leading ``/``
                            (``disp``, ``data/disp``), read with h5py (``nlid[hdf5]``); only the
                            datasets a column map uses are read
``.parquet``, ``.pq``       the columns of a Parquet file, read with pyarrow (``nlid[parquet]``)
==========================  ==========================================================================

A missing optional package is one :class:`~nlid.errors.DataError` line naming
the extra to install. Text, cell arrays, structs, sparse and complex arrays
are refused when a column map uses them, with what they hold.

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

Several degrees of freedom
--------------------------
A column map naming indexed channels (``z1=``, ``f1=``...), or a file with
columns ``z1``, ``z2``... and no ``z``, is read as a
:class:`~nlid.mdof.StructureRecord` (:mod:`nlid.columnmap`); the writers
write its channels ``f1``, ``z1``, ``z2``... the same way, so a written
structure record reads back as one.

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

import contextlib
import hashlib
import json
import reprlib
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .columnmap import ColumnExpr, frame_table, parse_columns, uses_indexed
from .errors import DataError, InputError
from .interface import to_jsonable
from .outputs import META_KEYS, check_sidecar, sidecar_path
from .record import Record

if TYPE_CHECKING:  # pragma: no cover
    from .mdof.record import StructureRecord

__all__ = [
    "ColumnExpr",
    "parse_columns",
    "read_record",
    "read_table",
    "file_sha256",
    "write_csv",
    "write_npz",
    "SUFFIXES",
    "META_KEYS",
    "sidecar_path",
]

#: File types understood by :func:`read_record`.
SUFFIXES = (".csv", ".txt", ".npz", ".mat", ".h5", ".hdf5", ".parquet", ".pq")
_HDF5 = (".h5", ".hdf5")
_PARQUET = (".parquet", ".pq")


def read_table(path: str | Path) -> dict[str, np.ndarray]:
    """Read every column/variable of a CSV, NPZ, MAT, HDF5 or Parquet file into arrays.

    Variables of an HDF5 or MATLAB v7.3 file that are not arrays (sparse
    matrices, MATLAB objects) are left out; :func:`read_record` names them
    when a column map uses them.

    Raises
    ------
    DataError
        If the file is missing, unreadable or of an unknown type, or needs an
        optional package that is not installed.
    """
    out = {}
    with _open_table(path) as table:
        for name in table:
            try:
                out[name] = np.asarray(table[name])
            except DataError:
                continue
    return out


@contextlib.contextmanager
def _open_table(path: str | Path) -> Iterator[Mapping[str, Any]]:
    """The table of a file; for HDF5 files a lazy one, open while the ``with`` block runs."""
    path = _check_path(path)
    handle: Any = None
    try:
        handle, table = _read(path)
    except DataError:
        raise
    except ValueError as exc:
        if "pickle" in str(exc).lower():
            raise DataError(f"{path}: contains pickled objects, which nlid never loads") from None
        raise DataError(f"cannot read {path}: {exc}") from None
    except Exception as exc:  # noqa: BLE001 - any reader failure is a data error
        raise DataError(f"cannot read {path}: {type(exc).__name__}: {exc}") from None
    try:
        yield table
    finally:
        if handle is not None:
            handle.close()


def _read(path: Path) -> tuple[Any, Mapping[str, Any]]:
    """``(open file handle or None, table)`` of a file, by its suffix."""
    suffix = path.suffix.lower()
    if suffix in (".csv", ".txt"):
        import pandas as pd

        frame = pd.read_csv(path, sep=None if suffix == ".txt" else ",", engine="python" if suffix == ".txt" else "c")
        return None, frame_table(frame, str(path))
    if suffix == ".npz":
        import zipfile

        if not zipfile.is_zipfile(path):
            raise DataError(f"cannot read {path}: not an NPZ (zip) archive")
        with np.load(path, allow_pickle=False) as data:
            return None, {k: np.asarray(data[k]) for k in data.files}
    if suffix == ".mat":
        from scipy import io as sio

        try:
            data = sio.loadmat(path)
        except NotImplementedError:  # v7.3: HDF5
            return _open_hdf5(path, "MATLAB v7.3 (HDF5) .mat files")
        return None, {
            k: np.asarray(v).squeeze() if np.asarray(v).ndim > 1 else np.asarray(v)
            for k, v in data.items()
            if not k.startswith("__")
        }
    if suffix in _HDF5:
        return _open_hdf5(path, "HDF5 files")
    if suffix in _PARQUET:
        try:
            import pyarrow.parquet as pq
        except ImportError:
            raise DataError(
                f"cannot read {path}: Parquet files need the optional package pyarrow (pip install 'nlid[parquet]')"
            ) from None
        return None, frame_table(pq.read_table(path).to_pandas(), str(path))
    raise DataError(f"cannot read {path}: unknown file type {suffix!r} (use {', '.join(SUFFIXES)})")


def _open_hdf5(path: Path, what: str) -> tuple[Any, Mapping[str, Any]]:
    try:
        import h5py
    except ImportError:
        raise DataError(
            f"cannot read {path}: {what} need the optional package h5py (pip install 'nlid[hdf5]')"
        ) from None
    handle = h5py.File(path, "r")
    try:
        return handle, _HDF5Table(handle, str(path))
    except BaseException:
        handle.close()
        raise


def _check_path(path: str | Path) -> Path:
    path = Path(path)
    if len(path.name) > 255 or len(str(path)) > 4095:  # longer than file systems allow (is_dir() would raise)
        raise DataError(f"cannot read {reprlib.repr(str(path))}: not a file name (too long)")
    if path.is_dir():
        raise DataError(f"{path} is a folder, not a data file")
    if not path.is_file():
        raise DataError(f"file not found: {path}" if not path.exists() else f"{path} is not a regular file")
    return path


#: MATLAB classes whose values are numbers (``char`` is text, ``cell`` references; others are objects).
_MATLAB_NUMERIC = frozenset(
    ("double", "single", "logical", "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64", "uint64")
)
#: Groups of a MATLAB v7.3 file that hold MATLAB's own bookkeeping, not variables.
_MATLAB_INTERNAL = ("#refs#", "#subsystem#")


def _attr(obj: Any, name: str) -> Any:
    value = obj.attrs.get(name)
    return value.decode() if isinstance(value, bytes) else value


class _HDF5Table(Mapping):
    """The datasets of an open HDF5 file (a MATLAB v7.3 file among them), read when asked for.

    Keys are paths without the leading ``/``. A dataset with a ``MATLAB_class``
    attribute is MATLAB's: transposed back to MATLAB's shape, text decoded,
    and a struct's fields keyed ``struct/field``.
    """

    def __init__(self, handle: Any, source: str) -> None:
        import h5py

        self._source = source
        self._items: dict[str, Any] = {}
        skip = list(_MATLAB_INTERNAL)  # and the insides of sparse matrices

        def visit(name: str, obj: Any) -> None:
            if any(name == k or name.startswith(k + "/") for k in skip):
                return
            if isinstance(obj, h5py.Dataset):
                self._items[name] = obj
            elif _attr(obj, "MATLAB_sparse") is not None:
                self._items[name] = obj
                skip.append(name)

        handle.visititems(visit)

    def __getitem__(self, key: str) -> np.ndarray:
        return _read_dataset(self._items[key], key, self._source)

    def __contains__(self, key: object) -> bool:
        return key in self._items

    def __iter__(self) -> Iterator[str]:
        return iter(self._items)

    def __len__(self) -> int:
        return len(self._items)


def _read_dataset(obj: Any, name: str, source: str) -> np.ndarray:
    """One dataset as an array in the orientation its writer meant (MATLAB's arrays transposed back)."""
    import h5py

    matlab = _attr(obj, "MATLAB_class")
    if _attr(obj, "MATLAB_sparse") is not None:
        raise DataError(f"variable {name!r} in {source} is a sparse matrix; save it with full() first")
    if not isinstance(obj, h5py.Dataset):
        raise DataError(f"{name!r} in {source} is not an array")
    if _attr(obj, "MATLAB_empty"):
        return np.zeros(0)
    if h5py.check_dtype(ref=obj.dtype) is not None:
        return np.empty(obj.shape, dtype=object)  # a cell array (references): refused as objects when used
    if h5py.check_string_dtype(obj.dtype) is not None:
        return np.asarray(obj.asstr()[()], dtype=str)
    if matlab is not None and matlab not in _MATLAB_NUMERIC and matlab != "char":
        raise DataError(f"variable {name!r} in {source} is a MATLAB {matlab}, not an array of numbers")
    data = np.asarray(obj[()])
    if data.dtype.names and {"real", "imag"} <= set(data.dtype.names):
        data = data["real"] + 1j * data["imag"]
    if matlab is None:
        return data
    data = data.T  # MATLAB writes column-major arrays: HDF5 holds them transposed
    if matlab == "char":
        return np.asarray("".join(map(chr, data.ravel(order="F"))))
    if matlab == "logical":
        return data.astype(bool)
    return data


def file_sha256(path: str | Path) -> str:
    """The SHA-256 of a file's bytes, as hexadecimal (what a model's provenance records for its data file)."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


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


def _write_sidecar(record: Record | StructureRecord, path: Path) -> None:
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
) -> Record | StructureRecord:
    """Read a record from a CSV, NPZ, MAT (v7.3 included), HDF5 or Parquet file.

    A column map with indexed channels (``z1=``...), or a file with columns
    ``z1``, ``z2``... and no ``z``, gives a :class:`~nlid.mdof.StructureRecord`.

    Parameters
    ----------
    path
        The file.
    columns
        Column map (see module docstring); unmapped channels are taken from
        same-named columns. A channel may carry its unit: ``z[mm]=disp``.
    fs
        Sampling frequency in Hz when the file has no time column.
    meta
        Passed to :class:`~nlid.record.Record`.
    units
        The unit of each channel, ``{"z": "mm"}`` (:mod:`nlid.units`);
        converted to SI.

    Returns
    -------
    Record or StructureRecord
        With ``meta["loaded"]``: the path, the file's SHA-256, the column map
        and ``fs=`` as given.

    Raises
    ------
    DataError
        For a missing file or column, a non-numeric or non-finite value, a
        non-uniform time axis, or a missing sampling frequency.
    InputError
        A malformed column map, or a unit outside the vocabulary.
    """
    path = Path(path)
    with _open_table(path) as table:
        meta = {"source": str(path), **_read_sidecar(path), **dict(meta or {})}
        meta["loaded"] = {**dict(meta.get("loaded") or {}), "sha256": file_sha256(path)}
        if uses_indexed(table, columns):
            from .mdof.record import StructureRecord

            return StructureRecord.from_table(table, columns, fs=fs, meta=meta, units=units, source=path)
        return Record.from_table(table, columns, fs=fs, meta=meta, units=units, source=path)


def _columns_of(record: Record | StructureRecord, channels: tuple[str, ...] | None) -> dict[str, np.ndarray]:
    """The named channels of a record; for a structure, ``"z"`` names every DOF's (``z1``, ``z2``...)."""
    if not isinstance(record, Record):
        names = []
        for c in channels or record.channels:
            names += [n for n in record.channels if n.rstrip("0123456789") == c] if c in ("f", "z", "v", "a") else [c]
        missing = [c for c in (channels or ()) if c in ("v", "a") and getattr(record, c) is None]
        if missing:
            raise InputError(f"record has no channel {missing[0]!r}")
        return {n: record.channel(n) for n in dict.fromkeys(names)}
    channels = channels or record.channels
    missing = [c for c in channels if getattr(record, c, None) is None]
    if missing:
        raise InputError(f"record has no channel {missing[0]!r}")
    return {c: getattr(record, c) for c in channels}


def write_csv(record: Record | StructureRecord, path: str | Path, channels: tuple[str, ...] | None = None) -> Path:
    """Write ``t`` and the channels to CSV (12 significant digits), and the metadata sidecar.

    Parameters
    ----------
    channels
        Channels to write (default: all present). ``t`` is always first. For
        a :class:`~nlid.mdof.StructureRecord`, ``"z"`` writes ``z1``, ``z2``...
        and ``"f"`` the forces of the driven DOFs; single channels (``"a2"``) are named as such.
    """
    import pandas as pd

    frame = pd.DataFrame({"t": record.t, **_columns_of(record, channels)})
    path = Path(path)
    check_sidecar(path)
    frame.to_csv(path, index=False, float_format="%.12g")
    _write_sidecar(record, path)
    return path


def write_npz(record: Record | StructureRecord, path: str | Path) -> Path:
    """Write the channels, ``t`` and ``fs`` to an NPZ file (no pickled objects), and the metadata sidecar."""
    path = Path(path)
    check_sidecar(path)
    arrays = _columns_of(record, None)
    np.savez(path, t=record.t, fs=np.array(record.fs), **arrays)
    _write_sidecar(record, path)
    return path
