"""The input path: what happens to the measured force before it acts on the structure.

A force channel records a command or a sensor reading; the force that acts on the
moving mass may be a delayed and smoothed copy of it (a drive's current loop, a shaker's
amplifier, an anti-aliasing filter, a clock offset between two acquisition cards), or held
differently between samples than the record says. None of this is a term of the restoring
force ``R(z, v) = f - m a``: it is a property of the input. :class:`InputPath` states it,
and every part of nlid that uses a record's force with an identified model goes through
:meth:`InputPath.apply` (identification, the equation error, free runs, predictions,
simulation), so that an input path found on the estimation record acts the same way on every
record the model is scored on.

The acting force is the recorded one through ``H(s) = exp(-s d) / (1 + s tau)``:

``delay`` (``d``, seconds)
    a pure delay between the force channel and the force that acts (sub-sample values are
    allowed); negative when the force channel is the late one (an anti-aliasing filter on the
    force sensor, a clock offset), which offline data allow;
``lag`` (``tau``, seconds)
    a first-order low-pass (an actuator or amplifier lag);
``hold``
    how the force behaves between samples (``"zoh"``: held; ``"sampled"``: band-limited),
    when it differs from what the record declares (a force-hold mismatch).

How the filter is applied, per hold:

* a **sampled** force (band-limited) is filtered in the frequency domain, which is exact for
  its band: circularly for a record of whole periods (``meta["periodic"]``), otherwise with
  the first and last values held beyond the ends (a record is taken to start and end
  in the state its edge samples show);
* a **held** force keeps its staircase: an integer delay shifts it; a fractional delay
  ``alpha`` of a sample shares each interval between the two values that now act in it
  (``(1 - alpha) f[k] + alpha f[k - 1]``, the interval's impulse kept exact); a lag gives each
  interval the exact mean of the first-order response to the staircase.
"""

from __future__ import annotations

import math
import re
import weakref
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..data.record import Record
from ..errors import InputError, brief
from .balance import share_channels

__all__ = ["InputPath", "input_path", "acting_record", "MAX_DELAY_SAMPLES", "META_KEY"]

#: Largest delay or lag, in samples of the record it is applied to: beyond this it is not an input path
#: but a different experiment (and the padding it needs would dwarf the record).
MAX_DELAY_SAMPLES = 1000
#: The metadata key of a record whose force is already the acting one (what :meth:`InputPath.apply` wrote).
META_KEY = "input_path"
#: Time constants of padding a lag needs (its response decays to exp(-12) ~ 6e-6 of a step).
_LAG_PADDING = 12.0
#: Samples of padding beyond the delay and lag on each side of a record that is not periodic.
_EDGE = 256
_HOLDS = ("sampled", "zoh")
_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "samples": None, "sample": None}
_SPEC = re.compile(r"^\s*([a-z]+)\s*=\s*([^=]+?)\s*$")


def _seconds(value: Any, name: str, signed: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise InputError(f"input_path {name}= must be a number of seconds, got {brief(value)}")
    x = float(value)
    if not math.isfinite(x) or (x < 0 and not signed):
        bound = "" if signed else " >= 0"
        raise InputError(f"input_path {name}= must be a finite number of seconds{bound}, got {value!r}")
    return x


@dataclass(frozen=True)
class InputPath:
    """The path from the force channel to the force that acts (see the module docstring).

    Parameters
    ----------
    delay
        Delay of the acting force behind the recorded one (s); negative when the force channel is the late one
        (a filter or a clock offset on the force sensor: the force acts before it is recorded).
    lag
        Time constant of a first-order lag (s, >= 0).
    hold
        ``"zoh"`` or ``"sampled"``: how the force behaves between samples, overriding the record's
        ``force_hold``; ``None`` keeps the record's.

    Raises
    ------
    InputError
        A negative or non-finite time, or an unknown hold.
    """

    delay: float = 0.0
    lag: float = 0.0
    hold: str | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "delay", _seconds(self.delay, "delay", signed=True))
        object.__setattr__(self, "lag", _seconds(self.lag, "lag"))
        if self.hold is not None and self.hold not in _HOLDS:
            raise InputError(f"input_path hold= must be 'zoh' or 'sampled', got {brief(self.hold)}")

    # ------------------------------------------------------------------ what it is
    @property
    def identity(self) -> bool:
        """True when the acting force is the recorded one (no delay, no lag, the record's hold)."""
        return self.delay == 0.0 and self.lag == 0.0 and self.hold is None

    @property
    def parameters(self) -> int:
        """Numbers fitted from data: the delay and the lag when non-zero (a hold is a choice, not a number)."""
        return int(self.delay != 0) + int(self.lag > 0)

    def describe(self) -> str:
        """One line, e.g. ``"force delayed by 3 ms, first-order lag 1.2 ms"`` (``"as recorded"``)."""
        if self.identity:
            return "as recorded"
        parts = []
        if self.delay > 0:
            parts.append(f"force delayed by {_ms(self.delay)}")
        elif self.delay < 0:
            parts.append(f"force acting {_ms(-self.delay)} ahead of the force channel (the channel is late)")
        if self.lag:
            parts.append(f"first-order lag {_ms(self.lag)}")
        if self.hold:
            parts.append("held between samples (zoh)" if self.hold == "zoh" else "band-limited between samples")
        return ", ".join(parts)

    def to_spec(self) -> str:
        """The spelling :meth:`from_spec` reads back (``"delay=0.003, lag=0.0012"``; ``""`` for the identity)."""
        parts = [f"delay={self.delay:.6g}"] if self.delay else []
        parts += [f"lag={self.lag:.6g}"] if self.lag else []
        parts += [f"hold={self.hold}"] if self.hold else []
        return ", ".join(parts)

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly form (seconds)."""
        return {"delay_s": self.delay, "lag_s": self.lag, "hold": self.hold, "text": self.describe()}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any] | None) -> InputPath:
        """Inverse of :meth:`to_dict` (``None``: the identity).

        Raises
        ------
        InputError
            Not a mapping, or bad values (named).
        """
        if data is None:
            return cls()
        if not isinstance(data, Mapping):
            raise InputError(f"input_path must be a mapping with delay_s, lag_s and hold, got {brief(data)}")
        return cls(data.get("delay_s", 0.0) or 0.0, data.get("lag_s", 0.0) or 0.0, data.get("hold"))

    @classmethod
    def from_spec(cls, spec: str, fs: float | None = None) -> InputPath:
        """Read ``"delay=3ms, lag=1.2ms, hold=zoh"`` (the command line's spelling).

        Times take a unit ``s``, ``ms``, ``us`` or ``samples`` (the last needs ``fs``); a bare number is
        seconds.

        Raises
        ------
        InputError
            An unknown key, a bad number or unit, or ``samples`` without ``fs``.
        """
        if not isinstance(spec, str):
            raise InputError(f"an input path is written 'delay=3ms, lag=1ms', got {brief(spec)}")
        values: dict[str, Any] = {}
        for item in filter(None, (p.strip() for p in spec.split(","))):
            match = _SPEC.match(item.lower())
            if not match or match.group(1) not in ("delay", "lag", "hold"):
                raise InputError(f"unknown input-path item {brief(item)}: use delay=..., lag=..., hold=zoh|sampled")
            key, text = match.groups()
            if key in values:
                raise InputError(f"input path: {key} is given twice")
            values[key] = text if key == "hold" else _time(text, fs, key)
        return cls(**values)

    # ------------------------------------------------------------------ applying it
    def apply(self, record: Record) -> Record:
        """The record with its force replaced by the acting force (the record itself for the identity).

        Idempotent: a record this path already produced (``meta["input_path"]``) is returned as is.

        Raises
        ------
        InputError
            A delay or lag longer than :data:`MAX_DELAY_SAMPLES` samples of the record.
        """
        spec = self.to_spec()
        if self.identity or record.meta.get(META_KEY) == spec:
            return record
        done = _applied(record)
        if spec not in done:
            hold = self.hold or record.force_hold
            force = self.acting_force(record.f, record.fs, hold, _whole_periods(record))
            acting = record.replace(f=force).with_meta(**{META_KEY: spec, "force_hold": hold})
            share_channels(record, acting)  # its motion is the record's: filtered once
            done[spec] = acting
        return done[spec]

    def acting_force(self, force: np.ndarray, fs: float, hold: str, period: int | None = None) -> np.ndarray:
        """The acting force at the record's samples (see the module docstring).

        Parameters
        ----------
        force
            The recorded force samples.
        fs
            Sampling frequency (Hz).
        hold
            ``"zoh"`` or ``"sampled"``: how the force behaves between samples.
        period
            The record is whole periods of this many samples (filtered circularly), or ``None``.
        """
        f = np.asarray(force, dtype=float)
        steps = max(abs(self.delay), self.lag) * fs
        if steps > MAX_DELAY_SAMPLES:
            raise InputError(
                f"input path of {steps:.3g} samples: at most {MAX_DELAY_SAMPLES} samples of delay or lag are accepted"
            )
        if f.size == 0:
            return f.copy()
        if hold == "zoh":
            out = _held_delay(f, self.delay * fs, period is not None)
            return _held_lag(out, self.lag * fs, period) if self.lag else out
        return _sampled(f, self.delay * fs, self.lag * fs, period)


def input_path(value: InputPath | str | Mapping[str, Any] | None, fs: float | None = None) -> InputPath:
    """An :class:`InputPath` from what a user gives: an instance, its spelling, its dictionary or ``None``."""
    if value is None:
        return InputPath()
    if isinstance(value, InputPath):
        return value
    if isinstance(value, str):
        return InputPath.from_spec(value, fs)
    if isinstance(value, Mapping):
        keys = set(value)
        if keys <= {"delay", "lag", "hold"}:
            return InputPath(**dict(value))
        return InputPath.from_dict(value)
    raise InputError(f"input_path= must be an InputPath, its spelling 'delay=3ms' or a mapping, got {brief(value)}")


def acting_record(fit: Any, record: Record) -> Record:
    """``record`` with the force that acts on ``fit``'s model: through its input path, when it has one.

    ``fit`` is anything with an ``input_path`` attribute (:attr:`nlid.identified.model.IdentifiedModel.input_path`);
    every score applies it (:mod:`nlid.scoring`), so that a delay or a lag found on the estimation record
    acts the same way on every record the model meets. Applying it twice is applying it once.
    """
    path = getattr(fit, "input_path", None)
    return record if path is None else path.apply(record)


# --------------------------------------------------------------------------- helpers
_APPLIED: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _applied(record: Record) -> dict[str, Record]:
    """The acting-force records already made from ``record``, by path spelling (dropped with the record)."""
    try:
        return _APPLIED.setdefault(record, {})
    except TypeError:  # pragma: no cover - a record type without weak references: no caching
        return {}


def _ms(seconds: float) -> str:
    return f"{1e3 * seconds:.3g} ms" if seconds >= 1e-4 else f"{1e6 * seconds:.3g} us"


def _time(text: str, fs: float | None, key: str) -> float:
    match = re.fullmatch(r"([-+0-9.eE]+)\s*([a-z]*)", text.strip())
    unit = match.group(2) if match else ""
    if not match or unit not in ("", *_UNITS):
        raise InputError(f"input path {key}={text!r}: a number with a unit s, ms, us or samples")
    try:
        x = float(match.group(1))
    except ValueError:
        raise InputError(f"input path {key}={text!r} is not a number") from None
    if unit in ("samples", "sample"):
        if not fs:
            raise InputError(f"input path {key}={text!r}: samples need the sampling frequency")
        return x / fs
    return x * (_UNITS[unit] if unit else 1.0)  # type: ignore[operator]


def _whole_periods(record: Record) -> int | None:
    """The period of a record that holds whole periods of it (``meta["periodic"]``), else ``None``."""
    declared = record.meta.get("periodic")
    if declared is True:
        return record.n
    if isinstance(declared, (int, np.integer)) and not isinstance(declared, bool) and declared > 1:
        return int(declared) if record.n % int(declared) == 0 else None
    return None


def _held_delay(f: np.ndarray, steps: float, circular: bool) -> np.ndarray:
    """A staircase delayed by ``steps`` samples: shifted, a fractional part sharing each interval."""
    if steps == 0.0:
        return f.copy()
    whole = int(math.floor(steps))
    alpha = steps - whole

    def shifted(k: int) -> np.ndarray:
        """``f`` later by ``k`` samples (earlier for ``k < 0``), its end values held beyond the record."""
        if circular:
            return np.roll(f, k)
        if k == 0:
            return f.copy()
        if k > 0:
            return np.concatenate([np.full(min(k, f.size), f[0]), f[: max(f.size - k, 0)]])
        return np.concatenate([f[min(-k, f.size) :], np.full(min(-k, f.size), f[-1])])

    out = shifted(whole)
    if alpha > 0.0:
        out = (1.0 - alpha) * out + alpha * shifted(whole + 1)
    return out


def _held_lag(f: np.ndarray, steps: float, period: int | None) -> np.ndarray:
    """Each interval's mean of a first-order lag (``steps`` samples) driven by the staircase ``f``."""
    from scipy import signal

    a = math.exp(-1.0 / steps)
    mean = steps * (1.0 - a)  # the interval's mean of exp(-t / tau), times h
    if period is not None:
        # start in the periodic regime: as many periods in front as the lag needs to forget its start
        repeats = 1 + int(math.ceil(_LAG_PADDING * steps / f.size))
        drive = np.tile(f, repeats + 1)
        y0 = f[0]
    else:
        drive, y0, repeats = f, f[0], 0
    # y[k]: the lag's output at the start of interval k; y[k + 1] = a y[k] + (1 - a) u[k]
    y_next, _ = signal.lfilter([1.0 - a], [1.0, -a], drive, zi=[a * y0])
    y = np.concatenate([[y0], y_next[:-1]])
    out = drive + (y - drive) * mean
    return out[repeats * f.size :] if period is not None else out


def _sampled(f: np.ndarray, delay: float, lag: float, period: int | None) -> np.ndarray:
    """A band-limited force through ``exp(-s d) / (1 + s tau)`` (``d``, ``tau`` in samples) by the FFT."""
    n = f.size
    if period is not None:
        pad = 0
        x = f
    else:
        # beyond each end the force is continued by its odd reflection about the end sample (value and slope
        # continuous: no kink whose ringing a fractional delay would carry into the record), then brought back
        # smoothly to where the other end starts, so that the FFT's periodic extension has no step either
        pad = int(math.ceil(abs(delay) + _LAG_PADDING * lag)) + _EDGE
        m = min(pad, n - 1)
        front = np.concatenate([np.full(pad - m, 2.0 * f[0] - f[m]), 2.0 * f[0] - f[m:0:-1]])
        back = np.concatenate([2.0 * f[-1] - f[-2 : -m - 2 : -1], np.full(pad - m, 2.0 * f[-1] - f[-m - 1])])
        ramp = back[-1] + (front[0] - back[-1]) * 0.5 * (1.0 - np.cos(np.pi * np.arange(1, pad + 1) / pad))
        x = np.concatenate([front, f, back, ramp])
    size = x.size
    w = 2.0 * np.pi * np.fft.rfftfreq(size)  # rad per sample
    h = np.exp(-1j * w * delay) / (1.0 + 1j * w * lag)
    if size % 2 == 0 and delay != round(delay):
        # the Nyquist bin of a real signal must stay real: its phase is split evenly between +/- Nyquist
        h[-1] = np.real(h[-1])
    y = np.fft.irfft(np.fft.rfft(x) * h, size)
    return y[pad : pad + n]
