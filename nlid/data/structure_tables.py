"""Tables of named columns -> :class:`~nlid.data.structure_record.StructureRecord` (what the readers call).

:func:`record_from_table` is the one path of every source of a structure
record (files through :func:`nlid.data.io.read_record`, DataFrames, xarray
Datasets and mappings through :func:`nlid.data.sources.as_record`), as
:meth:`Record.from_table <nlid.data.record.Record.from_table>` is for one DOF: the
column map is applied by :func:`nlid.data.columnmap.structure_arrays`, units are
merged from ``units=`` and the map, and ``meta["loaded"]`` says where the
record came from.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..errors import DataError, InputError
from ..signal import derivatives
from .checks import loaded_meta, table_source
from .columnmap import column_units, split_indexed, structure_arrays
from .units import parse_units, unit_of

__all__ = ["record_from_table", "structure_sha256"]


def structure_sha256(record: Any) -> str:
    """SHA-256 of a structure record's samples: ``fs``, ``t0``, then each channel (:attr:`channels` order) by name."""
    import hashlib

    digest = hashlib.sha256(b"nlid.StructureRecord/1\0")
    digest.update(np.array([record.fs, record.t0], dtype="<f8").tobytes())
    for name in record.channels:
        digest.update(name.encode("ascii") + b"\0")
        digest.update(np.ascontiguousarray(record.channel(name), dtype="<f8").tobytes())
    return digest.hexdigest()


def _merge_units(given: Mapping[str, Any], mapped: Mapping[str, str]) -> dict[str, str]:
    """``units=`` and the column map's ``z2[mm]=``; one channel given two different units is an error."""
    out = {c: u.symbol for c, u in parse_units(given, indexed=True).items()}
    for channel, text in mapped.items():
        unit = unit_of(channel, text, where="column map", indexed=True).symbol
        group = channel.rstrip("0123456789")
        for key in (channel, group):
            if key in out and out[key] != unit and (key == channel or channel not in out):
                raise InputError(
                    f"the unit of {channel!r} is given twice: {out[key]!r} in units= and {unit!r} in the column map"
                )
        out[channel] = unit
    return out


def _fill(arrays: dict[str, np.ndarray], group: str, n: int, fs: float | None, t: np.ndarray | None) -> dict[str, str]:
    """Estimate the DOFs of ``group`` (``v`` or ``a``) that are missing when some are given; their provenance."""
    have = [k for k in range(1, n + 1) if f"{group}{k}" in arrays]
    if not have or len(have) == n:
        return {}
    rate = fs if fs is not None else 1.0 / float(np.median(np.diff(t)))
    z = np.stack([arrays[f"z{k}"] for k in range(1, n + 1)], axis=1)
    cutoff = max(derivatives.suggest_cutoff(z[:, k], rate) for k in range(n))
    prov = {}
    for k in range(1, n + 1):
        if f"{group}{k}" in arrays:
            continue
        order = 1 if group == "v" else 2
        arrays[f"{group}{k}"], used = derivatives.differentiate(arrays[f"z{k}"], rate, order=order, cutoff=cutoff)
        prov[f"{group}{k}"] = f"estimated from z{k}: {used.describe()}"
    return prov


def record_from_table(
    cls: type,
    table: Mapping[str, Any],
    columns: str | Mapping[str, str] | None,
    fs: float | None,
    force_hold: str | None,
    meta: Mapping[str, Any] | None,
    units: Mapping[str, str] | None,
    source: str | os.PathLike[str],
) -> Any:
    """A structure record from a table
    (:meth:`StructureRecord.from_table <nlid.data.structure_record.StructureRecord.from_table>`)."""
    named, label, noun = table_source(table, source)
    given = _merge_units(units or {}, column_units(columns))
    arrays, table_fs = structure_arrays(named, columns, fs=fs, source=label, noun=noun)
    meta, loaded = loaded_meta(meta, force_hold, label, columns, fs)
    fs = table_fs
    n = max(k for c in arrays if (s := split_indexed(c)) and s[0] == "z" for k in (s[1],))
    lengths = {c: a.size for c, a in arrays.items()}
    if len(set(lengths.values())) > 1:
        first = next(iter(lengths))
        odd = next(c for c, size in lengths.items() if size != lengths[first])
        raise DataError(f"{label}: channel {odd!r} has {lengths[odd]} samples but {first!r} has {lengths[first]}")
    try:
        provenance = {}
        for group in ("v", "a"):
            provenance.update(_fill(arrays, group, n, fs, arrays.get("t")))
    except InputError as exc:
        raise DataError(f"{label}: {exc}") from None
    dofs = sorted(k for c in arrays if (s := split_indexed(c)) and s[0] == "f" for k in (s[1],))
    kwargs: dict[str, Any] = {
        "f": np.stack([arrays[f"f{k}"] for k in dofs], axis=1),
        "z": np.stack([arrays[f"z{k}"] for k in range(1, n + 1)], axis=1),
        "force_dofs": tuple(dofs),
        "meta": meta,
        "provenance": provenance,
        "units": given,
    }
    for group in ("v", "a"):
        if f"{group}1" in arrays:
            kwargs[group] = np.stack([arrays[f"{group}{k}"] for k in range(1, n + 1)], axis=1)
    try:
        record = cls.from_time(arrays["t"], **kwargs) if "t" in arrays else cls(fs=fs, **kwargs)
    except DataError as exc:
        raise DataError(f"{label}: {exc}") from None
    return record.with_meta(loaded={**loaded, "record_sha256": structure_sha256(record)})
