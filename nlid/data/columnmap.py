"""Tables of named columns, and the column map that turns them into channels.

Every source of a record goes through one path: a reader yields a *table*
(column or variable name -> array) and :func:`channel_arrays` maps its columns
to the channels of a :class:`~nlid.data.record.Record`
(:meth:`Record.from_table <nlid.data.record.Record.from_table>`). Files are read
into tables by :func:`nlid.data.io.read_table`; a pandas DataFrame by
:func:`frame_table`, an xarray Dataset by :func:`dataset_table`; a mapping of
arrays is a table already.

Column maps
-----------
A column map says which column (or variable) of a table becomes which channel,
optionally scaled: ``"f=vir*gtau, z=qm"`` or ``"f=-acc*0.265, z=disp/1000"``,
or the same as a mapping ``{"f": "vir*gtau", "z": "qm"}``. Each entry is
``channel=expr`` with ``channel`` one of ``t, f, z, v, a`` and ``expr`` an
optional leading ``-`` and a product/quotient of exactly one column name with
numbers or scalar variables of the table (a 1x1 MATLAB variable, an NPZ
scalar, a 0-d variable of a Dataset, a scalar of a mapping). It is parsed by a
small grammar, never evaluated. Channels not in the map are taken from columns
of the same name when present.

The grammar::

    map      := entry ("," entry)*
    entry    := channel ["[" unit "]"] "=" expr
    expr     := ["-"] operand (("*" | "/") operand)*
    operand  := number | name | quoted
    name     := a letter or "_", then letters, digits or "_" (any script: weg_µm, 変位)
    quoted   := "..." or '...' holding any text but its own quote

* **Units.** ``z[mm]=disp`` says that the channel, after the scaling, is in
  millimetres; it is converted to SI (the vocabulary is :mod:`nlid.data.units`):
  ``"t[ms]=time, f[kN]=load, z[µm]=weg_µm, a[g]=acc"``. In a mapping the key
  carries it: ``{"z[mm]": "disp"}``. ``z=disp_mm*0.001`` (a scale factor, no
  unit) still works: the result is taken to be in SI.
* **Any column name.** A name with spaces, brackets or other symbols (a
  spreadsheet's header ``Weg [mm]``, a number ``0``) is written in quotes:
  ``z[mm]="Weg [mm]"``. Quoted text is always a name, never a number or an
  operator, so the grammar stays unambiguous.
* **Paths.** The datasets of an HDF5 file (and the fields of a MATLAB v7.3
  struct) are named by their path, ``data/disp``, written in quotes because
  ``/`` divides: ``z="data/disp"`` (a leading ``/`` is allowed:
  ``z="/data/disp"``).

Several degrees of freedom
--------------------------
Indexed channels name the DOFs of a structure: ``z1, z2, z3`` (displacements,
each DOF one), ``f1, f3`` (the forces that act, on some DOFs), ``v2``,
``a1``... (``"f1=load, z1[mm]=disp_a, z2[mm]=disp_b"``). A map naming indexed
channels, or a table without a column ``z`` but with columns ``z1``, ``z2``...
(what :func:`nlid.data.io.write_csv` writes for a record of indexed
channels), is read as a structure
(:func:`structure_arrays`, :func:`uses_indexed`); one map cannot name both
``z`` and ``z1``. Units apply per channel (``z2[mm]=``), each in its
quantity's vocabulary.

The sampling frequency comes from the time column (checked for uniformity, see
:class:`nlid.data.record.Record`), else from ``fs=`` given by the caller, else from
a scalar ``fs`` variable of the table.

This module imports neither pandas nor xarray: it uses the objects it is given.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..errors import DataError, InputError, brief, grouped, listing
from .units import INDEXED

__all__ = [
    "ColumnExpr",
    "parse_columns",
    "column_units",
    "channel_arrays",
    "frame_table",
    "dataset_table",
    "MAP_CHANNELS",
    "split_indexed",
    "uses_indexed",
    "structure_arrays",
    "MAX_DOFS",
]

#: Channels a column map can name: the time ``t`` and the channels of a record.
MAP_CHANNELS = ("t", "f", "z", "v", "a")
#: Largest DOF number an indexed channel may name (``z1000``): a structure's matrices grow as its square.
MAX_DOFS = 1000
#: An operand: a number, a name (letters of any script, digits, ``_``; not starting with a digit) or quoted text.
_OPERAND = re.compile(
    r"""\s*(?:(?P<number>[0-9]*\.?[0-9]+(?:[eE][+-]?[0-9]+)?)(?![^\W\d])|(?P<name>[^\W\d]\w*)"""
    r"""|"(?P<dq>[^"]*)"|'(?P<sq>[^']*)')\s*"""
)
#: The left-hand side of an entry: a channel and an optional unit in brackets.
_KEY = re.compile(r"\s*(?P<channel>[^\s\[\]=]*)\s*(?:\[(?P<unit>[^\]]*)\])?\s*")


@dataclass(frozen=True)
class ColumnExpr:
    """``sign * column * prod(factors) / prod(divisors)``, in ``unit`` (``None``: SI)."""

    column: str
    factors: tuple[str | float, ...] = ()
    divisors: tuple[str | float, ...] = ()
    negate: bool = False
    unit: str | None = None

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
    if name not in table and name.startswith("/") and name.lstrip("/") in table:  # an HDF5 path written absolute
        name = name.lstrip("/")
    if name not in table:
        avail = listing(sorted(table)) or "none"
        what = "column" if column else "variable"
        raise DataError(f"{what} {brief(name, 60)} not found in {source}; it has: {avail}")
    return np.asarray(table[name])


def _real(value: Any, name: str, source: str, what: str) -> np.ndarray:
    """``value`` as a float array, refusing what is not real numbers (text, cells, structs, complex)."""
    array = np.asarray(value)
    kind = array.dtype.kind
    if kind == "c":
        raise DataError(f"{what} {name!r} in {source} holds complex numbers; nlid needs real ones (take .real or abs)")
    if kind == "b":
        raise DataError(f"{what} {name!r} in {source} holds booleans (True/False), not numbers")
    if kind not in "iuf":
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
    """Parse a column map such as ``"f=vir*gtau, z[mm]=qm"`` (the grammar is in the module docstring).

    Raises
    ------
    InputError
        Naming the entry and what is wrong with it; a unit outside the
        vocabulary of :mod:`nlid.data.units`.
    """
    if not spec:
        return {}
    items: list[tuple[str, str]] = []
    if isinstance(spec, Mapping):
        items = [(str(k), v) for k, v in spec.items()]
    elif isinstance(spec, str):
        for entry in _split_entries(spec):
            if not entry.strip():
                continue
            if "=" not in entry:
                raise InputError(
                    f"column map entry {brief(entry.strip(), 60)} must look like channel=column (e.g. f=vir*35.15)"
                )
            key, expr = entry.split("=", 1)
            items.append((key, expr))
    else:
        raise InputError(f"a column map is a string such as 'f=load,z=disp' or a mapping, got {type(spec).__name__}")
    out: dict[str, ColumnExpr] = {}
    for key, expr in items:
        channel, unit = _parse_key(key)
        if channel in out:
            raise InputError(f"column map gives channel {channel!r} twice")
        if not isinstance(expr, str):
            raise InputError(f"column map entry for {channel!r} must be text such as 'disp*0.001', got {expr!r}")
        parsed = _parse_expr(channel, expr)
        out[channel] = parsed if unit is None else replace(parsed, unit=unit)
    return out


def column_units(spec: str | Mapping[str, str] | None) -> dict[str, str]:
    """The units a column map declares: ``{"z": "mm"}`` for ``"f=load, z[mm]=disp"``."""
    return {c: e.unit for c, e in parse_columns(spec).items() if e.unit is not None}


def _split_entries(text: str) -> list[str]:
    """``text`` split at the commas outside quotes."""
    entries, current, quote = [], [], ""
    for char in text:
        if quote:
            quote = "" if char == quote else quote
        elif char in "\"'":
            quote = char
        elif char == ",":
            entries.append("".join(current))
            current = []
            continue
        current.append(char)
    if quote:
        raise InputError(f"column map {_excerpt(text)}: a quote {quote} is not closed")
    entries.append("".join(current))
    return entries


def _excerpt(text: str) -> str:
    text = text.strip()
    return repr(text if len(text) <= 60 else text[:57] + "...")


def split_indexed(channel: str) -> tuple[str, int] | None:
    """``"z2"`` -> ``("z", 2)``; ``None`` for a name that is not an indexed channel."""
    m = INDEXED.fullmatch(channel)
    return None if m is None else (m.group(1), int(m.group(2)))


def _check_dof(name: str, what: str, error: type[Exception]) -> None:
    """Refuse an indexed channel naming a DOF beyond :data:`MAX_DOFS` (before any list of DOFs is built)."""
    parts = split_indexed(name)
    if parts is not None and parts[1] > MAX_DOFS:
        raise error(f"{what} {_excerpt(name)} names DOF {brief(parts[1], 30)}; a structure has at most {MAX_DOFS}")


def _shape_of(table: Mapping[str, Any], name: str) -> tuple[int, ...] | None:
    """The shape of column ``name``: a file's table says what it declares without reading it (``None``: no array)."""
    declared = getattr(table, "shape_of", None)
    return declared(name) if declared is not None else np.shape(table[name])


def _size_of(table: Mapping[str, Any], name: str) -> int | None:
    shape = _shape_of(table, name)
    return None if shape is None else int(np.prod(shape, dtype=float))


def _is_column(table: Mapping[str, Any], name: str) -> bool:
    """True when ``table`` has ``name`` with more than one value (a column, not a scalar)."""
    if name not in table:
        return False
    n = _size_of(table, name)
    return n is None or n > 1  # unknown (not an array): read, and named for what it holds


#: Values a column may declare and be read before its length is compared with the other columns' (1 MiB of floats).
_READ_FREELY = 1 << 17


def _check_lengths(table: Mapping[str, Any], exprs: Mapping[str, ColumnExpr], source: str) -> None:
    """Refuse a large column of a file table whose declared length differs from the others', before reading it.

    (Smaller columns are read and named for what they hold: text, booleans, another length.)
    """
    if getattr(table, "shape_of", None) is None:
        return  # in memory already: the record compares the lengths
    sizes: dict[str, int] = {}
    for e in exprs.values():
        name = e.column if e.column in table else e.column.lstrip("/")
        shape = _shape_of(table, name) if name in table else None
        if shape is not None and sum(1 for n in shape if n > 1) == 1:  # a vector (a matrix is refused when read)
            sizes[name] = max(shape)
    if len(set(sizes.values())) > 1 and max(sizes.values()) > _READ_FREELY:
        (small, a), (large, b) = min(sizes.items(), key=lambda kv: kv[1]), max(sizes.items(), key=lambda kv: kv[1])
        raise DataError(
            f"column {large!r} in {source} declares {grouped(b)} values and column {small!r} {grouped(a)}: "
            "a record's channels have one length (nothing was read)"
        )


def _parse_key(key: str) -> tuple[str, str | None]:
    """``"z[mm]"`` -> ``("z", "mm")``; the unit is checked against the vocabulary."""
    from .units import unit_of

    m = _KEY.fullmatch(key)
    channel = m.group("channel") if m else key.strip()
    if channel not in MAP_CHANNELS and split_indexed(channel) is None:
        raise InputError(
            f"column map: unknown channel {_excerpt(channel)}; channels are {', '.join(MAP_CHANNELS)}"
            + " (f1, z1, v1, a1... for the DOFs of a structure)"
            + (", each optionally with its unit, e.g. z[mm]" if m is None or "[" in key else "")
        )
    if m is None:
        raise InputError(f"column map: {_excerpt(key)} must be a channel with an optional unit, e.g. z or z[mm]")
    _check_dof(channel, "column map: channel", InputError)
    unit = m.group("unit")
    if unit is None:
        return channel, None
    return channel, unit_of(channel, unit, where="column map", indexed=True).symbol


def _parse_expr(channel: str, text: str) -> ColumnExpr:
    rest = text.strip()
    negate = rest.startswith("-")
    if negate:
        rest = rest[1:]
    shown = f"column map entry {channel}={_excerpt(text)}"
    quoted = f'{channel}="{rest.strip()}"' if '"' not in rest and len(rest) <= 60 else f'{channel}="Weg [mm]"'
    quote_hint = f" (a name with spaces or symbols goes in quotes, e.g. {quoted})"
    operands: list[tuple[str, str | float]] = []
    op = "*"
    pos = 0
    while True:
        m = _OPERAND.match(rest, pos)
        if m is None or m.end() == pos:
            hint = quote_hint if pos < len(rest) and rest[pos] not in "*/-+" else ""
            raise InputError(f"{shown}: expected a column name or a number at character {pos + 1 + int(negate)}{hint}")
        number, name = m.group("number"), m.group("name")
        value: str | float
        if number is not None:
            value = float(number)
        else:
            # quoted text is a name as it is, but for the spaces around it (table names are stripped of them)
            value = (
                name if name is not None else (m.group("dq") if m.group("dq") is not None else m.group("sq")).strip()
            )
            if not value:
                raise InputError(f"{shown}: an empty name in quotes")
        operands.append((op, value))
        pos = m.end()
        if pos >= len(rest):
            break
        op = rest[pos]
        if op not in "*/":
            hint = quote_hint if op not in "+-^(" else ""
            raise InputError(f"{shown}: unexpected {op!r} (only * and / are allowed){hint}")
        pos += 1
    # The column is the first name; every other name is a scalar variable.
    names = [i for i, (o, v) in enumerate(operands) if isinstance(v, str) and o == "*"]
    if not names:
        raise InputError(f"{shown} names no column")
    col_index = names[0]
    column = operands[col_index][1]
    factors = tuple(v for i, (o, v) in enumerate(operands) if o == "*" and i != col_index)
    divisors = tuple(v for o, v in operands if o == "/")
    return ColumnExpr(column=str(column), factors=factors, divisors=divisors, negate=negate)


def channel_arrays(
    table: Mapping[str, Any],
    columns: str | Mapping[str, str] | None = None,
    *,
    fs: float | None = None,
    source: str = "the table",
    noun: str = "table",
) -> tuple[dict[str, np.ndarray], float | None]:
    """The channels of a table under a column map: ``(arrays, fs)``.

    Parameters
    ----------
    table
        Column or variable name -> array (or scalar).
    columns
        Column map (see the module docstring); unmapped channels are taken
        from same-named columns.
    fs
        Sampling frequency in Hz when the table has no time column.
    source, noun
        Where the table came from (a path, or a word such as ``"DataFrame"``)
        and what it is (``"file"``, ``"DataFrame"``), for the messages.

    Returns
    -------
    tuple
        ``arrays`` (channel -> 1-d float array, ``t`` among them when there is
        a time column) and the sampling frequency (``None`` when ``t`` is
        there).

    Raises
    ------
    DataError
        A missing or non-numeric column, or no way to know the sampling frequency.
    InputError
        A malformed column map, or both a time column and ``fs=``.
    """
    exprs = parse_columns(columns)
    indexed = [c for c in exprs if split_indexed(c)]
    if indexed:
        raise InputError(
            f"column map names the indexed channel {indexed[0]!r}: channels of several DOFs make a "
            "StructureRecord (read them with nlid.load or nlid.data.structure_record.StructureRecord.from_table)"
        )
    for channel in MAP_CHANNELS:
        if channel not in exprs and _is_column(table, channel):
            exprs[channel] = ColumnExpr(channel)
    for required in ("f", "z"):
        if required not in exprs and required in table:
            _real(table[required], required, source, "column")  # says what it holds if not numbers
            raise DataError(f"{source}: {required!r} holds a single value, not a column of samples")
        if required not in exprs:
            raise DataError(
                f"{source}: no column for channel {required!r}; map one with columns= "
                f"(e.g. {required}=NAME); the {noun} has: {listing(sorted(table))}"
            )
    _check_lengths(table, exprs, source)
    arrays = {c: e.evaluate(table, source).ravel() for c, e in exprs.items()}
    return arrays, _sampling(arrays, table, fs, source)


def _sampling(
    arrays: Mapping[str, np.ndarray], table: Mapping[str, Any], fs: float | None, source: str
) -> float | None:
    """The sampling frequency: ``None`` with a time column, else ``fs=``, else the table's scalar ``fs``."""
    if "t" in arrays:
        if fs is not None:
            raise InputError("give either a time column or fs=, not both")
        return None
    if fs is None and "fs" in table and _size_of(table, "fs") == 1:
        fs = float(_real(table["fs"], "fs", source, "variable").ravel()[0])
    if fs is None:
        raise DataError(
            f"{source}: no time column 't' and no sampling frequency; "
            "give fs= or map a time column (columns= with t=NAME)"
        )
    return fs


def uses_indexed(table: Mapping[str, Any], columns: str | Mapping[str, str] | None = None) -> bool:
    """True when a table is read as a structure: its map names indexed channels, or it has ``z1``... and no ``z``.

    Raises
    ------
    InputError
        A map naming both one-DOF channels (``f``, ``z``, ``v``, ``a``) and indexed ones.
    """
    exprs = parse_columns(columns)
    indexed = [c for c in exprs if split_indexed(c)]
    plain = [c for c in exprs if c in ("f", "z", "v", "a")]
    if indexed and plain:
        raise InputError(
            f"column map names both {plain[0]!r} and {indexed[0]!r}: one DOF's channels are f, z, v, a; "
            "a structure's are indexed (f1, z1, z2...)"
        )
    if indexed:
        return True
    if plain or "z" in table:
        return False
    return any(split_indexed(str(k)) == ("z", 1) for k in table)


def structure_arrays(
    table: Mapping[str, Any],
    columns: str | Mapping[str, str] | None = None,
    *,
    fs: float | None = None,
    source: str = "the table",
    noun: str = "table",
) -> tuple[dict[str, np.ndarray], float | None]:
    """The indexed channels of a table under a column map: ``(arrays, fs)`` (as :func:`channel_arrays`).

    Mapped channels are evaluated; indexed channels not in the map are taken
    from same-named columns (``z1``, ``f2``...), and ``t`` likewise. The
    displacements must be ``z1`` to ``zn`` without a gap (``n`` DOFs), and at
    least one force ``fk`` (``k <= n``) must be there.

    Raises
    ------
    DataError
        A missing displacement or force, a channel of a DOF beyond ``zn``, a
        missing or non-numeric column, or no sampling frequency.
    InputError
        A malformed column map, or both a time column and ``fs=``.
    """
    exprs = parse_columns(columns)
    for name in table:
        key = str(name)
        if key not in exprs and split_indexed(key):
            _check_dof(key, f"{source}: column", DataError)
            if _is_column(table, name):
                exprs[key] = ColumnExpr(key)
    if "t" not in exprs and _is_column(table, "t"):
        exprs["t"] = ColumnExpr("t")
    dofs: dict[str, list[int]] = {g: [] for g in "fzva"}
    for channel in exprs:
        parts = split_indexed(channel)
        if parts is not None:
            dofs[parts[0]].append(parts[1])
    n = max(dofs["z"], default=0)
    if n == 0:
        raise DataError(
            f"{source}: no displacement column z1; map the DOFs with columns= (e.g. z1=NAME, z2=NAME, f1=NAME); "
            f"the {noun} has: {', '.join(sorted(map(str, table)))}"
        )
    missing = [k for k in range(1, n + 1) if k not in dofs["z"]]
    if missing:
        raise DataError(f"{source}: no column for z{missing[0]}; each of the {n} DOFs needs its displacement z1..z{n}")
    beyond = [f"{g}{k}" for g in "fva" for k in dofs[g] if k > n]
    if beyond:
        raise DataError(f"{source}: channel {beyond[0]} names DOF {beyond[0][1:]} but the displacements are z1..z{n}")
    if not dofs["f"]:
        raise DataError(f"{source}: no force column; map at least one (e.g. f1=NAME)")
    _check_lengths(table, exprs, source)
    arrays = {c: e.evaluate(table, source).ravel() for c, e in exprs.items()}
    return arrays, _sampling(arrays, table, fs, source)


# --------------------------------------------------------------------------- in-memory tables
def _seconds(values: Any, name: object, source: str) -> np.ndarray | None:
    """Durations as float seconds; ``None`` for values that are not times. Dates are refused."""
    dtype = getattr(values, "dtype", None)
    kind = getattr(dtype, "kind", "")
    if kind == "m":
        return np.asarray(values, dtype="timedelta64[ns]") / np.timedelta64(1, "s")
    if kind == "M":
        raise DataError(
            f"{source}: column {name!r} holds dates and times; give seconds from the start, "
            "e.g. (t - t[0]).total_seconds()"
        )
    return None


def _frame_column(column: Any, name: object, source: str) -> np.ndarray:
    """One pandas column (a Series) as floats; a value that is not a number is named with its row."""
    import pandas as pd

    seconds = _seconds(column, name, source)
    if seconds is not None:
        return seconds
    kind = getattr(column.dtype, "kind", "")
    if isinstance(column.dtype, np.dtype) and kind in "iuf":  # plain numbers: no parsing (a 100 000-column file)
        return column.to_numpy(dtype=float)
    if kind == "c":
        _real(column.to_numpy(), str(name), source, "column")  # raises: complex numbers
    if kind == "b" or str(column.dtype) == "boolean":
        raise DataError(f"column {name!r} in {source} holds booleans (True/False), not numbers")
    try:
        numeric = pd.to_numeric(column, errors="coerce")
    except (TypeError, ValueError):
        raise DataError(f"{source}: column {name!r} holds values of type {column.dtype}, not numbers") from None
    bad = numeric.isna() & column.notna()
    if bad.any():
        i = int(np.argmax(bad.to_numpy()))
        raise DataError(f"{source}: column {name!r} has a non-numeric value {column.iloc[i]!r} at row {i + 1}")
    return numeric.to_numpy(dtype=float, na_value=np.nan)


def frame_table(frame: Any, source: str = "DataFrame") -> dict[str, np.ndarray]:
    """The columns of a pandas DataFrame as float arrays, keyed by name (stripped of spaces).

    A named index is one more column (an index named ``t`` is the time axis by
    default; one named ``time`` is mapped with ``t=time``); an unnamed index
    is ignored. Durations (``timedelta``) become seconds; dates are refused.

    Raises
    ------
    DataError
        A column that is not numbers (the first bad value and its row are named),
        or an index named like a column.
    """
    import pandas as pd

    out: dict[str, np.ndarray] = {}
    index = frame.index
    for level, name in enumerate(index.names):
        if name is None:
            continue
        key = str(name).strip()
        if key in (str(c).strip() for c in frame.columns):
            raise DataError(f"{source}: the index and a column are both named {key!r}; rename one")
        out[key] = _frame_column(pd.Series(index.get_level_values(level)), name, source)
    for name in frame.columns:
        out[str(name).strip()] = _frame_column(frame[name], name, source)
    return out


def dataset_table(dataset: Any, source: str = "Dataset") -> dict[str, np.ndarray]:
    """The coordinates and data variables of an xarray Dataset as arrays, keyed by name.

    0-d variables are scalars (scale factors, ``fs``); durations (``timedelta``)
    become seconds; dates are refused. Other values are checked when a column
    map uses them.
    """
    out: dict[str, np.ndarray] = {}
    for variables in (dataset.coords, dataset.data_vars):
        for name, variable in variables.items():
            values = np.asarray(variable.values)
            seconds = _seconds(values, name, source)
            out[str(name).strip()] = values if seconds is None else seconds
    return out
