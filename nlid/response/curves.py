"""One continued response curve: its points, their stability, the special points, and why it stopped.

A :class:`ResponseCurve` is what one continuation gives: the harmonic
coefficients of the motion at every point (``(points, n, 2H + 1)``), the
parameter (frequency at a fixed force, or force at a fixed frequency), Hill's
verdict per point, the folds, branch points and other bifurcations, and the
reason the continuation stopped. Its amplitudes are the first-harmonic
amplitude ``sqrt(a_1^2 + b_1^2)`` per DOF (the quantity a stepped-sine test
measures), the static offset ``c_0`` and the peak ``max |z - c_0|`` over the
period. :meth:`ResponseCurve.sweep` is the path a slow sweep follows (up or
down), jumping at the folds.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .harmonics import Harmonics

__all__ = ["ResponseCurve", "SpecialPoint", "motion_labels"]


@dataclass(frozen=True)
class SpecialPoint:
    """A fold, branch point or other bifurcation of a curve.

    Attributes
    ----------
    kind
        ``"fold"``, ``"branch"``, ``"flip"`` or ``"torus"``.
    frequency_hz, force
        Where it is.
    amplitude
        The first-harmonic amplitude of each DOF there (m).
    index
        The curve's point at (a fold is a point of the curve) or just after it.
    """

    kind: str
    frequency_hz: float
    force: float
    amplitude: tuple[float, ...]
    index: int

    def to_dict(self) -> dict[str, Any]:
        """Plain data."""
        return {
            "kind": self.kind,
            "frequency_hz": self.frequency_hz,
            "force": self.force,
            "amplitude": list(self.amplitude),
            "index": self.index,
        }


@dataclass(frozen=True, eq=False)
class ResponseCurve:
    """A continued periodic response (module docstring).

    Attributes
    ----------
    parameter
        ``"frequency"`` (continued in frequency at a fixed force) or ``"force"``.
    frequency_hz, force
        Frequency (Hz) and force amplitude (N) of every point.
    coefficients
        ``(points, n, 2H + 1)``: the motion's harmonics per DOF.
    stable
        Hill's verdict per point.
    multiplier
        The largest Floquet multiplier modulus per point.
    instability
        How each unstable point loses stability (``"real"``, ``"flip"``, ``"complex"``; ``""`` if stable).
    labels
        What each point's motion is: ``"in-well z*=..."`` or ``"cross-well"`` for a double well, else ``""``.
    start
        The equilibrium the curve started from (per DOF).
    events
        The special points.
    stopped
        Why the continuation stopped.
    dofs
        The DOF names.
    newton, rejected
        Corrector iterations and rejected steps.
    truncation
        Per point, how far the truncated motion misses the equations between its harmonics
        (:func:`nlid.response.balance.time_residual`; NaN with a memory term): above ``1e-3`` more
        harmonics would change the answer.
    """

    parameter: str
    frequency_hz: np.ndarray
    force: np.ndarray
    coefficients: np.ndarray
    stable: np.ndarray
    multiplier: np.ndarray
    instability: tuple[str, ...]
    labels: tuple[str, ...]
    start: tuple[float, ...]
    events: tuple[SpecialPoint, ...] = ()
    stopped: str = ""
    dofs: tuple[str, ...] = ("z",)
    newton: int = 0
    rejected: int = 0
    truncation: np.ndarray | None = None
    meta: dict = field(default_factory=dict)

    @property
    def harmonics(self) -> int:
        """Number of harmonics."""
        return (self.coefficients.shape[-1] - 1) // 2

    @property
    def basis(self) -> Harmonics:
        """The basis of the coefficients."""
        return Harmonics(self.harmonics)

    def __len__(self) -> int:
        return int(self.frequency_hz.size)

    def dof_index(self, dof: int | str) -> int:
        """The row of a DOF given by number (1-based) or name."""
        if isinstance(dof, str):
            return self.dofs.index(dof)
        return int(dof) - 1

    def amplitude(self, dof: int | str = 1, order: int = 1) -> np.ndarray:
        """First-harmonic (or ``order``-th) amplitude of a DOF at every point (m)."""
        return self.basis.amplitude(self.coefficients[:, self.dof_index(dof), :], order)

    def offset(self, dof: int | str = 1) -> np.ndarray:
        """The static offset ``c_0`` of a DOF at every point (m)."""
        return self.coefficients[:, self.dof_index(dof), 0]

    def peak(self, dof: int | str = 1) -> np.ndarray:
        """``max |z - c_0|`` over the period at every point (m)."""
        c = self.coefficients[:, self.dof_index(dof), :]
        fine = self.basis.fine(c, 256)
        return np.max(np.abs(fine - c[:, :1]), axis=1)

    def extremes(self, dof: int | str = 1) -> tuple[np.ndarray, np.ndarray]:
        """Least and largest displacement over the period at every point (m)."""
        fine = self.basis.fine(self.coefficients[:, self.dof_index(dof), :], 256)
        return fine.min(axis=1), fine.max(axis=1)

    @property
    def folds(self) -> tuple[SpecialPoint, ...]:
        """The turning points (where a sweep jumps)."""
        return tuple(e for e in self.events if e.kind == "fold")

    def sweep(self, direction: str = "up") -> np.ndarray:
        """Indices of the points a slow sweep passes, in order: stable, monotone in frequency, jumping at folds.

        From the curve's low-frequency end (``"up"``) or high-frequency end
        (``"down"``): the sweep follows the curve while the frequency moves
        its way and the point is stable; where the curve turns back (a fold)
        or loses stability, it jumps to the next stable point further along
        the curve at a frequency beyond the last one passed.
        """
        f = self.frequency_hz
        order = np.arange(len(f))
        if direction == "down":
            order = order[::-1]
        sign = 1.0 if direction == "up" else -1.0
        out: list[int] = []
        last = -np.inf
        for i in order:
            if not self.stable[i]:
                continue
            if sign * f[i] >= last:
                out.append(int(i))
                last = sign * f[i]
        return np.array(out, dtype=int)

    def along(
        self, frequency_hz: np.ndarray, direction: str = "up", dof: int | str = 1
    ) -> tuple[np.ndarray, np.ndarray]:
        """First-harmonic amplitude and offset a slow sweep in ``direction`` reads at each frequency (NaN outside).

        Between two points of the sweep path that follow each other on the curve, linear interpolation;
        across a jump, the branch the sweep lands on (between the landing point and its neighbour).
        """
        f = np.atleast_1d(np.asarray(frequency_hz, dtype=float))
        amp, off = np.full(f.size, np.nan), np.full(f.size, np.nan)
        idx = self.sweep(direction)
        a_all, o_all, fr = self.amplitude(dof), self.offset(dof), self.frequency_hz
        slack = 1e-9 * max(float(np.max(np.abs(fr))), 1.0)  # the band's ends, to the rounding of 2 pi
        for a, b in zip(idx[:-1], idx[1:], strict=True):
            lo, hi = sorted((fr[a], fr[b]))
            inside = (f >= lo - slack) & (f <= hi + slack)
            if not inside.any():
                continue
            if abs(int(b) - int(a)) > 1:  # a jump at a's frequency: the landing branch, from b back towards a
                a = b - 1 if b > a else b + 1
            x0, x1 = fr[a], fr[b]
            w = np.zeros(f.size) if x1 == x0 else (f - x0) / (x1 - x0)
            amp[inside] = ((1 - w) * a_all[a] + w * a_all[b])[inside]
            off[inside] = ((1 - w) * o_all[a] + w * o_all[b])[inside]
        return amp, off

    def stable_segments(self) -> list[np.ndarray]:
        """The runs of consecutive stable points (indices), each a stretch of one branch."""
        out, run = [], []
        for k, s in enumerate(self.stable):
            if s:
                run.append(k)
            elif run:
                out.append(np.array(run))
                run = []
        if run:
            out.append(np.array(run))
        return [r for r in out if r.size >= 2]

    def follow(self, frequency_hz: np.ndarray, dof: int | str = 1, start_amplitude: float | None = None) -> np.ndarray:
        """The first-harmonic amplitude a slow test reads at a sequence of frequencies, in the order played.

        The test stays on the stable stretch it is on while the frequency stays within it; where the
        stretch ends (a fold, or a loss of stability), it lands on the stable stretch at the new
        frequency whose amplitude is nearest the last one it read (the other branch). It starts on the
        stable solution nearest ``start_amplitude`` (default: the smallest, as from rest). NaN where no
        stable solution is known.
        """
        f = np.atleast_1d(np.asarray(frequency_hz, dtype=float))
        amp = self.amplitude(dof)
        fr = self.frequency_hz
        segments = self.stable_segments()

        def value(seg: np.ndarray, x: float) -> float:
            order = np.argsort(fr[seg], kind="stable")
            xs, ys = fr[seg][order], amp[seg][order]
            slack = 1e-9 * max(abs(xs[-1]), 1.0)  # the band's ends, to the rounding of 2 pi
            return float(np.interp(x, xs, ys)) if xs[0] - slack <= x <= xs[-1] + slack else float("nan")

        out = np.full(f.size, np.nan)
        current = None
        for k, x in enumerate(f):
            if current is not None and np.isfinite(value(segments[current], x)):
                out[k] = value(segments[current], x)
                continue
            options = [(i, value(seg, x)) for i, seg in enumerate(segments)]
            options = [(i, y) for i, y in options if np.isfinite(y)]
            if not options:
                current = None
                continue
            target = out[k - 1] if k and np.isfinite(out[k - 1]) else start_amplitude
            if target is None:
                current, out[k] = min(options, key=lambda o: o[1])
            else:
                current, out[k] = min(options, key=lambda o: abs(o[1] - target))
        return out

    def at(self, frequency_hz: float, direction: str = "up", dof: int | str = 1) -> float:
        """The first-harmonic amplitude a slow sweep in ``direction`` reads at a frequency (NaN outside the curve)."""
        return float(self.along(np.array([frequency_hz]), direction, dof)[0][0])

    def to_dict(self) -> dict[str, Any]:
        """Plain data (the coefficients as nested lists)."""
        return {
            "parameter": self.parameter,
            "start": list(self.start),
            "frequency_hz": self.frequency_hz.tolist(),
            "force": self.force.tolist(),
            "stable": [bool(x) for x in self.stable],
            "multiplier": self.multiplier.tolist(),
            "instability": list(self.instability),
            "labels": list(self.labels),
            "coefficients": self.coefficients.tolist(),
            "events": [e.to_dict() for e in self.events],
            "truncation": None if self.truncation is None else self.truncation.tolist(),
            "stopped": self.stopped,
            "dofs": list(self.dofs),
        }


def motion_labels(curve_coefficients: np.ndarray, saddles: tuple[float, ...], wells: tuple[float, ...]) -> list[str]:
    """``"in-well z*=..."`` or ``"cross-well"`` for each point of a one-DOF double well, from its extremes.

    A motion that stays on one side of every unstable equilibrium (saddle) is in the well of the stable
    equilibrium on that side; one that passes a saddle is cross-well.
    """
    if not saddles or len(wells) < 2:
        return [""] * len(curve_coefficients)
    basis = Harmonics((curve_coefficients.shape[-1] - 1) // 2)
    fine = basis.fine(curve_coefficients, 256)
    lo, hi = fine.min(axis=1), fine.max(axis=1)
    out = []
    for a, b, mid in zip(lo, hi, fine.mean(axis=1), strict=True):
        if any(a < s < b for s in saddles):
            out.append("cross-well")
        else:
            well = min(wells, key=lambda w: abs(w - mid) if all((w < s) == (mid < s) for s in saddles) else np.inf)
            out.append(f"in-well z*={well:.4g}")
    return out
