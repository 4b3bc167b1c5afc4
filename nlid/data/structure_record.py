"""The record of a structure with several degrees of freedom: :class:`StructureRecord`.

The multi-DOF counterpart of :class:`nlid.data.record.Record` (which is unchanged:
one DOF stays the special case). A structure record holds, sampled
uniformly, the displacement of each of its ``n`` DOFs, the external force on
the DOFs that are driven, and velocities and accelerations where measured.
Its channels are named with 1-based DOF numbers, as engineers write them:
``z1 .. zn``, ``f1`` (and ``f3``... for the other driven DOFs), ``v1 .. vn``,
``a1 .. an``.

Arrays
------
``z``, ``f`` and, when present, ``v`` and ``a`` are ``(N, n)`` arrays, one
column per DOF; ``f`` has zero columns for the DOFs no force acts on, and
:attr:`StructureRecord.force_dofs` says which are driven. A velocity or
acceleration group is present for every DOF or for none; a reader given some
DOFs' velocities or accelerations only estimates the others
(:meth:`StructureRecord.with_derivatives`) and says so in
:attr:`~StructureRecord.provenance`, channel by channel.

Validation is that of :class:`~nlid.data.record.Record`, per channel: equal
lengths, at least :data:`~nlid.data.checks.MIN_SAMPLES` samples, finite values
(the channel and the first bad index named), no constant displacement,
velocity, acceleration or driven force; a force column of a DOF that is not
driven is exactly zero.

Units are declared per channel (``units={"z2": "mm"}``) or for every DOF of
a quantity (``{"z": "mm"}``), in the vocabulary of :mod:`nlid.data.units`
(``z2`` is a displacement), and converted to SI on construction.

``record.dof(k)`` is a one-DOF :class:`~nlid.data.record.Record` view of DOF ``k``
(its displacement, velocity, acceleration and own force), for plots and
per-DOF figures.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import DataError, InputError
from .checks import MIN_SAMPLES, RecordMeta, TimeAxis
from .checks import freeze as _freeze
from .record import Record
from .units import Unit, parse_units

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

__all__ = ["StructureRecord", "GROUPS", "channel_names"]

#: The quantities of a structure record, in the order their channels are written.
GROUPS = ("f", "z", "v", "a")
_SI = {"f": "N", "z": "m", "v": "m/s", "a": "m/s^2"}


def channel_names(group: str, dofs: Any) -> tuple[str, ...]:
    """``("z1", "z2", ...)``: the names of a quantity's channels for the given DOFs (1-based)."""
    return tuple(f"{group}{k}" for k in dofs)


def _units(spec: Any, n: int) -> dict[str, Unit]:
    """Per-channel units from ``{"z": "mm", "z2": "um", "t": "ms"}``: a quantity's unit applies to every DOF."""
    given = parse_units(spec, indexed=True)
    out: dict[str, Unit] = {}
    for channel, unit in given.items():
        if channel in GROUPS:
            for k in range(1, n + 1):
                out.setdefault(f"{channel}{k}", unit)
        elif channel == "t":
            out["t"] = unit
    for channel, unit in given.items():
        if channel not in GROUPS and channel != "t":
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


@dataclass(frozen=True, eq=False)
class StructureRecord(TimeAxis):
    """A uniformly sampled force/motion record of a structure with ``n`` DOFs.

    Parameters
    ----------
    f
        External force (N): ``(N, n)`` with zero columns for DOFs without a
        force, or ``(N, m)`` / ``(N,)`` for the DOFs named by ``force_dofs``.
    z
        Displacements (m), ``(N, n)``.
    fs
        Sampling frequency in Hz.
    v, a
        Velocities and accelerations, ``(N, n)``, or ``None``.
    t0
        Time of the first sample in s.
    force_dofs
        The driven DOFs (1-based); default: the non-zero columns of ``f``.
    units
        The unit of each channel as given (``{"z": "mm"}`` for every DOF,
        ``{"z2": "um"}`` for one; :mod:`nlid.data.units`), converted to SI;
        afterwards the SI unit of each channel.
    meta
        Free metadata, as for :class:`~nlid.data.record.Record` (``reference``,
        ``force_hold``, ``source``...); ``mass`` is the mass matrix (kg) when known.
    provenance
        How each channel (``"a2"``) was obtained; missing entries mean "measured".

    Raises
    ------
    DataError
        A rule of the module docstring is broken.
    InputError
        A unit outside the vocabulary.
    """

    f: np.ndarray
    z: np.ndarray
    fs: float
    v: np.ndarray | None = None
    a: np.ndarray | None = None
    t0: float = 0.0
    force_dofs: tuple[int, ...] | None = None
    units: Mapping[str, str] = field(default_factory=dict)
    meta: Mapping[str, Any] = field(default_factory=dict)
    provenance: Mapping[str, str] = field(default_factory=dict)
    _indexed = True

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        fs = float(self.fs)
        if not np.isfinite(fs) or fs <= 0:
            raise DataError(f"sampling frequency must be a positive number, got {self.fs!r}")
        set_(self, "fs", fs)
        z = _columns(self.z, "z", None)
        N, n = z.shape
        declared = _units(self.units, n)
        if "t" in declared and not declared["t"].is_si:
            raise InputError("units: t applies to a time vector (StructureRecord.from_time); fs= is always in Hz")
        f = _columns(self.f, "f", N)
        dofs = self.force_dofs
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
        set_(self, "force_dofs", tuple(sorted(dofs)))
        arrays = {"f": f, "z": z}
        for name in ("v", "a"):
            raw = getattr(self, name)
            if raw is not None:
                arrays[name] = _columns(raw, name, N)
                if arrays[name].shape[1] != n:
                    raise DataError(
                        f"channel group {name!r} has {arrays[name].shape[1]} columns but there are {n} DOFs"
                    )
        if N < MIN_SAMPLES:
            raise DataError(f"record has {N} samples; at least {MIN_SAMPLES} are needed")
        for name, arr in arrays.items():
            for k in range(n):
                if name == "f" and k + 1 not in self.force_dofs:
                    continue
                unit = declared.get(f"{name}{k + 1}")
                if unit is not None and unit.factor != 1.0:
                    arr[:, k] *= unit.factor
                if np.ptp(arr[:, k]) == 0.0:
                    raise DataError(
                        f"channel {name}{k + 1} is constant ({arr[0, k]}); nothing can be identified from it"
                    )
            arr.setflags(write=False)
            set_(self, name, arr)
        units = {"t": "s"}
        for name in self.groups:
            for k in range(1, n + 1):
                unit = declared.get(f"{name}{k}")
                units[f"{name}{k}"] = _SI[name] if unit is None else unit.si
        set_(self, "units", _freeze(units))
        if self.meta and self.meta.get("force_hold", "sampled") not in ("sampled", "zoh"):
            raise DataError(f"meta['force_hold'] must be 'sampled' or 'zoh', got {self.meta['force_hold']!r}")
        converted = {c: u.to_dict() for c, u in declared.items() if not u.is_si and c != "t"}
        meta = self.meta
        if converted:
            meta = dict(meta or {})
            meta["input_units"] = {**dict(meta.get("input_units") or {}), **converted}
        set_(self, "meta", RecordMeta.of(meta))
        set_(self, "provenance", _freeze(self.provenance))

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_record(cls, record: Record) -> StructureRecord:
        """A one-DOF :class:`~nlid.data.record.Record` as a structure record of one DOF (``z1``, ``f1``...)."""
        if not isinstance(record, Record):
            raise InputError(f"from_record needs an nlid Record, got {type(record).__name__}")
        prov = {f"{c}1": p for c, p in record.provenance.items()}
        return cls(
            f=record.f,
            z=record.z,
            fs=record.fs,
            v=record.v,
            a=record.a,
            t0=record.t0,
            meta=dict(record.meta),
            provenance=prov,
        )

    @classmethod
    def from_table(
        cls,
        table: Mapping[str, Any],
        columns: str | Mapping[str, str] | None = None,
        *,
        fs: float | None = None,
        force_hold: str | None = None,
        meta: Mapping[str, Any] | None = None,
        units: Mapping[str, str] | None = None,
        source: str | os.PathLike[str] = "mapping",
    ) -> StructureRecord:
        """Build a record from named columns under a column map with indexed channels (``z1=``, ``f1=``...).

        Every source of a structure record goes through here, as
        :meth:`Record.from_table <nlid.data.record.Record.from_table>` for one DOF
        (see :func:`nlid.data.columnmap.structure_arrays` for the rules). A velocity
        or acceleration given for some DOFs only is estimated for the others.

        Parameters
        ----------
        table, columns, fs, force_hold, meta, units, source
            As for :meth:`Record.from_table <nlid.data.record.Record.from_table>`;
            ``units`` and the map's ``z2[mm]=`` may name single channels.

        Raises
        ------
        DataError, InputError
            As for :meth:`Record.from_table <nlid.data.record.Record.from_table>`.
        """
        from .structure_tables import record_from_table

        return record_from_table(cls, table, columns, fs, force_hold, meta, units, source)

    @classmethod
    def from_frame(
        cls, frame: pd.DataFrame, columns: str | Mapping[str, str] | None = None, **kwargs: Any
    ) -> StructureRecord:
        """Build a record from a pandas DataFrame with the column map files use (as :meth:`Record.from_frame`)."""
        import pandas as pd

        from .columnmap import frame_table

        if not isinstance(frame, pd.DataFrame):
            raise InputError(f"StructureRecord.from_frame needs a pandas DataFrame, got {type(frame).__name__}")
        return cls.from_table(frame_table(frame, "DataFrame"), columns, source="DataFrame", **kwargs)

    # ------------------------------------------------------------------ properties
    @property
    def n(self) -> int:
        """Number of samples (as :attr:`Record.n`)."""
        return int(self.z.shape[0])

    @property
    def n_dofs(self) -> int:
        """Number of degrees of freedom."""
        return int(self.z.shape[1])

    @property
    def groups(self) -> tuple[str, ...]:
        """The quantities present, in :data:`GROUPS` order (``f`` and ``z`` always)."""
        return tuple(g for g in GROUPS if getattr(self, g) is not None)

    @property
    def channels(self) -> tuple[str, ...]:
        """The channel names, in the order files are written: driven forces, then ``z1..zn``, ``v``, ``a``."""
        out = list(channel_names("f", self.force_dofs))
        for g in self.groups[1:]:
            out += channel_names(g, range(1, self.n_dofs + 1))
        return tuple(out)

    def channel(self, name: str) -> np.ndarray:
        """One channel by name, e.g. ``record.channel("a2")`` (read-only)."""
        from .columnmap import split_indexed

        parts = split_indexed(name) if isinstance(name, str) else None
        if parts is None or parts[1] > self.n_dofs or getattr(self, parts[0]) is None:
            raise InputError(f"record has no channel {name!r}; its channels are {', '.join(self.channels)}")
        return getattr(self, parts[0])[:, parts[1] - 1]

    @property
    def mass(self) -> np.ndarray | None:
        """``meta['mass']`` as an ``(n, n)`` matrix (kg), if present (a vector is a lumped mass)."""
        m = self.meta.get("mass")
        if m is None:
            return None
        from ..model.structure import as_matrix

        return as_matrix(m, self.n_dofs, "the record's mass (meta['mass'], a file's .meta.json sidecar)", positive=True)

    def is_measured(self, channel: str) -> bool:
        """True if the channel is present and was measured (possibly resampled), not estimated."""
        try:
            self.channel(channel)
        except InputError:
            return False
        return self.source_of(channel).startswith("measured")

    def __repr__(self) -> str:
        src = self.meta.get("source", "")
        return (
            f"StructureRecord(n={self.n}, fs={self.fs:g} Hz, dofs={self.n_dofs}, "
            f"forces={','.join(channel_names('f', self.force_dofs))}"
            f", channels={','.join(self.groups)}{', source=' + str(src) if src else ''})"
        )

    # ------------------------------------------------------------------ views
    def dof(self, k: int) -> Record:
        """A one-DOF :class:`~nlid.data.record.Record` of DOF ``k`` (1-based): its z, v, a and its own force.

        For plots and per-DOF figures: the coupling to the other DOFs is not
        in it. ``meta`` keeps ``source`` and ``force_hold``, says
        ``dof = k``, and gives ``mass`` when the mass matrix is known and
        diagonal; the structure's reference is not a one-DOF reference and is
        left out.

        Raises
        ------
        InputError
            ``k`` is not a DOF of the record.
        DataError
            No force acts on DOF ``k`` (a one-DOF record needs one).
        """
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not 1 <= k <= self.n_dofs:
            raise InputError(f"dof must be a DOF number from 1 to {self.n_dofs}, got {k!r}")
        if k not in self.force_dofs:
            raise DataError(
                f"no force acts on DOF {k} (forces: {', '.join(channel_names('f', self.force_dofs))}); "
                "a one-DOF record needs its force"
            )
        meta = {key: self.meta[key] for key in ("source", "force_hold", "g") if key in self.meta}
        meta["dof"] = int(k)
        mass = self.mass
        if mass is not None and np.count_nonzero(mass - np.diag(np.diag(mass))) == 0:
            meta["mass"] = float(mass[k - 1, k - 1])
        arrays = {g: getattr(self, g)[:, k - 1] for g in self.groups}
        prov = {g: self.provenance[f"{g}{k}"] for g in self.groups if f"{g}{k}" in self.provenance}
        units = {g: self.units[f"{g}{k}"] for g in self.groups}
        return Record(fs=self.fs, t0=self.t0, meta=meta, provenance=prov, units=units, **arrays)

    # ------------------------------------------------------------------ derived records
    def without(self, *groups: str) -> StructureRecord:
        """A copy without the optional quantities named (``"v"`` and/or ``"a"``: every DOF's)."""
        for g in groups:
            if g not in ("v", "a"):
                raise InputError(f"only the optional quantities 'v' and 'a' can be dropped, not {g!r}")
        prov = {k: p for k, p in self.provenance.items() if k[0] not in groups}
        return replace(self, provenance=prov, **{g: None for g in groups})

    def to_dict(self) -> dict[str, np.ndarray]:
        """``t`` and every channel (:attr:`channels`) as a dictionary of 1-D arrays."""
        out = {"t": self.t}
        out.update({c: self.channel(c) for c in self.channels})
        return out
