"""The rules a :class:`~nlid.data.record.Record` obeys, checked on construction.

The channel names (:data:`CHANNELS`) and their SI units (:data:`DEFAULT_UNITS`);
:func:`checked_fields`, which turns the fields a record is given into the ones
it holds (each channel a read-only float array in SI units, equal lengths, at
least :data:`MIN_SAMPLES` samples, finite, not constant; the metadata as
:class:`RecordMeta`); and :func:`uniform_step`, the check of a time vector
(uniform within :data:`TIME_TOLERANCE`). The rules themselves are listed in
the docstring of :mod:`nlid.data.record`, which re-exports these names.
"""

from __future__ import annotations

import dataclasses
import numbers
import os
from collections.abc import Mapping
from types import MappingProxyType
from typing import Any, Self

import numpy as np

from ..base.frozen import FrozenDict
from ..errors import DataError, InputError
from ..signal import derivatives
from ..signal.channelsource import ChannelSource
from .units import Unit, parse_units, unit_of

__all__ = [
    "TimeAxis",
    "indexed_form",
    "CHANNELS",
    "MIN_SAMPLES",
    "TIME_TOLERANCE",
    "DEFAULT_UNITS",
    "META_ALIASES",
    "RecordMeta",
    "checked_fields",
    "checked_meta",
    "uniform_step",
    "real_array",
    "merge_units",
    "freeze",
    "table_source",
    "loaded_meta",
]

#: Channel names, in the order they are written to files.
CHANNELS = ("f", "z", "v", "a")
#: Smallest number of samples a record may have.
MIN_SAMPLES = 32
#: Largest relative deviation of a time step from the median step.
TIME_TOLERANCE = 1e-3
#: SI units of the channels.
DEFAULT_UNITS: Mapping[str, str] = MappingProxyType({"f": "N", "z": "m", "v": "m/s", "a": "m/s^2", "t": "s"})


def freeze(mapping: Mapping[str, Any] | None) -> Mapping[str, Any]:
    """A read-only copy that pickles (records cross process boundaries: studies, ``identify(timeout=)``)."""
    return FrozenDict(dict(mapping or {}))


def table_source(table: Any, source: str | os.PathLike[str]) -> tuple[Mapping[str, Any], str, str]:
    """A table's columns by name, and its source as messages name it (``label``) and as a noun (``"file"``)."""
    if not isinstance(table, Mapping):
        raise InputError(f"a table must map column names to arrays, got {type(table).__name__}")
    if isinstance(source, os.PathLike):
        label, noun = os.fspath(source), "file"
    else:
        label = noun = str(source)
    named = table if all(isinstance(k, str) for k in table) else {str(k): v for k, v in table.items()}
    return named, label, noun


def loaded_meta(
    meta: Mapping[str, Any] | None, force_hold: str | None, label: str, columns: Any, fs: float | None
) -> tuple[dict[str, Any], dict[str, Any]]:
    """The metadata of a record read from a table (``force_hold=`` checked), and its ``meta["loaded"]``."""
    meta = dict(meta or {})
    if force_hold is not None:
        if force_hold not in ("sampled", "zoh"):
            raise InputError(f"force_hold must be 'sampled' or 'zoh', got {force_hold!r}")
        meta["force_hold"] = force_hold
        meta["force_hold_source"] = "option"
    loaded = {**dict(meta.get("loaded") or {}), "source": label}
    loaded["columns"] = dict(columns) if isinstance(columns, Mapping) else (columns or None)
    loaded["fs"] = fs
    meta["loaded"] = loaded
    return meta, loaded


#: Earlier names of metadata keys: ``{old: current}``. A record stores the current name; the old one still reads.
META_ALIASES: Mapping[str, str] = MappingProxyType({"truth": "reference"})


class RecordMeta(FrozenDict):
    """A record's metadata: read-only, each entry under one name; an earlier name (:data:`META_ALIASES`) still reads.

    ``meta["truth"]`` and ``meta.get("truth")`` give ``meta["reference"]`` (simulated records carried their
    truth under ``"truth"`` before); the old name is not a key (``"truth" in meta`` is false).
    """

    __slots__ = ()

    @classmethod
    def of(cls, mapping: Mapping[str, Any] | None) -> RecordMeta:
        """The metadata of ``mapping`` with entries under an earlier name moved to the current one."""
        items = dict(mapping or {})
        for old, new in META_ALIASES.items():
            if old in items and new not in items:
                items[new] = items.pop(old)
        return cls(items)

    def __missing__(self, key: str) -> Any:
        new = META_ALIASES.get(key)
        if new is not None and dict.__contains__(self, new):
            return dict.__getitem__(self, new)
        raise KeyError(key)

    def get(self, key: str, default: Any = None) -> Any:
        """``meta[key]`` (an earlier name included), else ``default``."""
        try:
            return self[key]
        except KeyError:
            return default


def merge_units(given: dict[str, Unit], mapped: Mapping[str, str], *, indexed: bool = False) -> dict[str, Unit]:
    """The units of ``units=`` and those of the column map (``z[mm]=disp``); the same channel twice must agree.

    With ``indexed`` (a structure's channels), a quantity's unit in ``units=`` (``z``) applies to each of
    its channels (``z2[mm]=`` in the map must agree with it unless ``units=`` names ``z2`` itself).
    """
    out = dict(given)
    for channel, text in mapped.items():
        unit = unit_of(channel, text, where="column map", indexed=indexed)
        for key in (channel, channel.rstrip("0123456789")):
            if key in out and out[key] != unit and (key == channel or channel not in out):
                raise InputError(
                    f"the unit of {channel!r} is given twice: {out[key].symbol!r} in units= "
                    f"and {unit.symbol!r} in the column map"
                )
        out[channel] = unit
    return out


def real_array(name: str, raw: Any) -> np.ndarray:
    """A channel as a new float array; complex, boolean, text and other non-numbers are refused, not cast."""
    arr = np.asarray(raw)
    kind = arr.dtype.kind
    if kind == "c":
        raise DataError(f"channel {name!r} holds complex numbers; nlid needs real ones (take .real or abs)")
    if kind == "b":
        raise DataError(
            f"channel {name!r} holds booleans (True/False), not numbers: a measured signal cannot be boolean"
        )
    try:
        return np.array(arr, dtype=float) if kind in "iuf" else _objects_as_floats(arr)
    except (TypeError, ValueError):
        what = "text" if kind in "US" else f"values of type {arr.dtype}"
        raise DataError(f"channel {name!r} holds {what}, not numbers") from None


def _objects_as_floats(arr: np.ndarray) -> np.ndarray:
    """Numbers held as objects (``Decimal``, ``Fraction``...) as floats; anything else raises TypeError/ValueError."""
    if arr.dtype.kind != "O" or any(
        isinstance(x, (bool, np.bool_, complex, np.complexfloating, str, bytes)) for x in arr.flat
    ):
        raise TypeError(arr.dtype)
    return np.array(arr, dtype=float)


def checked_fields(
    fs: Any,
    channels: Mapping[str, Any],
    units: Any,
    meta: Mapping[str, Any] | None,
    provenance: Mapping[str, str] | None,
) -> dict[str, Any]:
    """The fields of a record as it holds them, from those it was given; every rule of :mod:`nlid.data.record` checked.

    Parameters
    ----------
    fs
        The sampling frequency (Hz).
    channels
        ``{name: array or None}`` for each name of :data:`CHANNELS`.
    units, meta, provenance
        As given to :class:`~nlid.data.record.Record`.

    Returns
    -------
    dict
        ``fs`` (a float), each channel given (a new read-only float array in SI units), ``units`` (the SI
        unit of each channel), ``meta`` (a :class:`RecordMeta`, with ``input_units`` when a channel was
        converted) and ``provenance`` (read-only).

    Raises
    ------
    DataError
        A broken rule (the channel and, for a non-finite value, the first bad index named).
    InputError
        A unit outside the vocabulary, or a time unit other than s (``fs`` is always in Hz).
    """
    declared = parse_units(units)
    time_unit = declared.get("t")
    if time_unit is not None and not time_unit.is_si:
        raise InputError(
            f"units: t in {time_unit.symbol!r} applies to a time vector (Record.from_time, or a time column); "
            "fs= is always in Hz"
        )
    rate = float(fs)
    if not np.isfinite(rate) or rate <= 0:
        raise DataError(f"sampling frequency must be a positive number, got {fs!r}")
    out: dict[str, Any] = {"fs": rate}
    n = None
    for name in CHANNELS:
        raw = channels.get(name)
        if raw is None:
            if name in ("f", "z"):
                raise DataError(f"channel {name!r} is required")
            continue
        arr = real_array(name, raw)  # a private copy
        if arr.ndim != 1:
            arr = arr.squeeze()
            if arr.ndim != 1:
                raise DataError(f"channel {name!r} must be one-dimensional, got shape {np.shape(raw)}")
        bad = ~np.isfinite(arr)
        if bad.any():
            i = int(np.argmax(bad))
            raise DataError(f"channel {name!r} has a non-finite value ({arr[i]}) at index {i}")
        if n is None:
            n = arr.size
        elif arr.size != n:
            raise DataError(f"channel {name!r} has {arr.size} samples but 'f' has {n}")
        unit = declared.get(name)
        if unit is not None and unit.factor != 1.0:
            arr *= unit.factor
        arr.setflags(write=False)
        out[name] = arr
    assert n is not None
    if n < MIN_SAMPLES:
        raise DataError(f"record has {n} samples; at least {MIN_SAMPLES} are needed")
    for name in CHANNELS:
        arr = out.get(name)
        if arr is not None and np.ptp(arr) == 0.0:
            raise DataError(f"channel {name!r} is constant ({arr[0]}); nothing can be identified from it")
    si = dict(DEFAULT_UNITS)
    si.update({c: u.si for c, u in declared.items()})
    out["units"] = freeze(si)
    return {**out, **checked_meta(meta, provenance, declared, n)}


def checked_meta(
    meta: Mapping[str, Any] | None, provenance: Mapping[str, str] | None, declared: Mapping[str, Unit], n: int
) -> dict[str, Any]:
    """A record's ``meta`` (a :class:`RecordMeta`, with ``input_units`` for each channel ``declared`` in a unit
    other than SI) and ``provenance`` (read-only), checked: ``force_hold`` and ``periodic`` (of ``n`` samples).
    """
    if meta and meta.get("force_hold", "sampled") not in ("sampled", "zoh"):
        raise DataError(f"meta['force_hold'] must be 'sampled' or 'zoh', got {meta['force_hold']!r}")
    periodic = meta.get("periodic") if meta else None
    if periodic is not None and not isinstance(periodic, bool):
        if not isinstance(periodic, numbers.Integral) or not 2 <= periodic <= n:
            raise DataError(f"meta['periodic'] must be true, false or a period of 2 to {n} samples, not {periodic}")
    converted = {c: u.to_dict() for c, u in declared.items() if not u.is_si}
    if converted:
        meta = dict(meta or {})
        meta["input_units"] = {**dict(meta.get("input_units") or {}), **converted}
    return {"meta": RecordMeta.of(meta), "provenance": freeze(provenance)}


def uniform_step(t: np.ndarray) -> float:
    """The time step of a time vector (s) that is one-dimensional, finite, increasing and uniform.

    Every step may differ from the median step by at most :data:`TIME_TOLERANCE` (relative).

    Raises
    ------
    DataError
        A time vector that breaks the rule (the first bad index or step named).
    """
    if t.ndim != 1 or t.size < 2:
        raise DataError("time vector must be one-dimensional with at least 2 samples")
    bad = ~np.isfinite(t)
    if bad.any():
        raise DataError(f"channel 't' has a non-finite value at index {int(np.argmax(bad))}")
    dt = np.diff(t)
    step = float(np.median(dt))
    if step <= 0:
        raise DataError("time vector is not increasing")
    dev = np.abs(dt - step) / step
    if dev.max() > TIME_TOLERANCE:
        i = int(np.argmax(dev))
        raise DataError(
            f"time axis is not uniform: step {i} is {dt[i]:.6g} s but the median step is {step:.6g} s "
            f"(tolerance {TIME_TOLERANCE:g} relative)"
        )
    return step


def indexed_form(z: Any, force_dofs: Any, indexed: bool | None) -> bool:
    """Whether a record is built in its indexed form (a structure's channels ``z1 .. zn``).

    ``indexed`` when given; else when ``force_dofs`` is given or ``z`` has more than one column (a
    one-column ``z`` is squeezed to one DOF's 1-D channel, as it always was).
    """
    if indexed is not None:
        return bool(indexed)
    return force_dofs is not None or (np.ndim(z) == 2 and np.shape(z)[1] > 1)


class TimeAxis:
    """The time axis of a :class:`~nlid.data.record.Record`, in either form (1-D channels or a structure's
    ``(N, n)``): its length, step, duration and sample times, how its force was held, where each channel
    came from, and the copies that change its metadata or keep part of its samples.

    The class defines ``n`` (samples), ``fs`` (Hz), ``t0`` (s), ``meta``, ``provenance`` and slicing by
    sample index (``record[i0:i1]``).
    """

    n: int
    fs: float
    t0: float
    meta: Mapping[str, Any]
    provenance: Mapping[str, str]

    @classmethod
    def from_time(cls, t: np.ndarray, f: np.ndarray, z: np.ndarray, **kwargs: Any) -> Self:
        """Build a record from a time vector, checking that it is uniform.

        Parameters
        ----------
        t
            Sample times in s, strictly increasing and uniform within
            :data:`TIME_TOLERANCE`.
        f, z, **kwargs
            As for the record's class (``fs`` and ``t0`` are taken from ``t``);
            ``units={"t": "ms"}`` says that ``t`` is in ms.
        """
        indexed = indexed_form(z, kwargs.get("force_dofs"), kwargs.get("indexed"))
        units = dict(parse_units(kwargs.pop("units", None), indexed=indexed))
        time_unit = units.pop("t", None)
        t = real_array("t", t).squeeze()
        if time_unit is not None and not time_unit.is_si:
            t = t * time_unit.factor
            meta = dict(kwargs.pop("meta", None) or {})
            meta["input_units"] = {**dict(meta.get("input_units") or {}), "t": time_unit.to_dict()}
            kwargs["meta"] = meta
        step = uniform_step(t)
        return cls(f=f, z=z, fs=1.0 / step, t0=float(t[0]), units=units, **kwargs)  # type: ignore[call-arg]

    # ------------------------------------------------------------------ one DOF (1-D channels) and n DOFs ((N, n))
    def _arrays(self, transform: Any) -> dict[str, np.ndarray]:
        """``transform`` of each quantity present (``f``, ``z``, ``v``, ``a``), by name."""
        return {g: transform(getattr(self, g)) for g in CHANNELS if getattr(self, g, None) is not None}

    def _column(self, group: str, k: int | None) -> str:
        """The name of a quantity's channel: ``"z"`` for one DOF (``k`` is ``None``), ``"z2"`` for column 1."""
        return group if k is None else f"{group}{k + 1}"

    def _columns(self) -> list[int | None]:
        """The column of each DOF, ``[None]`` for a record of 1-D channels."""
        z = self.z  # type: ignore[attr-defined]
        return [None] if z.ndim == 1 else list(range(z.shape[1]))

    def _steps(self, step: str) -> dict[str, str]:
        """The provenance of every channel with ``step`` appended."""
        return {c: f"{self.source_of(c)}; {step}" for c in self.channels}  # type: ignore[attr-defined]

    def _periodic_meta(self, n: int, up: int = 1, down: int = 1) -> Mapping[str, Any]:
        """The metadata of a part of ``n`` samples at ``up / down`` times the rate: ``meta["periodic"]`` there.

        A declared period (``True``: the record's length) stays the part's period (in its own samples) while
        the part holds a whole period of a whole number of samples, so that a held-out part of a periodic
        record is scored periodic; otherwise the key is dropped.
        """
        periodic = self.meta.get("periodic")
        if periodic is None or periodic is False:
            return self.meta
        period = self.n if periodic is True else int(periodic)
        meta = dict(self.meta)
        new, rest = divmod(period * up, down)
        if rest == 0 and 2 <= new <= n:
            meta["periodic"] = True if new == n else new
        else:
            del meta["periodic"]
        return meta

    def __getitem__(self, item: slice) -> Self:
        """Slice by sample index: ``record[1000:5000]`` or ``record[::2]``.

        A step other than 1 is plain down-sampling without anti-aliasing; use
        :meth:`decimate` for that.
        """
        if not isinstance(item, slice):
            raise TypeError("records are sliced with a slice, e.g. record[100:2000]")
        start, _, step = item.indices(self.n)
        arrays = self._arrays(lambda x: x[item])
        meta = self._periodic_meta(arrays["z"].shape[0], 1, step)
        return dataclasses.replace(  # type: ignore[type-var]
            self, fs=self.fs / step, t0=self.t0 + start / self.fs, meta=meta, **arrays
        )

    def decimate(self, q: int) -> Self:
        """Reduce the sampling frequency by an integer factor with anti-aliasing.

        Each channel is low-passed at 80 % of the new Nyquist frequency by a
        Butterworth filter of order 8 applied forwards and backwards
        (zero-phase, maximally flat: the gain error is below 1e-6 up to a
        third of the cut-off), then every ``q``-th sample is kept. (scipy's
        default Chebyshev filter is avoided: its 0.05 dB ripple, doubled by the
        zero-phase pass, changes amplitudes by up to 1.2 %.)
        """
        q = int(q)
        if q < 1:
            raise InputError(f"decimation factor must be a positive integer, got {q}")
        if q == 1:
            return self
        cutoff = 0.8 * self.fs / (2 * q)

        def down(x: np.ndarray) -> np.ndarray:
            if x.ndim == 1:
                return derivatives.lowpass(x, self.fs, cutoff, order=8)[::q]
            return np.stack([derivatives.lowpass(x[:, k], self.fs, cutoff, order=8)[::q] for k in range(x.shape[1])], 1)

        arrays = self._arrays(down)
        if arrays["f"].ndim == 2:  # the force columns of the DOFs not driven stay exactly zero
            driven = self.force_dofs  # type: ignore[attr-defined]
            arrays["f"][:, [k for k in range(arrays["f"].shape[1]) if k + 1 not in driven]] = 0.0
        meta = self._periodic_meta(arrays["z"].shape[0], 1, q)
        return dataclasses.replace(  # type: ignore[type-var]
            self, fs=self.fs / q, provenance=self._steps(f"decimated by {q}"), meta=meta, **arrays
        )

    def resample(self, fs: float) -> Self:
        """Resample to a new sampling frequency (polyphase, anti-aliased).

        The ratio ``fs / self.fs`` is approximated by a fraction with a
        denominator of at most 1000.
        """
        from fractions import Fraction

        from scipy import signal

        ratio = Fraction(float(fs) / self.fs).limit_denominator(1000)
        if ratio == 1:
            return self
        arrays = self._arrays(lambda x: signal.resample_poly(x, ratio.numerator, ratio.denominator, axis=0))
        new_fs = self.fs * ratio.numerator / ratio.denominator
        meta = self._periodic_meta(arrays["z"].shape[0], ratio.numerator, ratio.denominator)
        provenance = self._steps(f"resampled to {new_fs:g} Hz")
        return dataclasses.replace(self, fs=new_fs, provenance=provenance, meta=meta, **arrays)  # type: ignore[type-var]

    def suggest_cutoff(self) -> float:
        """One cut-off (Hz) for every DOF: the highest :func:`nlid.signal.derivatives.suggest_cutoff` of the
        displacements.

        One filter for all DOFs keeps their estimated channels in phase with each other.
        """
        z = self.z  # type: ignore[attr-defined]
        return max(derivatives.suggest_cutoff(z if k is None else z[:, k], self.fs) for k in self._columns())

    def with_derivatives(
        self, *, cutoff: float | None = None, velocity: bool = True, acceleration: bool = True, overwrite: bool = False
    ) -> Self:
        """Fill in missing velocity/acceleration channels by estimation, DOF by DOF.

        Velocity comes from differentiating ``z`` unless ``v`` is present
        (integrating a measured ``a`` loses the low frequencies; ask for it
        explicitly with ``with_velocity_from_acceleration``). Acceleration
        comes from differentiating a measured ``v`` when there is one, else
        from differentiating ``z`` twice. See :mod:`nlid.signal.derivatives` for the
        filters.

        Parameters
        ----------
        cutoff
            Low-pass cut-off in Hz for the differentiating filter, one for every DOF (default:
            :meth:`suggest_cutoff`).
        velocity, acceleration
            Which channels to provide.
        overwrite
            Re-estimate channels even when they are present.
        """
        if cutoff is None:
            cutoff = self.suggest_cutoff()
        changes: dict[str, Any] = {}
        prov = dict(self.provenance)

        def derive(group: str, source: Any) -> np.ndarray:
            out = np.empty(self.z.shape)  # type: ignore[attr-defined]
            for k in self._columns():
                name, order = source(k)
                x = getattr(self, name) if k is None else getattr(self, name)[:, k]
                column, used = derivatives.differentiate(x, self.fs, order=order, cutoff=cutoff)
                prov[self._column(group, k)] = ChannelSource.differentiated(used, self._column(name, k)).text
                if k is None:
                    out = column
                else:
                    out[:, k] = column
            return out

        if velocity and (self.v is None or overwrite):  # type: ignore[attr-defined]
            changes["v"] = derive("v", lambda k: ("z", 1))
        if acceleration and (self.a is None or overwrite):  # type: ignore[attr-defined]
            measured = self.is_measured  # type: ignore[attr-defined]
            changes["a"] = derive(
                "a", lambda k: ("v", 1) if measured(self._column("v", k)) and not overwrite else ("z", 2)
            )
        if not changes:
            return self
        return dataclasses.replace(self, provenance=prov, **changes)  # type: ignore[type-var]

    @property
    def force_hold(self) -> str:
        """``"zoh"`` if the force was held over each sample, else ``"sampled"``."""
        return str(self.meta.get("force_hold", "sampled"))

    def source_of(self, channel: str) -> str:
        """How ``channel`` (``"v"``, a structure's ``"v2"``) was obtained ("measured" unless estimated)."""
        return self.provenance.get(channel, "measured")

    def channel_source(self, channel: str) -> ChannelSource:
        """:meth:`source_of` as a :class:`~nlid.signal.channelsource.ChannelSource`: measured or not, and its line."""
        text = self.source_of(channel)
        return ChannelSource.from_text(text, text.startswith("measured"))

    def replace(self, **changes: Any) -> Self:
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)  # type: ignore[type-var]

    def with_meta(self, **items: Any) -> Self:
        """A copy with metadata entries added or replaced."""
        meta = dict(self.meta)
        meta.update(items)
        return dataclasses.replace(self, meta=meta)  # type: ignore[type-var]

    def time_slice(self, start: float | None = None, stop: float | None = None) -> Self:
        """The samples with ``start <= t < stop`` (times in s)."""
        t = self.t
        i0 = 0 if start is None else int(np.searchsorted(t, start - 1e-9 / self.fs))
        i1 = self.n if stop is None else int(np.searchsorted(t, stop - 1e-9 / self.fs))
        return self[i0:i1]

    def split(self, fraction: float) -> tuple[Self, Self]:
        """Split into an estimation part and a held-out part.

        Parameters
        ----------
        fraction
            Fraction of samples in the held-out (second) part, ``0 < fraction < 1``.
        """
        if not 0.0 < fraction < 1.0:
            raise InputError(f"hold-out fraction must be between 0 and 1, got {fraction}")
        cut = int(round(self.n * (1.0 - fraction)))
        return self[:cut], self[cut:]

    def __len__(self) -> int:
        return self.n

    @property
    def dt(self) -> float:
        """Sampling interval in s."""
        return 1.0 / self.fs

    @property
    def duration(self) -> float:
        """Length of the record in s (``n / fs``)."""
        return self.n / self.fs

    @property
    def t(self) -> np.ndarray:
        """Time of each sample in s."""
        return self.t0 + np.arange(self.n) / self.fs
