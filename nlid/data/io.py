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
(:meth:`Record.from_table <nlid.data.record.Record.from_table>`); the grammar and
the rules are in :mod:`nlid.data.columnmap` (:class:`ColumnExpr` and
:func:`parse_columns` are re-exported here).

Several degrees of freedom
--------------------------
A column map naming indexed channels (``z1=``, ``f1=``...), or a file with
columns ``z1``, ``z2``... and no ``z``, is read as a
record of indexed channels (:mod:`nlid.data.columnmap`); the writers
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
from typing import Any

import numpy as np

from ..base.jsonable import to_jsonable
from ..errors import DataError, InputError
from ..runtime.outputs import META_KEYS, check_sidecar, sidecar_path
from .columnmap import uses_indexed
from .filetables import SizeError, open_file_table, size_text
from .record import Record

__all__ = [
    "read_record",
    "read_table",
    "open_table",
    "check_path",
    "read_text_file",
    "TEXT_LIMIT",
    "file_sha256",
    "write_csv",
    "write_npz",
    "SUFFIXES",
]

#: Largest configuration or JSON file nlid reads (a study, a benchmark file, a model JSON, a sidecar): 64 MiB.
TEXT_LIMIT = 64 << 20
#: File types understood by :func:`read_record`.
SUFFIXES = (".csv", ".txt", ".npz", ".mat", ".h5", ".hdf5", ".parquet", ".pq")


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
    with open_table(path) as table:
        for name in table:
            try:
                out[name] = np.asarray(table[name])
            except SizeError:
                raise
            except DataError:  # not an array (a sparse matrix, a MATLAB object)
                continue
    return out


@contextlib.contextmanager
def open_table(path: str | Path) -> Iterator[Mapping[str, Any]]:
    """The table of a data file, open while the ``with`` block runs (:mod:`nlid.data.filetables`).

    MATLAB, NPZ, HDF5 and Parquet files are read lazily: a variable is read
    when it is asked for, and only if the file holds the bytes it declares;
    the table's ``shape_of(name)`` gives the shape a variable declares
    without reading it. The path goes through :func:`check_path`.

    Raises
    ------
    DataError
        If the file is missing, not a regular file, unreadable or of an
        unknown type, or needs an optional package that is not installed.
    """
    path = check_path(path)
    handle: Any = None
    try:
        handle, table = open_file_table(path, SUFFIXES)
    except DataError:
        raise
    except ValueError as exc:
        if "pickle" in str(exc).lower():
            raise DataError(f"{path}: contains pickled objects, which nlid never loads") from None
        raise DataError(f"cannot read {path}: {exc}") from None
    except Exception as exc:  # noqa: BLE001 - any reader failure is a data error
        raise DataError(f"cannot read {path}: {type(exc).__name__}: {exc}") from None
    try:
        yield _Reading(table, path)
    finally:
        if handle is not None:
            handle.close()


class _Reading(Mapping):
    """A file's table whose reads turn a reader's own failure into one :class:`DataError` naming the file."""

    def __init__(self, table: Mapping[str, Any], path: Path) -> None:
        self.table, self.path = table, path

    def shape_of(self, key: str) -> tuple[int, ...] | None:
        """The shape ``key`` declares, without reading it (``None``: not an array)."""
        shape_of = getattr(self.table, "shape_of", None)
        return shape_of(key) if shape_of is not None else np.shape(self.table[key])

    def __getitem__(self, key: str) -> Any:
        try:
            return self.table[key]
        except (DataError, KeyError, MemoryError):
            raise
        except ValueError as exc:
            if "pickle" in str(exc).lower():
                raise DataError(f"{self.path}: contains pickled objects, which nlid never loads") from None
            raise DataError(f"cannot read {key!r} from {self.path}: {exc}") from None
        except Exception as exc:  # noqa: BLE001 - any reader failure is a data error
            raise DataError(f"cannot read {key!r} from {self.path}: {type(exc).__name__}: {exc}") from None

    def __contains__(self, key: object) -> bool:
        return key in self.table

    def __iter__(self) -> Iterator[str]:
        return iter(self.table)

    def __len__(self) -> int:
        return len(self.table)


def _kind(path: Path) -> str:
    """What a path that is neither a file nor a folder is: ``"a named pipe (FIFO)"``, ``"a device"``..."""
    import stat

    try:
        mode = path.stat().st_mode
    except OSError:
        return "not a regular file"
    if stat.S_ISFIFO(mode):
        return "a named pipe (FIFO)"
    if stat.S_ISSOCK(mode):
        return "a socket"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    return "not a regular file"


def check_path(path: str | Path, *, what: str = "data file", max_bytes: int | None = None) -> Path:
    """The one check of every path a user names for nlid to read: a regular file, of a sane name and size.

    Folders, FIFOs, sockets and devices (``/dev/zero``) are refused: reading
    them would hang or never end. Symbolic links are followed.

    Parameters
    ----------
    path
        The path as given.
    what
        What the file is, for the messages (``"data file"``, ``"model JSON"``).
    max_bytes
        Largest size accepted (``None``: any; data files are bounded by their readers).

    Raises
    ------
    DataError
        A name longer than file systems allow, a missing path, a folder, a
        special file or a file larger than ``max_bytes``.
    """
    path = Path(path)
    if len(path.name) > 255 or len(str(path)) > 4095:  # longer than file systems allow (is_dir() would raise)
        raise DataError(f"cannot read {reprlib.repr(str(path))}: not a file name (too long)")
    try:
        is_dir, is_file = path.is_dir(), path.is_file()
    except OSError as exc:
        raise DataError(f"cannot read {path}: {exc.strerror or exc}") from None
    if is_dir:
        raise DataError(f"{path} is a folder, not a {what}")
    if not is_file:
        if not path.exists():
            broken = " (a symbolic link to a missing file)" if path.is_symlink() else ""
            raise DataError(f"file not found: {path}{broken}")
        raise DataError(f"{path} is {_kind(path)}, not a {what}: nlid reads only regular files")
    if max_bytes is not None:
        size = path.stat().st_size
        if size > max_bytes:
            raise DataError(f"{path} is {size_text(size)}; a {what} is at most {size_text(max_bytes)}")
    return path


def read_text_file(path: str | Path, what: str) -> str:
    """The UTF-8 text of a small file the user named (a study, a benchmark file, a JSON), after :func:`check_path`.

    Raises
    ------
    DataError
        Not a regular file, larger than :data:`TEXT_LIMIT`, unreadable, or not UTF-8 text.
    """
    checked = check_path(path, what=what, max_bytes=TEXT_LIMIT)
    try:
        return checked.read_text(encoding="utf-8")
    except OSError as exc:
        raise DataError(f"cannot read the {what} {checked}: {exc.strerror or exc}") from None
    except UnicodeDecodeError as exc:
        raise DataError(f"the {what} {checked} is not UTF-8 text (byte {exc.start})") from None


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
        data = json.loads(read_text_file(side, "metadata file"))
    except DataError:
        raise
    except (ValueError, RecursionError) as exc:
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
    """Read a record from a CSV, NPZ, MAT (v7.3 included), HDF5 or Parquet file.

    A column map with indexed channels (``z1=``...), or a file with columns
    ``z1``, ``z2``... and no ``z``, gives a record of indexed channels (:attr:`Record.indexed`).

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
        Passed to :class:`~nlid.data.record.Record`.
    units
        The unit of each channel, ``{"z": "mm"}`` (:mod:`nlid.data.units`);
        converted to SI.

    Returns
    -------
    Record
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
    with open_table(path) as table:
        side = _read_sidecar(path)
        if "force_hold" in side:  # the assumption every summary states, with where it came from
            side["force_hold_source"] = f"the sidecar {sidecar_path(path).name}"
        meta = {"source": str(path), **side, **dict(meta or {})}
        meta["loaded"] = {**dict(meta.get("loaded") or {}), "sha256": file_sha256(path)}
        indexed = uses_indexed(table, columns)
        return Record.from_table(table, columns, fs=fs, meta=meta, units=units, source=path, indexed=indexed)


def _columns_of(record: Record, channels: tuple[str, ...] | None) -> dict[str, np.ndarray]:
    """The named channels of a record; for a structure, ``"z"`` names every DOF's (``z1``, ``z2``...)."""
    if record.indexed:
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


def write_csv(record: Record, path: str | Path, channels: tuple[str, ...] | None = None) -> Path:
    """Write ``t`` and the channels to CSV (12 significant digits), and the metadata sidecar.

    Parameters
    ----------
    channels
        Channels to write (default: all present). ``t`` is always first. For
        an indexed record, ``"z"`` writes ``z1``, ``z2``...
        and ``"f"`` the forces of the driven DOFs; single channels (``"a2"``) are named as such.
    """
    import pandas as pd

    frame = pd.DataFrame({"t": record.t, **_columns_of(record, channels)})
    path = Path(path)
    check_sidecar(path)
    frame.to_csv(path, index=False, float_format="%.12g")
    _write_sidecar(record, path)
    return path


def write_npz(record: Record, path: str | Path) -> Path:
    """Write the channels, ``t`` and ``fs`` to an NPZ file (no pickled objects), and the metadata sidecar."""
    path = Path(path)
    check_sidecar(path)
    arrays = _columns_of(record, None)
    np.savez(path, t=record.t, fs=np.array(record.fs), **arrays)
    _write_sidecar(record, path)
    return path
