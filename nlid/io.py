"""Reading and writing records: CSV, NPZ (never with pickle) and MATLAB .mat.

Column maps
-----------
A column map says which column (or variable) of a file becomes which channel,
optionally scaled: ``"f=vir*gtau, z=qm"`` or ``"f=-acc*0.265, z=disp/1000"``.
Each entry is ``channel=expr`` with ``channel`` one of ``t, f, z, v, a`` and
``expr`` an optional leading ``-`` and a product/quotient of exactly one column
name with numbers or scalar variables of the file (a 1x1 MATLAB variable or an
NPZ scalar). It is parsed by a small grammar, never evaluated. Channels not in
the map are taken from columns of the same name when present.

The sampling frequency comes from the time column (checked for uniformity, see
:class:`nlid.record.Record`), else from ``fs=`` given by the caller, else from
a scalar ``fs`` variable in the file.

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
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .errors import DataError, InputError
from .interface import to_jsonable
from .record import CHANNELS, Record

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
_MAP_CHANNELS = ("t", *CHANNELS)
#: Metadata keys written to and read from the ``.meta.json`` sidecar.
META_KEYS = ("source", "force_hold", "mass", "g", "excitation", "preset", "seed", "noise", "reference", "truth")
_OPERAND = re.compile(r"\s*([A-Za-z_][A-Za-z_0-9]*|[0-9]*\.?[0-9]+(?:[eE][+-]?[0-9]+)?)\s*")


@dataclass(frozen=True)
class ColumnExpr:
    """``sign * column * prod(factors) / prod(divisors)``."""

    column: str
    factors: tuple[str | float, ...] = ()
    divisors: tuple[str | float, ...] = ()
    negate: bool = False

    def evaluate(self, table: Mapping[str, np.ndarray], source: str) -> np.ndarray:
        """Apply the expression to a table of columns/variables."""
        out = _real(_lookup(table, self.column, source, column=True), self.column, source, "column")
        if sum(1 for n in out.shape if n > 1) > 1:
            raise DataError(
                f"column {self.column!r} in {source} is an array of shape {out.shape}; a channel needs one dimension"
            )
        for factor in self.factors:
            out = out * _scalar(table, factor, source)
        for divisor in self.divisors:
            value = _scalar(table, divisor, source)
            if value == 0:
                raise InputError(f"column map divides {self.column!r} by zero")
            out = out / value
        return -out if self.negate else out


def _lookup(table: Mapping[str, np.ndarray], name: str, source: str, column: bool) -> np.ndarray:
    if name not in table:
        avail = ", ".join(sorted(table)) or "none"
        what = "column" if column else "variable"
        raise DataError(f"{what} {name!r} not found in {source}; it has: {avail}")
    return np.asarray(table[name])


def _real(value: Any, name: str, source: str, what: str) -> np.ndarray:
    """``value`` as a float array, refusing what is not real numbers (text, cells, structs, complex)."""
    array = np.asarray(value)
    kind = array.dtype.kind
    if kind == "c":
        raise DataError(f"{what} {name!r} in {source} holds complex numbers; nlid needs real ones (take .real or abs)")
    if kind not in "biuf":
        described = {"U": "text", "S": "text", "O": "objects (a cell array or strings)", "V": "a struct"}.get(
            kind, f"values of type {array.dtype}"
        )
        raise DataError(f"{what} {name!r} in {source} holds {described}, not numbers")
    return np.array(array, dtype=float)


def _scalar(table: Mapping[str, np.ndarray], item: str | float, source: str) -> float:
    if isinstance(item, float):
        return item
    value = _real(_lookup(table, item, source, column=False), item, source, "scale factor")
    if value.size != 1:
        raise DataError(f"{item!r} in {source} is used as a scale factor but has {value.size} values")
    return float(value.ravel()[0])


def parse_columns(spec: str | Mapping[str, str] | None) -> dict[str, ColumnExpr]:
    """Parse a column map such as ``"f=vir*gtau, z=qm"``.

    Raises
    ------
    InputError
        Naming the entry and what is wrong with it.
    """
    if not spec:
        return {}
    items = list(spec.items()) if isinstance(spec, Mapping) else []
    if isinstance(spec, str):
        for entry in spec.split(","):
            if not entry.strip():
                continue
            if "=" not in entry:
                raise InputError(f"column map entry {entry.strip()!r} must look like channel=column (e.g. f=vir*35.15)")
            key, expr = entry.split("=", 1)
            items.append((key, expr))
    out: dict[str, ColumnExpr] = {}
    for key, expr in items:
        channel = key.strip()
        if channel not in _MAP_CHANNELS:
            raise InputError(f"column map: unknown channel {channel!r}; channels are {', '.join(_MAP_CHANNELS)}")
        if channel in out:
            raise InputError(f"column map gives channel {channel!r} twice")
        out[channel] = _parse_expr(channel, str(expr))
    return out


def _parse_expr(channel: str, text: str) -> ColumnExpr:
    rest = text.strip()
    negate = rest.startswith("-")
    if negate:
        rest = rest[1:]
    operands: list[tuple[str, str | float]] = []
    op = "*"
    pos = 0
    while True:
        m = _OPERAND.match(rest, pos)
        if m is None or not m.group(1):
            raise InputError(
                f"column map entry {channel}={text.strip()!r}: expected a column name or a number "
                f"at character {pos + 1 + int(negate)}"
            )
        token = m.group(1)
        value: str | float = token if re.match(r"[A-Za-z_]", token) else float(token)
        operands.append((op, value))
        pos = m.end()
        if pos >= len(rest):
            break
        op = rest[pos]
        if op not in "*/":
            raise InputError(
                f"column map entry {channel}={text.strip()!r}: unexpected {op!r} (only * and / are allowed)"
            )
        pos += 1
    # The column is the first name; every other name is a scalar variable.
    names = [i for i, (o, v) in enumerate(operands) if isinstance(v, str) and o == "*"]
    if not names:
        raise InputError(f"column map entry {channel}={text.strip()!r} names no column")
    col_index = names[0]
    column = operands[col_index][1]
    factors = tuple(v for i, (o, v) in enumerate(operands) if o == "*" and i != col_index)
    divisors = tuple(v for o, v in operands if o == "/")
    return ColumnExpr(column=str(column), factors=factors, divisors=divisors, negate=negate)


def read_table(path: str | Path) -> dict[str, np.ndarray]:
    """Read every column/variable of a CSV, NPZ or MAT file into arrays.

    Raises
    ------
    DataError
        If the file is missing, unreadable or of an unknown type.
    """
    path = Path(path)
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
            out = {}
            for name in frame.columns:
                col = pd.to_numeric(frame[name], errors="coerce")
                bad = col.isna() & frame[name].notna()
                if bad.any():
                    i = int(np.argmax(bad.to_numpy()))
                    raise DataError(
                        f"{path}: column {name!r} has a non-numeric value {frame[name].iloc[i]!r} at row {i + 1}"
                    )
                out[str(name).strip()] = col.to_numpy(dtype=float)
            return out
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


def sidecar_path(path: str | Path) -> Path:
    """``<file>.meta.json`` beside a data file."""
    path = Path(path)
    return path.with_name(path.name + ".meta.json")


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


def _check_sidecar(path: Path) -> None:
    from .outputs import check_sidecar

    check_sidecar(path)


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
    exprs = parse_columns(columns)
    for channel in _MAP_CHANNELS:
        if channel not in exprs and channel in table and np.asarray(table[channel]).size > 1:
            exprs[channel] = ColumnExpr(channel)
    for required in ("f", "z"):
        if required not in exprs and required in table:
            _real(table[required], required, str(path), "column")  # says what it holds if not numbers
            raise DataError(f"{path}: {required!r} holds a single value, not a column of samples")
        if required not in exprs:
            raise DataError(
                f"{path}: no column for channel {required!r}; map one with columns= "
                f"(e.g. {required}=NAME); the file has: {', '.join(sorted(table))}"
            )
    arrays = {c: e.evaluate(table, str(path)).ravel() for c, e in exprs.items()}
    meta = {"source": str(path), **_read_sidecar(path), **dict(meta or {})}
    kwargs: dict[str, Any] = {c: arrays[c] for c in CHANNELS if c in arrays}
    if "t" in arrays:
        if fs is not None:
            raise InputError("give either a time column or fs=, not both")
        try:
            return Record.from_time(arrays["t"], meta=meta, units=units or {}, **kwargs)
        except DataError as exc:
            raise DataError(f"{path}: {exc}") from None
    if fs is None and "fs" in table and np.asarray(table["fs"]).size == 1:
        fs = float(_real(table["fs"], "fs", str(path), "variable").ravel()[0])
    if fs is None:
        raise DataError(f"{path}: no time column 't' and no sampling frequency; give fs= or map a time column (columns= with t=NAME)")
    try:
        return Record(fs=fs, meta=meta, units=units or {}, **kwargs)
    except DataError as exc:
        raise DataError(f"{path}: {exc}") from None


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
    _check_sidecar(path)
    frame.to_csv(path, index=False, float_format="%.12g")
    _write_sidecar(record, path)
    return path


def write_npz(record: Record, path: str | Path) -> Path:
    """Write the channels, ``t`` and ``fs`` to an NPZ file (no pickled objects), and the metadata sidecar."""
    path = Path(path)
    _check_sidecar(path)
    arrays = {c: getattr(record, c) for c in record.channels}
    np.savez(path, t=record.t, fs=np.array(record.fs), **arrays)
    _write_sidecar(record, path)
    return path
