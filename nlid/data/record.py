"""The measured (or simulated) record every identifier works on, of one DOF or of a structure.

A :class:`Record` holds uniformly sampled channels of a test. Of one degree of
freedom (1-D channels): the external force ``f`` on the mass (N; for base
excitation ``f = -m * b''``), the displacement ``z`` (m) and, when measured,
the velocity ``v`` (m/s) and acceleration ``a`` (m/s^2). Of a structure of
``n`` DOFs (the *indexed* form, :attr:`Record.indexed`): the same quantities as
``(N, n)`` arrays, one column per DOF, its channels named with 1-based DOF
numbers as engineers write them (``z1 .. zn``, ``f1`` and ``f3``... for the
driven DOFs, ``v1 .. vn``, ``a1 .. an``); ``f`` has zero columns for the DOFs
no force acts on, and :attr:`Record.force_dofs` says which are driven. One DOF
is the case ``n = 1`` with its conveniences: 1-D channels named ``f, z, v, a``
and a scalar mass. A record is validated on construction and never modified in
place: slicing, decimation and channel estimation return new records.

Validation rules
----------------
* every channel is of equal length, at least :data:`MIN_SAMPLES` long, finite
  (the error names the channel and the first bad index) and not constant (a
  force column of a DOF that is not driven is exactly zero instead); 1-D
  channels are one-dimensional, an indexed record's quantities ``(N, n)``, a
  velocity or acceleration group present for every DOF or for none;
* a time vector, when given (:meth:`Record.from_time`), is strictly increasing
  and uniform: every step may differ from the median step by at most
  :data:`TIME_TOLERANCE` (relative), which accepts time stamps written with
  six or more significant digits but rejects dropped or repeated samples.

The checks, and the names above, are in :mod:`nlid.data.checks` (1-D channels)
and :mod:`nlid.data.structure_tables` (indexed).

Units
-----
A record holds SI values (N, m, m/s, m/s^2, s). Data in other units are
declared with ``units=`` (``{"z": "mm", "a": "g"}``; an indexed record's
per channel, ``{"z2": "mm"}``, or for every DOF of a quantity, ``{"z": "mm"}``;
the vocabulary is :mod:`nlid.data.units`) and converted on construction; a unit
outside the vocabulary is refused. :attr:`Record.units` then holds the SI unit
of each channel, and ``meta["input_units"]`` what each channel was given in and
the factor applied (``{"z": {"unit": "mm", "si": "m", "factor": 0.001}}``).

Provenance
----------
``Record.provenance`` says for each channel whether it was measured or how it
was estimated (e.g. "zero-phase Butterworth low-pass (order 4, fc=120 Hz) +
5-point central difference"). Identifiers copy it into their diagnostics.
A record read from a file or a table (:meth:`Record.from_table`) keeps in
``meta["loaded"]`` where it came from and how: the source, the column map,
``fs=`` and, for a file, its SHA-256.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import DataError, InputError
from ..signal import derivatives
from ..signal.channelsource import ChannelSource
from .checks import (
    CHANNELS,
    DEFAULT_UNITS,
    TimeAxis,
    checked_fields,
    indexed_form,
    loaded_meta,
    merge_units,
    table_source,
)
from .columnmap import channel_arrays, column_units, dataset_table, frame_table, split_indexed
from .digest import record_sha256
from .structure_tables import indexed_channels, indexed_fields
from .units import parse_units

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd
    import xarray as xr

# CHANNELS ... RecordMeta are defined in nlid.data.checks (the rules a record obeys) and importable from here.
__all__ = [
    "Record",
]


@dataclass(frozen=True, eq=False)
class Record(TimeAxis):
    """A uniformly sampled force/motion record, of one DOF (1-D channels) or of a structure of ``n`` DOFs.

    Parameters
    ----------
    f
        External force on the mass, shape ``(N,)``; indexed: ``(N, n)`` with zero columns for DOFs without a
        force, or ``(N, m)`` / ``(N,)`` for the DOFs named by ``force_dofs``.
    z
        Displacement, shape ``(N,)``; indexed: ``(N, n)``.
    fs
        Sampling frequency in Hz.
    v, a
        Optional measured velocity and acceleration, shaped as ``z``.
    t0
        Time of the first sample in s.
    units
        The unit each channel is given in, e.g. ``{"z": "mm", "a": "g"}``
        (the vocabulary is :mod:`nlid.data.units`; a mapping or ``"z=mm,a=g"``);
        channels not named are SI (:data:`DEFAULT_UNITS`). Values are
        converted to SI on construction; afterwards this attribute holds the
        SI unit of each channel (``V``, ``V/s``... for an uncalibrated
        signal in volts, kept as given) and ``meta["input_units"]`` what
        each channel was given in. A time unit (``"t"``) applies to a time
        vector (:meth:`from_time`); ``fs`` is always in Hz.
    meta
        Free metadata. Keys nlid understands: ``mass`` (kg), ``g`` (m/s^2),
        ``source`` (str), ``periodic`` (the record is in periodic steady state: ``True``, whole periods of
        its own length, or the period in samples; ``False``: not periodic; kept by slicing while a part
        holds a whole period), ``reference`` (reference values:
        :meth:`nlid.identified.reference.Reference.from_meta`; a simulation's truth, a
        benchmark's published values; ``truth``, its earlier name, still
        reads), ``force_hold`` (``"sampled"``, the default: the
        force is a sampled continuous signal; or ``"zoh"``: it was held
        constant over each sample interval, as a DAC output or the paper's
        simulation).
    provenance
        How each channel was obtained; missing entries mean "measured".

    Raises
    ------
    DataError
        If any validation rule in the module docstring is broken.
    InputError
        A unit outside the vocabulary (the channel, the unit and the units
        accepted are named).
    """

    f: np.ndarray
    z: np.ndarray
    fs: float
    v: np.ndarray | None = None
    a: np.ndarray | None = None
    t0: float = 0.0
    units: Mapping[str, str] = field(default_factory=lambda: DEFAULT_UNITS)
    meta: Mapping[str, Any] = field(default_factory=dict)
    provenance: Mapping[str, str] = field(default_factory=dict)
    force_dofs: tuple[int, ...] | None = field(default=None, kw_only=True)
    indexed: bool = field(default=None, kw_only=True)  # type: ignore[assignment]

    def __post_init__(self) -> None:
        channels = {name: getattr(self, name) for name in CHANNELS}
        indexed = indexed_form(self.z, self.force_dofs, self.indexed)
        if indexed:
            fields = indexed_fields(self.fs, channels, self.force_dofs, self.units, self.meta, self.provenance)
        elif self.force_dofs is not None:
            raise InputError("force_dofs= names the driven DOFs of an indexed record, not of one with indexed=False")
        else:
            fields = checked_fields(self.fs, channels, self.units, self.meta, self.provenance)
        for name, value in {**fields, "indexed": indexed}.items():
            object.__setattr__(self, name, value)

    # ------------------------------------------------------------------ construction
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
        indexed: bool = False,
    ) -> Record:
        """Build a record from named columns under a column map; every source goes through here.

        Files (:func:`nlid.data.io.read_record`), DataFrames (:meth:`from_frame`),
        xarray Datasets (:meth:`from_xarray`) and mappings of arrays share
        this one path, so they share the rules and the messages.

        Parameters
        ----------
        table
            Column or variable name -> array (scalars serve as scale factors
            and ``fs``), e.g. ``{"t": t, "f": f, "z": z}``.
        columns
            Column map, ``"t=time,f=load_N,z=disp_mm*0.001"`` or
            ``{"f": "load_N", "z": "disp_mm*0.001"}`` (see
            :mod:`nlid.data.columnmap`); default: columns named like the channels
            ``t, f, z, v, a``. A channel may carry its unit:
            ``"z[mm]=disp, a[g]=acc"``.
        fs
            Sampling frequency in Hz when there is no time column.
        force_hold
            ``"sampled"`` (default) or ``"zoh"`` (see :class:`Record`).
        meta
            As for :class:`Record`.
        units
            The unit of each channel after the column map's scaling, e.g.
            ``{"z": "mm", "t": "ms"}`` (:mod:`nlid.data.units`); converted to SI.
            The same as ``z[mm]=`` in the column map (giving a channel two
            different units is an error).
        source
            What the table came from, named in error messages: the path of a
            file, or a word such as ``"DataFrame"``.
        indexed
            Read a structure's indexed channels (``z1=``, ``f1=``...; see
            :func:`nlid.data.columnmap.structure_arrays` for the rules) into an
            indexed record; ``units`` and the map's ``z2[mm]=`` may name single
            channels, and a velocity or acceleration given for some DOFs only
            is estimated for the others.

        Raises
        ------
        DataError
            A missing or non-numeric column, a non-finite value (channel and
            index named), a non-uniform time axis, or no sampling frequency.
        InputError
            A malformed column map, both a time column and ``fs=``, a bad
            ``force_hold``, or a unit outside the vocabulary.
        """
        named, label, noun = table_source(table, source)
        if indexed:
            kwargs, t, table_fs = indexed_channels(named, columns, fs, units, label, noun)
        else:
            given = merge_units(parse_units(units), column_units(columns))
            arrays, table_fs = channel_arrays(named, columns, fs=fs, source=label, noun=noun)
            kwargs = {"units": given, **{c: arrays[c] for c in CHANNELS if c in arrays}}
            t = arrays.get("t")
        meta, loaded = loaded_meta(meta, force_hold, label, columns, fs)
        try:
            if t is not None:
                record = cls.from_time(t, meta=meta, **kwargs)
            else:
                record = cls(fs=table_fs, meta=meta, **kwargs)
        except DataError as exc:
            raise DataError(f"{label}: {exc}") from None
        return record.with_meta(loaded={**loaded, "record_sha256": record_sha256(record)})

    @classmethod
    def from_frame(
        cls,
        frame: pd.DataFrame,
        columns: str | Mapping[str, str] | None = None,
        *,
        fs: float | None = None,
        force_hold: str | None = None,
        meta: Mapping[str, Any] | None = None,
        units: Mapping[str, str] | None = None,
        indexed: bool = False,
    ) -> Record:
        """Build a record from a pandas DataFrame, with the column map files use.

        ``Record.from_frame(df, "t=time,f=load_N,z=disp_mm*0.001")`` gives the
        same record as writing ``df`` to CSV and reading it with
        :func:`nlid.load`. Without a column map, columns named like the
        channels ``t, f, z, v, a`` are used.

        The index: a named index is one more column, so an index named ``t``
        is the time axis by default and one named ``time`` is mapped with
        ``t=time``; an unnamed index (such as the default ``RangeIndex``) is
        ignored, and then ``fs=`` gives the sampling frequency. Durations
        (``timedelta``) become seconds; dates are refused.

        Parameters
        ----------
        frame
            The data.
        columns, fs, force_hold, meta, units, indexed
            As for :meth:`from_table`: ``Record.from_frame(df, "t=time,f=load,z=disp",
            units={"z": "mm"})`` converts ``disp`` from mm to m.

        Raises
        ------
        DataError, InputError
            As for :meth:`from_table`; the messages name ``DataFrame`` where a
            file's name its path.
        """
        import pandas as pd

        if not isinstance(frame, pd.DataFrame):
            raise InputError(f"Record.from_frame needs a pandas DataFrame, got {type(frame).__name__}")
        table = frame_table(frame, "DataFrame")
        return cls.from_table(
            table, columns, fs=fs, force_hold=force_hold, meta=meta, units=units, source="DataFrame", indexed=indexed
        )

    @classmethod
    def from_xarray(
        cls,
        dataset: xr.Dataset,
        columns: str | Mapping[str, str] | None = None,
        *,
        fs: float | None = None,
        force_hold: str | None = None,
        meta: Mapping[str, Any] | None = None,
        units: Mapping[str, str] | None = None,
    ) -> Record:
        """Build a record from an xarray Dataset, with the column map files use.

        Its coordinates and data variables are the columns (a time coordinate
        named ``t`` is the time axis by default; one named ``time`` is mapped
        with ``t=time``); 0-d variables are scalars, usable as scale factors
        or as ``fs``. xarray is optional: nlid never imports it.

        Parameters
        ----------
        dataset
            The data.
        columns, fs, force_hold, meta, units
            As for :meth:`from_table`.

        Raises
        ------
        DataError, InputError
            As for :meth:`from_table`; the messages name ``Dataset``.
        """
        if not (hasattr(dataset, "data_vars") and hasattr(dataset, "coords")):
            raise InputError(f"Record.from_xarray needs an xarray Dataset, got {type(dataset).__name__}")
        table = dataset_table(dataset, "Dataset")
        return cls.from_table(table, columns, fs=fs, force_hold=force_hold, meta=meta, units=units, source="Dataset")

    # ------------------------------------------------------------------ properties
    @property
    def n(self) -> int:
        """Number of samples."""
        return int(self.z.shape[0])

    @property
    def n_dofs(self) -> int:
        """Number of degrees of freedom (1 for 1-D channels)."""
        return int(self.z.shape[1]) if self.indexed else 1

    @property
    def groups(self) -> tuple[str, ...]:
        """The quantities present, in :data:`CHANNELS` order (``f`` and ``z`` always)."""
        return tuple(g for g in CHANNELS if getattr(self, g) is not None)

    @property
    def channels(self) -> tuple[str, ...]:
        """The channel names, in the order files are written: ``f, z, v, a`` present; indexed, the driven
        forces, then ``z1..zn``, ``v``, ``a``."""
        if not self.indexed:
            return self.groups
        out = list(_names("f", self.force_dofs))
        for g in self.groups[1:]:
            out += _names(g, range(1, self.n_dofs + 1))
        return tuple(out)

    def channel(self, name: str) -> np.ndarray:
        """One channel by name, e.g. ``record.channel("a2")`` of an indexed record, ``"a"`` of 1-D ones (read-only)."""
        if not self.indexed:
            if name not in self.channels:
                raise InputError(f"record has no channel {name!r}; its channels are {', '.join(self.channels)}")
            return getattr(self, name)
        parts = split_indexed(name) if isinstance(name, str) else None
        if parts is None or parts[1] > self.n_dofs or getattr(self, parts[0]) is None:
            raise InputError(f"record has no channel {name!r}; its channels are {', '.join(self.channels)}")
        return getattr(self, parts[0])[:, parts[1] - 1]

    @property
    def mass(self) -> Any:
        """``meta['mass']`` if present (kg): a float for 1-D channels; indexed, an ``(n, n)`` matrix (a vector
        is a lumped mass)."""
        m = self.meta.get("mass")
        if m is None or not self.indexed:
            return None if m is None else float(m)
        from ..model.structure import as_matrix

        return as_matrix(m, self.n_dofs, "the record's mass (meta['mass'], a file's .meta.json sidecar)", positive=True)

    def is_measured(self, channel: str) -> bool:
        """True if ``channel`` is present and was measured (possibly resampled), not estimated."""
        if not self.indexed:
            return getattr(self, channel, None) is not None and self.source_of(channel).startswith("measured")
        try:
            self.channel(channel)
        except InputError:
            return False
        return self.source_of(channel).startswith("measured")

    def __repr__(self) -> str:
        src = self.meta.get("source", "")
        tail = ", source=" + str(src) if src else ""
        if self.indexed:
            return (
                f"StructureRecord(n={self.n}, fs={self.fs:g} Hz, dofs={self.n_dofs}, "
                f"forces={','.join(_names('f', self.force_dofs))}, channels={','.join(self.groups)}{tail})"
            )
        return f"Record(n={self.n}, fs={self.fs:g} Hz, channels={','.join(self.channels)}{tail})"

    # ------------------------------------------------------------------ views
    def dof(self, k: int) -> Record:
        """A one-DOF record (1-D channels) of DOF ``k`` (1-based): its z, v, a and its own force.

        For plots and per-DOF figures: the coupling to the other DOFs is not
        in it. ``meta`` keeps ``source`` and ``force_hold``, says
        ``dof = k``, and gives ``mass`` when the mass matrix is known and
        diagonal; the structure's reference is not a one-DOF reference and is
        left out. A record of 1-D channels is its own DOF 1.

        Raises
        ------
        InputError
            ``k`` is not a DOF of the record.
        DataError
            No force acts on DOF ``k`` (a one-DOF record needs one).
        """
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not 1 <= k <= self.n_dofs:
            raise InputError(f"dof must be a DOF number from 1 to {self.n_dofs}, got {k!r}")
        if not self.indexed:
            return self
        if k not in self.force_dofs:
            raise DataError(
                f"no force acts on DOF {k} (forces: {', '.join(_names('f', self.force_dofs))}); "
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

    def as_indexed(self) -> Record:
        """This record in the indexed form: a one-DOF record as a structure of one DOF (``z1``, ``f1``...)."""
        if self.indexed:
            return self
        prov = {f"{c}1": p for c, p in self.provenance.items()}
        arrays = {g: getattr(self, g) for g in self.groups}
        return Record(fs=self.fs, t0=self.t0, meta=dict(self.meta), provenance=prov, indexed=True, **arrays)

    # ------------------------------------------------------------------ derived records
    def with_velocity_from_acceleration(self, highpass: float | None = None) -> Record:
        """Replace ``v`` by the drift-free integral of the measured ``a`` (1-D channels).

        See :func:`nlid.signal.derivatives.integrate`.
        """
        if self.indexed:
            raise InputError("with_velocity_from_acceleration is for a record of one DOF's 1-D channels")
        if self.a is None:
            raise DataError("record has no acceleration channel to integrate")
        v, hp = derivatives.integrate(self.a, self.fs, highpass=highpass)
        prov = dict(self.provenance)
        prov["v"] = ChannelSource.integrated(hp, "a").text
        return replace(self, v=v, provenance=prov)

    def without(self, *channels: str) -> Record:
        """A copy without the optional channels named (``"v"`` and/or ``"a"``; indexed, every DOF's)."""
        word = "quantities" if self.indexed else "channels"
        for c in channels:
            if c not in ("v", "a"):
                raise InputError(f"only the optional {word} 'v' and 'a' can be dropped, not {c!r}")
        prov = {k: p for k, p in self.provenance.items() if k.rstrip("0123456789") not in channels}
        return replace(self, provenance=prov, **{c: None for c in channels})

    def to_dict(self) -> dict[str, np.ndarray]:
        """``t`` and every channel (:attr:`channels`) as a dictionary of 1-D arrays."""
        out = {"t": self.t}
        out.update({c: self.channel(c) for c in self.channels})
        return out


def _names(group: str, dofs: Any) -> tuple[str, ...]:
    """``("z1", "z2", ...)``: the names of a quantity's channels for the given DOFs (1-based)."""
    return tuple(f"{group}{k}" for k in dofs)
