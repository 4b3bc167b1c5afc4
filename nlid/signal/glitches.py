"""Glitches a record carries and no model of the motion can fit: clipped channels and isolated spikes.

## Clipped channels

A channel that leaves its instrument's range is cut flat at the range's edge: the samples there stop
measuring the motion, and nothing downstream can tell. On ``paper-numerical`` at 1 % noise (rfs,
mass given, seeds 1-3; ``python benchmarks/record_glitches.py``), a displacement cut at 90 % of its peak
(0.27-0.54 % of the samples) makes the cubic spring 0.8-1.2 % too stiff, one cut at 80 % (3.0-4.4 % of
the samples) 8-10 %, one cut at 60 % 62-71 %. A model can look clean with its input cut: the probes of
what remains read a few cut samples as noise.

:func:`find_clipping` looks for the cut itself, on each side of each measured channel:

* **a pile at the extreme**: at least :data:`EXTREME_RATIO` times as many samples sit exactly at the channel's
  largest (or smallest) value as at each of its next values (:data:`NEXT_VALUES`, on average). A
  continuous channel reaches its extreme once; a periodic one once a period, and every other value as
  often; a quantised one about as often as the levels next to it;
* **reached and left in motion**: the step into each visit of the extreme and the step out of it are at
  least :data:`MOTION_STEP` of the channel's median step (:data:`SINGLE_STEP` for a visit of one sample),
  so a stage that slows down and rests at the end of its travel is not taken for a clipped sensor; and
  the visit is not left by exactly the step it was reached by, as a synthetic sine is at a crest that
  the sampling hits (:data:`SYMMETRIC`);
* **repeatedly**: at least :data:`MIN_VISITS` such visits (runs of one or more samples), at as many places
  of the period on a periodic record (``meta["periodic"]``), whose crests repeat every period.

## Isolated spikes

A displacement cannot leave its path for one sample and come back, nor can a velocity: such a sample is a
glitch of the sensor or the acquisition (a lost count, a bit error, an interference pulse). On
``paper-numerical`` at 1 % noise (seeds 1-3), 20 spikes of twice std(z) (0.016 % of the samples) make the
cubic spring 4-8 % weak and the quadratic 7-21 %, with nothing said (``python benchmarks/record_glitches.py``,
which measures both kinds of glitch); spikes of one std(z) still move them by 0.5-2.5 %.

:func:`find_spikes` finds them on each measured displacement and velocity channel: a sample that both the
line through its two left neighbours and the line through its two right neighbours miss on the same side,
each by more than :data:`SPIKE_SCALES` times the channel's robust scale of such misses, :data:`SPIKE_STD` of
its standard deviation and :data:`SPIKE_QUANTA` of its quanta. A velocity is rougher than a displacement
(the misses' scale is 0.25 std(v) against 0.024 std(z) on ``paper-numerical``), so only spikes of several
std(v) stand out.
A kink (an impact reversing the velocity) is met by one of the two lines, a step (a velocity jump) by the
line on its far side. Forces and accelerations are not read: a hammer's blow or an impact is a real
one-sample pulse there.

:func:`find_glitches` gives both kinds; :func:`glitch_warnings` one line each. :func:`nlid.identify` adds them
to the model's warnings, :func:`nlid.discover` and :func:`~nlid.discovery.structure.discover_structure` to
their report and stop reason. Works for records of any number of DOFs (every channel, ``z2`` of a structure
as ``z`` of one DOF).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = [
    "Clipping",
    "Spikes",
    "find_clipping",
    "find_spikes",
    "find_glitches",
    "despike",
    "glitch_warnings",
    "glitch_note",
    "reported_by_caller",
    "EXTREME_RATIO",
    "NEXT_VALUES",
    "SPIKE_SCALES",
    "SPIKE_STD",
    "SPIKE_QUANTA",
    "MIN_VISITS",
    "MOTION_STEP",
    "SINGLE_STEP",
    "SYMMETRIC",
]

#: How many times more samples must sit at the extreme than at the channel's next value. A sine quantised
#: with a level at its peak puts up to 2.4 times as many samples in its top level as in the next (the
#: arcsine density); a stepped or swept sine repeats its peak sample once a period, as every other sample.
EXTREME_RATIO = 4.0
#: The next values the extreme's count is compared with (their mean count): one next value alone is too few
#: samples to judge a coarsely quantised channel by (a beam's acceleration rounded to 0.1 std: 4 samples at
#: its lowest level, 1, 2 and 9 at the next three).
NEXT_VALUES = 3
#: Fewest visits of the extreme, each reached and left in motion, that call a side clipped.
MIN_VISITS = 3
#: The step into and out of a visit, as a fraction of the channel's median nonzero step, that counts as
#: motion (a sine clipped at 95 % of its peak is entered at about 0.45 of its median step; a stage that
#: decelerates to rest, at the noise's or the quantisation's step).
MOTION_STEP = 0.25
#: A visit of one sample must be reached and left by at least this fraction of the median step: a smooth
#: crest that rounds to the same value at several crests (a noise-free sine at ``sin = 1.0``) is reached by
#: a small step (measured: 0.02-0.13 of the median on the swept- and stepped-sine presets), a broadband force
#: cut at 90 % of its peak by 2.3-5.9 of it.
SINGLE_STEP = 1.0
#: A visit left by the same step as it was reached, to this relative difference, is a smooth crest that the
#: sampling hits exactly (a synthetic sine whose period is a multiple of four samples), not a cut.
SYMMETRIC = 1e-6


@dataclass(frozen=True)
class Clipping:
    """One side of one channel found clipped (:func:`find_clipping`).

    Attributes
    ----------
    channel
        The channel's name (``"z"``, a structure's ``"z2"``).
    side
        ``"maximum"`` or ``"minimum"``.
    level
        The value it is cut at, in the record's (SI) unit of the channel.
    unit
        That unit.
    visits
        Runs of samples at the level, each reached and left in motion.
    samples
        Samples in those runs.
    share
        ``samples`` over the record's length.
    """

    channel: str
    side: str
    level: float
    unit: str
    visits: int
    samples: int
    share: float

    def short(self) -> str:
        """``"channel z looks clipped at its maximum, 0.0036 m"``."""
        return f"channel {self.channel} looks clipped at its {self.side}, {self.level:.6g} {self.unit}".rstrip()

    def describe(self) -> str:
        """One line for a warning."""
        return (
            self.short()
            + f": {self.samples} samples ({100 * self.share:.2g} % of the record) sit exactly there, reached and "
            f"left in motion {self.visits} times (a sensor or amplifier past its range?); they do not measure the "
            "motion and bias what is fitted to them: cut them out, or use a record within the range"
        )


def _phases(start: np.ndarray, period: int | None) -> int:
    """How many distinct places of the period the visits starting at ``start`` take (within a sample)."""
    if not period:
        return int(start.size)
    phases = np.sort(start % period)
    return int(1 + np.sum(np.diff(phases) > 1)) if phases.size else 0


def _visits(y: np.ndarray, period: int | None = None) -> tuple[int, int]:
    """``(visits, samples)`` of the clipped-looking top of ``y`` (its maximum); ``(0, 0)`` when it is not.

    ``period``: a periodic record's period in samples; its visits must then take :data:`MIN_VISITS` distinct
    places of the period (one crest repeated every period is one visit).
    """
    level = y.max()
    at = y == level
    count = int(at.sum())
    if count < MIN_VISITS:  # the usual case, settled without sorting
        return 0, 0
    values, counts = np.unique(y[~at], return_counts=True)
    if values.size == 0 or count < EXTREME_RATIO * float(np.mean(counts[-NEXT_VALUES:])):
        return 0, 0
    edges = np.diff(np.concatenate([[0], at.astype(np.int8), [0]]))
    start, stop = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    inside = (start >= 1) & (stop <= y.size - 1)  # a visit at the record's edge has no way in or out
    start, stop = start[inside], stop[inside]
    steps = np.abs(np.diff(y))
    scale = float(np.median(steps[steps > 0]))
    into, out = level - y[start - 1], level - y[stop]
    least = np.where(stop - start > 1, MOTION_STEP, SINGLE_STEP) * scale
    moving = (into >= least) & (out >= least)
    moving &= np.abs(into - out) > SYMMETRIC * np.maximum(into, out)  # not a sampled crest, left as reached
    if int(moving.sum()) < MIN_VISITS or _phases(start[moving], period) < MIN_VISITS:
        return 0, 0
    return int(moving.sum()), int((stop - start)[moving].sum())


def find_clipping(record: Any) -> tuple[Clipping, ...]:
    """Every channel side of ``record`` that looks clipped (see the module docstring); empty when none does.

    Parameters
    ----------
    record
        A :class:`~nlid.data.record.Record` of any number of DOFs. Only measured channels are read: a channel
        estimated from a clipped one inherits its flat tops, and the warning names the source.

    Returns
    -------
    tuple of Clipping
        In the record's channel order, the maximum before the minimum.
    """
    found = []
    period = record.meta.get("periodic")
    period = int(period) if isinstance(period, (int, np.integer)) and not isinstance(period, bool) else None
    for name in _measured(record):
        x = np.asarray(record.channel(name), dtype=float)
        if x.size < 2 * MIN_VISITS or not np.all(np.isfinite(x)) or x.max() == x.min():
            continue
        unit = _unit(record, name)
        for sign, side in ((1.0, "maximum"), (-1.0, "minimum")):
            visits, samples = _visits(sign * x, period)
            if visits:
                level = float(x.max() if sign > 0 else x.min())
                found.append(Clipping(name, side, level, unit, visits, samples, samples / x.size))
    return tuple(found)


#: A spike misses both lines through its neighbours by more than this many robust scales (1.4826 times the
#: median absolute deviation of every such miss in the channel). The largest miss on a healthy channel: 11.3
#: scales (noise-free paper-experimental z), 5.3 on the structures, 4.6 on Silverbox, 18.9 on EMPS (an encoder
#: at rest: the scale is a fraction of a count, and :data:`SPIKE_STD` rules it out); a spike of half std(z)
#: at 1 % noise misses by 19 scales, one of twice std(z) by 80.
SPIKE_SCALES = 25.0
#: ... and by more than this fraction of the channel's standard deviation (EMPS: 1e-5 at most; a smooth channel
#: sampled a few times a period misses by up to 2 std: Silverbox).
SPIKE_STD = 0.05
#: ... and by more than this many of its quanta (its smallest step): a coarse encoder or a CSV of few digits
#: toggles by one quantum and back, and a channel mostly at rest has a robust scale below one quantum (the
#: 2dof-double-well's z2 rounded to 1 % of the std of both displacements: 416 toggles taken for spikes).
SPIKE_QUANTA = 4.0
#: Misses per side the robust scale is read from (every k-th of a longer record): the scale of 32768 is within
#: about 1 % of all of them, at a fraction of the cost of sorting a long record's.
SCALE_SAMPLES = 32768
#: Sample indices a :class:`Spikes` lists (the first ones).
SPIKES_LISTED = 5


@dataclass(frozen=True)
class Spikes:
    """Isolated spikes of one channel (:func:`find_spikes`).

    Attributes
    ----------
    channel
        The channel's name (``"z"``, a structure's ``"z2"``).
    count
        Spikes found.
    largest
        The largest miss, in the record's (SI) unit of the channel.
    unit
        That unit.
    std
        The channel's standard deviation, in that unit.
    samples
        The first :data:`SPIKES_LISTED` spikes' sample indices.
    """

    channel: str
    count: int
    largest: float
    unit: str
    std: float
    samples: tuple[int, ...]

    def short(self) -> str:
        """``"channel z has 20 isolated spikes"``."""
        return f"channel {self.channel} has {self.count} isolated spike{'s' if self.count > 1 else ''}"

    def describe(self) -> str:
        """One line for a warning."""
        at = ", ".join(str(i) for i in self.samples) + (", ..." if self.count > len(self.samples) else "")
        return (
            f"{self.short()} (samples {at}; up to {self.largest:.3g} {self.unit} = {self.largest / self.std:.2g} "
            "std off the line through their neighbours on both sides, and back): glitches of the sensor or the "
            "acquisition? they bias what is fitted to them: replace each by its neighbours' mean "
            "(nlid.signal.glitches.despike), or cut them out"
        )


def _spikes(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Sample indices of the isolated spikes of ``x`` and the size of each (its smaller miss)."""
    left = x[2:-2] - (2.0 * x[1:-3] - x[:-4])
    right = x[2:-2] - (2.0 * x[3:-1] - x[4:])
    size = np.where(np.sign(left) == np.sign(right), np.minimum(np.abs(left), np.abs(right)), 0.0)
    found = np.flatnonzero(size > SPIKE_STD * float(np.std(x)))
    if found.size:  # the usual case has none: the robust scale and the quantum only when there are candidates
        stride = max(1, left.size // SCALE_SAMPLES)  # a robust scale needs no more than that many misses
        misses = np.concatenate([left[::stride], right[::stride]])
        scale = 1.4826 * float(np.median(np.abs(misses - np.median(misses))))
        steps = np.abs(np.diff(x))
        quantum = float(steps[steps > 0].min()) if np.any(steps > 0) else 0.0
        found = found[size[found] > max(SPIKE_SCALES * scale, SPIKE_QUANTA * quantum)]
    return found + 2, size[found]


def _spiked(record: Any) -> Iterator[tuple[str, np.ndarray, np.ndarray, np.ndarray]]:
    """``(name, channel, indices, sizes)`` of each measured displacement and velocity channel with spikes."""
    for name in _measured(record, ("z", "v")):
        x = np.asarray(record.channel(name), dtype=float)
        if x.size < 5 or not np.all(np.isfinite(x)):
            continue
        where, size = _spikes(x)
        if where.size:
            yield name, x, where, size


def find_spikes(record: Any) -> tuple[Spikes, ...]:
    """Every measured displacement and velocity channel of ``record`` with isolated spikes (module docstring).

    Parameters
    ----------
    record
        A :class:`~nlid.data.record.Record` of any number of DOFs.

    Returns
    -------
    tuple of Spikes
        In the record's channel order; empty when no channel has any.
    """
    return tuple(
        Spikes(name, int(where.size), float(size.max()), _unit(record, name), float(np.std(x)),
               tuple(int(i) for i in where[:SPIKES_LISTED]))
        for name, x, where, size in _spiked(record)
    )  # fmt: skip


def _measured(record: Any, groups: tuple[str, ...] | None = None) -> list[str]:
    """The measured channels of ``record`` (of ``groups`` only, when given)."""
    names = [n for n in record.channels if str(record.source_of(n)).startswith("measured")]
    return [n for n in names if groups is None or n.rstrip("0123456789") in groups]


def _unit(record: Any, name: str) -> str:
    """The SI unit of channel ``name`` ("" when the record does not say)."""
    units = getattr(record, "units", {}) or {}
    return str(units.get(name) or units.get(name.rstrip("0123456789")) or "")


def despike(record: Any) -> Any:
    """``record`` with every isolated spike of :func:`find_spikes` replaced by the mean of its two neighbours.

    The repair the warning suggests, never applied unasked. The channels touched are named in
    ``meta["despiked"]`` (channel: sample indices), so the record says what was changed.

    Parameters
    ----------
    record
        A :class:`~nlid.data.record.Record` of any number of DOFs.

    Returns
    -------
    Record
        A new record (``record`` itself when it has no spike).
    """
    changes: dict[str, Any] = {}
    touched: dict[str, list[int]] = {}
    for name, x, where, _ in _spiked(record):
        group = name.rstrip("0123456789")
        x = x.copy()
        x[where] = 0.5 * (x[where - 1] + x[where + 1])
        touched[name] = [int(i) for i in where]
        if record.indexed:
            block = np.array(changes.get(group, getattr(record, group)), dtype=float, copy=True)
            block[:, int(name[len(group) :]) - 1] = x
            changes[group] = block
        else:
            changes[group] = x
    if not touched:
        return record
    meta = {**dict(record.meta), "despiked": touched}
    return dataclasses.replace(record, meta=meta, **changes)


def find_glitches(record: Any) -> tuple[Clipping | Spikes, ...]:
    """:func:`find_clipping` and :func:`find_spikes` together."""
    return (*find_clipping(record), *find_spikes(record))


#: True within :func:`reported_by_caller`.
_REPORTED: ContextVar[bool] = ContextVar("nlid_glitches_reported", default=False)


@contextmanager
def reported_by_caller() -> Iterator[None]:
    """Within the block :func:`glitch_warnings` gives nothing: the caller checks the whole record once and says
    what it finds. A search fits its model on parts of the record hundreds of times, and checking every part
    again took a fifth of ``discover``'s time (paper-numerical: 6.4 s against 5.3 s)."""
    token = _REPORTED.set(True)
    try:
        yield
    finally:
        _REPORTED.reset(token)


def glitch_warnings(record: Any) -> list[str]:
    """:func:`find_glitches` as warning lines (empty when the record has none, or within
    :func:`reported_by_caller`)."""
    if _REPORTED.get():
        return []
    return [g.describe() for g in find_glitches(record)]


def glitch_note(found: tuple[Clipping | Spikes, ...]) -> str:
    """The end of a search's stop reason when the record has glitches: an effect found may be fitting them."""
    names = "; ".join(g.short() for g in found)
    return (
        f"; but {names}: those samples do not measure the motion, so the model cannot be clean and any effect "
        "added may only be fitting them (data, above)"
    )
