"""The measured (or simulated) record every identifier works on.

A :class:`Record` holds uniformly sampled channels of a single-degree-of-freedom
test: the external force ``f`` on the mass (N; for base excitation
``f = -m * b''``), the displacement ``z`` (m) and, when measured, the velocity
``v`` (m/s) and acceleration ``a`` (m/s^2). It is validated on construction and
never modified in place: slicing, decimation and channel estimation return new
records.

Validation rules
----------------
* every channel is one-dimensional, of equal length, at least
  :data:`MIN_SAMPLES` long, finite (the error names the channel and the first
  bad index) and not constant;
* a time vector, when given (:meth:`Record.from_time`), is strictly increasing
  and uniform: every step may differ from the median step by at most
  :data:`TIME_TOLERANCE` (relative), which accepts time stamps written with
  six or more significant digits but rejects dropped or repeated samples.

The checks, and the names above, are in :mod:`nlid.data.checks`.

Units
-----
A record holds SI values (N, m, m/s, m/s^2, s). Data in other units are
declared with ``units=`` (``{"z": "mm", "a": "g"}``; the vocabulary is
:mod:`nlid.data.units`) and converted on construction; a unit outside the
vocabulary is refused. :attr:`Record.units` then holds the SI unit of each
channel, and ``meta["input_units"]`` what each channel was given in and the
factor applied (``{"z": {"unit": "mm", "si": "m", "factor": 0.001}}``).

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
    loaded_meta,
    merge_units,
    table_source,
)
from .columnmap import channel_arrays, column_units, dataset_table, frame_table
from .digest import record_sha256
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
    """A uniformly sampled force/motion record.

    Parameters
    ----------
    f
        External force on the mass, shape ``(N,)``.
    z
        Displacement, shape ``(N,)``.
    fs
        Sampling frequency in Hz.
    v, a
        Optional measured velocity and acceleration.
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

    def __post_init__(self) -> None:
        channels = {name: getattr(self, name) for name in CHANNELS}
        for name, value in checked_fields(self.fs, channels, self.units, self.meta, self.provenance).items():
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
        given = merge_units(parse_units(units), column_units(columns))
        arrays, table_fs = channel_arrays(named, columns, fs=fs, source=label, noun=noun)
        meta, loaded = loaded_meta(meta, force_hold, label, columns, fs)
        kwargs: dict[str, Any] = {c: arrays[c] for c in CHANNELS if c in arrays}
        try:
            if "t" in arrays:
                record = cls.from_time(arrays["t"], meta=meta, units=given, **kwargs)
            else:
                record = cls(fs=table_fs, meta=meta, units=given, **kwargs)
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
        columns, fs, force_hold, meta, units
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
        return cls.from_table(table, columns, fs=fs, force_hold=force_hold, meta=meta, units=units, source="DataFrame")

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
        return int(self.z.size)

    @property
    def channels(self) -> tuple[str, ...]:
        """Names of the channels present, in :data:`CHANNELS` order."""
        return tuple(c for c in CHANNELS if getattr(self, c) is not None)

    @property
    def mass(self) -> float | None:
        """``meta['mass']`` if present (kg)."""
        m = self.meta.get("mass")
        return None if m is None else float(m)

    def is_measured(self, channel: str) -> bool:
        """True if ``channel`` is present and was measured (possibly resampled), not estimated."""
        return getattr(self, channel, None) is not None and self.source_of(channel).startswith("measured")

    def __repr__(self) -> str:
        src = self.meta.get("source", "")
        chans = ",".join(self.channels)
        return f"Record(n={self.n}, fs={self.fs:g} Hz, channels={chans}{', source=' + str(src) if src else ''})"

    # ------------------------------------------------------------------ derived records
    def with_velocity_from_acceleration(self, highpass: float | None = None) -> Record:
        """Replace ``v`` by the drift-free integral of the measured ``a``.

        See :func:`nlid.signal.derivatives.integrate`.
        """
        if self.a is None:
            raise DataError("record has no acceleration channel to integrate")
        v, hp = derivatives.integrate(self.a, self.fs, highpass=highpass)
        prov = dict(self.provenance)
        prov["v"] = ChannelSource.integrated(hp, "a").text
        return replace(self, v=v, provenance=prov)

    def without(self, *channels: str) -> Record:
        """A copy without the optional channels named (``"v"`` and/or ``"a"``)."""
        for c in channels:
            if c not in ("v", "a"):
                raise InputError(f"only the optional channels 'v' and 'a' can be dropped, not {c!r}")
        prov = {k: p for k, p in self.provenance.items() if k not in channels}
        return replace(self, provenance=prov, **{c: None for c in channels})

    def to_dict(self) -> dict[str, np.ndarray]:
        """The channels (and ``t``) as a dictionary of arrays."""
        out = {"t": self.t}
        out.update({c: getattr(self, c) for c in self.channels})
        return out
