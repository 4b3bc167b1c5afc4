"""Clipped channels: a sensor or amplifier driven past its range, found from the record alone.

A channel that leaves its instrument's range is cut flat at the range's edge: the samples there stop
measuring the motion, and nothing downstream can tell. On ``paper-numerical`` at 1 % noise (rfs, mass
given, seeds 1-3; ``python benchmarks/clipped_channels.py``), a displacement cut at 90 % of its peak (0.3-0.5 %
of the samples) makes the cubic spring 0.8-1.2 % too stiff, one cut at 80 % (3-4 % of the samples) 8-10 %,
one cut at 60 % 62-71 %. A model can look clean with its input cut: the probes of what remains read a few
cut samples as noise.

:func:`find_clipping` looks for the cut itself, on each side of each measured channel:

* **a spike at the extreme**: at least :data:`SPIKE` times as many samples sit exactly at the channel's
  largest (or smallest) value as at its next value. A continuous channel reaches its extreme once; a
  periodic one once a period, and every other value as often; a quantised one about as often as the
  levels next to it;
* **reached and left in motion**: the step into each visit of the extreme and the step out of it are at
  least :data:`MOTION_STEP` of the channel's median step (:data:`SINGLE_STEP` for a visit of one sample),
  so a stage that slows down and rests at the end of its travel is not taken for a clipped sensor; and
  the visit is not left by exactly the step it was reached by, as a synthetic sine is at a crest that
  the sampling hits (:data:`SYMMETRIC`);
* **repeatedly**: at least :data:`MIN_VISITS` such visits (runs of one or more samples).

:func:`clipping_warnings` gives one line per clipped side; :func:`nlid.identify` adds them to the
model's warnings and :func:`nlid.discover` to its report. Works for records of any number of DOFs
(every channel, ``z2`` of a structure as ``z`` of one DOF).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = [
    "Clipping",
    "find_clipping",
    "clipping_warnings",
    "clipped_note",
    "SPIKE",
    "MIN_VISITS",
    "MOTION_STEP",
    "SINGLE_STEP",
    "SYMMETRIC",
]

#: How many times more samples must sit at the extreme than at the channel's next value. A sine quantised
#: with a level at its peak puts up to 2.4 times as many samples in its top level as in the next (the
#: arcsine density); a stepped or swept sine repeats its peak sample once a period, as every other sample.
SPIKE = 4.0
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

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly form."""
        return {
            "channel": self.channel,
            "side": self.side,
            "level": self.level,
            "unit": self.unit,
            "visits": self.visits,
            "samples": self.samples,
            "share": self.share,
        }


def _visits(y: np.ndarray) -> tuple[int, int]:
    """``(visits, samples)`` of the clipped-looking top of ``y`` (its maximum); ``(0, 0)`` when it is not."""
    level = y.max()
    at = y == level
    count = int(at.sum())
    below = y[~at]
    if count < MIN_VISITS or below.size == 0 or count < SPIKE * int((y == below.max()).sum()):
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
    if int(moving.sum()) < MIN_VISITS:
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
    units = getattr(record, "units", {}) or {}
    for name in record.channels:
        if not str(record.source_of(name)).startswith("measured"):
            continue
        x = np.asarray(record.channel(name), dtype=float)
        if x.size < 2 * MIN_VISITS or not np.all(np.isfinite(x)) or x.max() == x.min():
            continue
        unit = str(units.get(name) or units.get(name.rstrip("0123456789")) or "")
        for sign, side in ((1.0, "maximum"), (-1.0, "minimum")):
            visits, samples = _visits(sign * x)
            if visits:
                level = float(x.max() if sign > 0 else x.min())
                found.append(Clipping(name, side, level, unit, visits, samples, samples / x.size))
    return tuple(found)


def clipped_note(found: tuple[Clipping, ...]) -> str:
    """The end of a search's stop reason when channels look clipped: an effect found may be fitting the cut."""
    names = "; ".join(c.short() for c in found)
    return (
        f"; but {names}: the cut samples do not measure the motion, so the model cannot be clean and any effect "
        "added may only be fitting the cut (data, above)"
    )


def clipping_warnings(record: Any) -> list[str]:
    """:func:`find_clipping` as warning lines (empty when no channel looks clipped)."""
    return [c.describe() for c in find_clipping(record)]
