"""Where a record comes from: one function turns every accepted source into a :class:`~nlid.data.record.Record`.

:func:`as_record` is the boundary the verbs share (:func:`nlid.load`,
:func:`nlid.identify`, :func:`nlid.compare`, :func:`nlid.posterior`,
:func:`nlid.discover`). It accepts

* a :class:`~nlid.data.record.Record`, returned as is;
* a path (``str`` or :class:`pathlib.Path`) to a ``.csv``, ``.txt``, ``.npz``,
  ``.mat`` (v7.3 included), ``.h5``/``.hdf5`` or ``.parquet`` file
  (:func:`nlid.data.io.read_record`), or ``"dataset:NAME[:PART]"``
  for a bundled benchmark (:func:`nlid.data.datasets.load`);
* a pandas DataFrame (:meth:`Record.from_frame <nlid.data.record.Record.from_frame>`);
* an xarray Dataset (:meth:`Record.from_xarray <nlid.data.record.Record.from_xarray>`);
* a mapping of arrays such as ``{"t": t, "f": f, "z": z}``, or a numpy
  structured array (:meth:`Record.from_table <nlid.data.record.Record.from_table>`).

Files and tables share one column map and one set of rules (:mod:`nlid.data.columnmap`),
and one way of declaring units (``units={"z": "mm"}`` or ``z[mm]=`` in the
column map; :mod:`nlid.data.units`).
A table or file whose channels are indexed (``z1, z2, f1``; :mod:`nlid.data.columnmap`)
gives a record in its indexed form (:attr:`Record.indexed <nlid.data.record.Record.indexed>`);
any record is also accepted as is.
Anything else is an :class:`~nlid.errors.InputError` naming what was given.
pandas and xarray are never imported here: an object can only be a DataFrame
or a Dataset if its library is already loaded.
"""

from __future__ import annotations

import os
import reprlib
import sys
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..errors import InputError
from . import datasets
from .checks import TimeAxis
from .columnmap import dataset_table, frame_table, uses_indexed
from .digest import record_sha256
from .io import read_record
from .record import Record

__all__ = ["as_record", "ACCEPTED"]

#: What :func:`as_record` accepts, as its messages say it.
ACCEPTED = (
    "a Record, a file path ('rig.csv'), 'dataset:NAME[:PART]', a pandas DataFrame, "
    "an xarray Dataset or a mapping of arrays ({'t': t, 'f': f, 'z': z})"
)


def as_record(
    source: Any,
    *,
    columns: str | Mapping[str, str] | None = None,
    fs: float | None = None,
    force_hold: str | None = None,
    units: str | Mapping[str, str] | None = None,
) -> Record:
    """A :class:`~nlid.data.record.Record` from any accepted source (see the module docstring).

    A source with indexed channels (``z1``, ``z2``, ``f1``...) gives a
    record of indexed channels (several degrees of freedom, :attr:`Record.indexed <nlid.data.record.Record.indexed>`).

    Parameters
    ----------
    source
        A Record, a file path, ``"dataset:NAME[:PART]"``, a pandas DataFrame,
        an xarray Dataset, or a mapping of arrays.
    columns
        Column map for files and tables: ``"t=time,f=load_N,z=disp_mm*0.001"``
        or ``{"f": "load_N", "z": "disp_mm*0.001"}``; default: columns named
        like the channels ``t, f, z, v, a``.
    fs
        Sampling frequency (Hz) of a file or table without a time column.
    force_hold
        ``"sampled"`` or ``"zoh"``, set on the record's metadata; default:
        what the source says (a file's ``.meta.json``, a Record's metadata).
    units
        The unit of each channel of a file or table, ``{"z": "mm", "a": "g"}``
        or ``"z=mm,a=g"`` (:mod:`nlid.data.units`); converted to SI. Default SI.

    Returns
    -------
    Record
        ``source`` itself when it is a record and ``force_hold`` is not given.

    Raises
    ------
    InputError
        A source of another type (its type and a short repr are named),
        ``columns=``/``fs=``/``units=`` given with a Record or a bundled
        dataset, a bad ``force_hold``, or a unit outside the vocabulary.
    DataError
        An unreadable file, a missing column, a NaN (channel and index named)...
    """
    record = _convert(source, columns, fs, units)
    if force_hold is not None:
        if force_hold not in ("sampled", "zoh"):
            raise InputError(f"force_hold must be 'sampled' or 'zoh', got {force_hold!r}")
        record = record.with_meta(force_hold=force_hold, force_hold_source="option")
    return record


def _table_record(table: Mapping[str, Any], columns: Any, fs: float | None, units: Any, source: str) -> Any:
    """A :class:`Record`, in the indexed form when the channels are indexed."""
    return Record.from_table(table, columns, fs=fs, units=units, source=source, indexed=uses_indexed(table, columns))


def _convert(source: Any, columns: str | Mapping[str, str] | None, fs: float | None, units: Any) -> Any:
    if isinstance(source, TimeAxis):  # a record already, of one DOF or a structure
        if columns or fs is not None or units:
            raise InputError(
                "columns=, fs= and units= apply to files and tables, not to a Record "
                "(its values are SI already: Record(..., units=) converted them)"
            )
        return source
    if isinstance(source, (str, os.PathLike)):
        return _from_path(source, columns, fs, units)
    pandas = sys.modules.get("pandas")
    if pandas is not None and isinstance(source, pandas.DataFrame):
        return _table_record(frame_table(source, "DataFrame"), columns, fs, units, "DataFrame")
    xarray = sys.modules.get("xarray")
    if xarray is not None and isinstance(source, xarray.Dataset):  # before Mapping: a Dataset is one
        return _table_record(dataset_table(source, "Dataset"), columns, fs, units, "Dataset")
    if isinstance(source, np.ndarray) and source.dtype.names:
        table = {name: source[name] for name in source.dtype.names}
        return _table_record(table, columns, fs, units, "structured array")
    if isinstance(source, Mapping):
        return _table_record(source, columns, fs, units, "mapping")
    raise InputError(f"cannot make a record from {_describe(source)}; give {ACCEPTED}")


def _from_path(
    source: str | os.PathLike[str], columns: str | Mapping[str, str] | None, fs: float | None, units: Any
) -> Any:
    text = os.fspath(source)
    if isinstance(text, bytes):
        raise InputError(f"cannot make a record from a bytes path {reprlib.repr(text)}; give the path as str")
    if text.startswith("dataset:"):
        if columns or fs or units:
            raise InputError("columns=, fs= and units= do not apply to bundled datasets")
        parts = text.split(":")
        record = datasets.load(parts[1] if len(parts) > 1 else "", part=parts[2] if len(parts) > 2 else "all")
        return record.with_meta(loaded={"source": text, "record_sha256": record_sha256(record)})
    if "\n" in text:
        raise InputError(
            f"cannot make a record from the text {_short(text)}: a file path has no line breaks "
            "(CSV text is read with pandas.read_csv(io.StringIO(text)))"
        )
    return read_record(text, columns, fs=fs, units=units)


def _describe(source: Any) -> str:
    """``list [1, 2, 3]``: the type and a short repr, on one line."""
    if source is None:
        return "None"
    kind = type(source)
    module = kind.__module__.split(".")[0]
    name = kind.__name__ if module == "builtins" else f"{module}.{kind.__name__}"
    if isinstance(source, np.ndarray):
        return f"{name} of shape {source.shape} without column names"
    if module != "builtins":  # another library's repr may be long or span lines: its shape says enough
        shape = getattr(source, "shape", None)
        return name if shape is None else f"{name} of shape {tuple(shape)}"
    return f"{name} {_short(source)}"


_REPR = reprlib.Repr()
_REPR.maxstring = _REPR.maxother = 40
_REPR.maxlist = _REPR.maxtuple = _REPR.maxdict = _REPR.maxset = 4


def _short(value: Any) -> str:
    """A repr on one line, at most 60 characters."""
    text = " ".join(_REPR.repr(value).split())
    return text if len(text) <= 60 else text[:57] + "..."
