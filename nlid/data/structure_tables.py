"""The indexed form of a :class:`~nlid.data.record.Record` (a structure's ``(N, n)`` channels): its rules and tables.

:func:`indexed_fields` checks the fields of an indexed record on construction
(the rules are in the docstring of :mod:`nlid.data.record`), as
:func:`nlid.data.checks.checked_fields` does for 1-D channels.
:func:`indexed_channels` reads a table's indexed channels for
:meth:`Record.from_table <nlid.data.record.Record.from_table>` (``indexed=True``),
the one path of every source of a record (files through
:func:`nlid.data.io.read_record`, DataFrames, xarray Datasets and mappings
through :func:`nlid.data.sources.as_record`): the column map is applied by
:func:`nlid.data.columnmap.structure_arrays` and units are merged from
``units=`` and the map.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from ..errors import DataError, InputError
from ..signal import derivatives
from .checks import CHANNELS, DEFAULT_UNITS, MIN_SAMPLES, checked_meta, freeze, merge_units
from .columnmap import column_units, split_indexed, structure_arrays
from .units import Unit, parse_units

__all__ = ["indexed_fields", "indexed_channels"]


def _units(spec: Any, n: int) -> dict[str, Unit]:
    """Per-channel units from ``{"z": "mm", "z2": "um", "t": "ms"}``: a quantity's unit applies to every DOF."""
    given = parse_units(spec, indexed=True)
    out: dict[str, Unit] = {}
    for channel, unit in given.items():
        if channel in CHANNELS:
            for k in range(1, n + 1):
                out.setdefault(f"{channel}{k}", unit)
        elif channel == "t":
            out["t"] = unit
    for channel, unit in given.items():
        if channel not in CHANNELS and channel != "t":
            if int(channel[1:]) > n:
                raise InputError(f"units: channel {channel!r} names DOF {channel[1:]} but the record has {n} DOFs")
            out[channel] = unit
    return out


def _columns(raw: Any, name: str, n_rows: int | None) -> np.ndarray:
    arr = np.array(raw, dtype=float)
    if arr.ndim == 1:
        arr = arr[:, None]
    if arr.ndim != 2:
        raise DataError(f"channel group {name!r} must be an (N, n) array, got shape {np.shape(raw)}")
    if n_rows is not None and arr.shape[0] != n_rows:
        raise DataError(f"channel group {name!r} has {arr.shape[0]} samples but 'z' has {n_rows}")
    bad = ~np.isfinite(arr)
    if bad.any():
        i, k = np.argwhere(bad)[0]
        raise DataError(f"channel {name}{k + 1} has a non-finite value ({arr[i, k]}) at index {i}")
    return arr


def indexed_fields(
    fs: Any,
    channels: Mapping[str, Any],
    force_dofs: Any,
    units: Any,
    meta: Mapping[str, Any] | None,
    provenance: Mapping[str, str] | None,
) -> dict[str, Any]:
    """The fields of an indexed record as it holds them, from those it was given; every rule checked.

    Parameters
    ----------
    fs
        The sampling frequency (Hz).
    channels
        ``{name: array or None}`` for each quantity of :data:`~nlid.data.checks.CHANNELS`: ``(N, n)`` arrays
        (``f`` may have a column per driven DOF, or be 1-D for one).
    force_dofs, units, meta, provenance
        As given to :class:`~nlid.data.record.Record`.

    Returns
    -------
    dict
        ``fs``, ``force_dofs`` (sorted), each quantity given (a read-only ``(N, n)`` float array in SI units),
        ``units`` (the SI unit of each channel, ``z2``...), ``meta`` and ``provenance``.

    Raises
    ------
    DataError
        A broken rule (the channel and, for a non-finite value, the first bad index named).
    InputError
        A unit outside the vocabulary, or a time unit (``fs`` is always in Hz).
    """
    rate = float(fs)
    if not np.isfinite(rate) or rate <= 0:
        raise DataError(f"sampling frequency must be a positive number, got {fs!r}")
    out: dict[str, Any] = {"fs": rate}
    z = _columns(channels["z"], "z", None)
    N, n = z.shape
    declared = _units(units, n)
    if "t" in declared and not declared["t"].is_si:
        raise InputError("units: t applies to a time vector (StructureRecord.from_time); fs= is always in Hz")
    f = _columns(channels["f"], "f", N)
    dofs = force_dofs
    if dofs is not None:
        dofs = tuple(int(k) for k in np.atleast_1d(dofs))
        if len(set(dofs)) != len(dofs) or not all(1 <= k <= n for k in dofs):
            raise DataError(f"force_dofs must be distinct DOFs from 1 to {n}, got {dofs}")
        if f.shape[1] == len(dofs) and (f.shape[1] != n or dofs != tuple(range(1, n + 1))):
            full = np.zeros((N, n))
            full[:, [k - 1 for k in dofs]] = f
            f = full
    if f.shape[1] != n:
        raise DataError(f"force has {f.shape[1]} columns but there are {n} DOFs (give force_dofs= for fewer)")
    nonzero = tuple(k + 1 for k in range(n) if np.any(f[:, k] != 0.0))
    if dofs is None:
        dofs = nonzero
    stray = [k for k in nonzero if k not in dofs]
    if stray:
        raise DataError(f"force f{stray[0]} is not zero but DOF {stray[0]} is not in force_dofs {dofs}")
    if not dofs:
        raise DataError("no force acts: every force column is zero")
    out["force_dofs"] = tuple(sorted(dofs))
    arrays = {"f": f, "z": z}
    for name in ("v", "a"):
        raw = channels.get(name)
        if raw is not None:
            arrays[name] = _columns(raw, name, N)
            if arrays[name].shape[1] != n:
                raise DataError(f"channel group {name!r} has {arrays[name].shape[1]} columns but there are {n} DOFs")
    if N < MIN_SAMPLES:
        raise DataError(f"record has {N} samples; at least {MIN_SAMPLES} are needed")
    for name, arr in arrays.items():
        for k in range(n):
            if name == "f" and k + 1 not in out["force_dofs"]:
                continue
            unit = declared.get(f"{name}{k + 1}")
            if unit is not None and unit.factor != 1.0:
                arr[:, k] *= unit.factor
            if np.ptp(arr[:, k]) == 0.0:
                raise DataError(f"channel {name}{k + 1} is constant ({arr[0, k]}); nothing can be identified from it")
        arr.setflags(write=False)
        out[name] = arr
    si = {"t": "s"}
    for name in (g for g in CHANNELS if g in arrays):
        for k in range(1, n + 1):
            unit = declared.get(f"{name}{k}")
            si[f"{name}{k}"] = DEFAULT_UNITS[name] if unit is None else unit.si
    out["units"] = freeze(si)
    return {**out, **checked_meta(meta, provenance, declared, N)}


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


def indexed_channels(
    named: Mapping[str, Any], columns: Any, fs: float | None, units: Any, label: str, noun: str
) -> tuple[dict[str, Any], np.ndarray | None, float | None]:
    """The channels of an indexed record in a table (:meth:`Record.from_table <nlid.data.record.Record.from_table>`
    with ``indexed=True``; see :func:`nlid.data.columnmap.structure_arrays` for the map's rules).

    Returns the keywords of the record (``f``, ``z``, ``v``, ``a``, ``force_dofs``, ``units`` and the
    ``provenance`` of the DOFs' velocities or accelerations estimated because the table gives only some),
    the time column (or ``None``) and the sampling frequency given or found.
    """
    given = merge_units(parse_units(units or {}, indexed=True), column_units(columns), indexed=True)
    arrays, fs = structure_arrays(named, columns, fs=fs, source=label, noun=noun)
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
        "provenance": provenance,
        "units": given,
    }
    for group in ("v", "a"):
        if f"{group}1" in arrays:
            kwargs[group] = np.stack([arrays[f"{group}{k}"] for k in range(1, n + 1)], axis=1)
    return kwargs, arrays.get("t"), fs
