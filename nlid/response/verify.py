"""Checked, not assumed: continuation points against long time integration, and jumps against a swept sine.

:func:`check_points` integrates the model in time (:mod:`nlid.response.timesim`)

* from each sampled *stable* point's own state (the folds excepted), for as
  many periods as its Floquet multiplier needs to shrink an error a million
  times, then in blocks until the first-harmonic amplitude and the offset settle
  (two blocks agree to 1e-5 of the amplitude), and reports the difference from the harmonic
  balance in percent of its amplitude, per DOF;
* from *unstable* points perturbed by 1 % of their amplitude (both ways), for
  as many periods as the multiplier needs to grow the perturbation a
  thousand times, then until settled, and reports whether the integration
  stays on them (it should not: an unstable point is reached when the
  settled amplitude is within 0.5 % of its own). A point so weakly unstable
  that this exceeds :data:`MAX_PERIODS` is reported as not settled.

:func:`check_sweeps` simulates slow sweeps up and down through the band at a
given rate, finds the jump in the cycle-by-cycle amplitude, and puts it beside
the fold the continuation says a sweep in that direction jumps at.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .backbone import Backbone
from .curves import ResponseCurve
from .fitted import Fitted
from .timesim import STEPS, Simulator, envelope, first_harmonic

__all__ = [
    "PointCheck",
    "SweepCheck",
    "BackboneCheck",
    "check_points",
    "check_sweeps",
    "check_backbones",
    "REACHED_PERCENT",
]

#: An unstable point counts as reached when a run from near it settles within this distance (percent).
REACHED_PERCENT = 0.5
#: Periods per block of a settling run, and most periods.
BLOCK, MAX_PERIODS = 50, 4000


@dataclass(frozen=True)
class PointCheck:
    """One continuation point against time integration.

    Attributes
    ----------
    curve, index
        The curve (its position in the response) and the point.
    frequency_hz, force
        Where.
    stable
        The continuation's verdict.
    balance, simulated
        First-harmonic amplitude per DOF: harmonic balance, time integration (m).
    error_percent
        For a stable point: the largest ``|simulated - balance| / balance`` over the DOFs (percent);
        for an unstable one: the least distance a perturbed run settled at from it.
    settled
        Whether the run settled within :data:`MAX_PERIODS` periods.
    nearest_stable_percent
        For an unstable point: the distance of that settled run from the nearest stable point the
        continuation found at the same frequency and force (NaN if none).
    """

    curve: int
    index: int
    frequency_hz: float
    force: float
    stable: bool
    balance: tuple[float, ...]
    simulated: tuple[float, ...]
    error_percent: float
    settled: bool
    nearest_stable_percent: float = float("nan")

    @property
    def reached(self) -> bool:
        """For an unstable point: a perturbed run settled on it (within 0.5 %, and nearer it than any stable point)."""
        if self.stable:
            return False
        return self.error_percent < REACHED_PERCENT and not self.nearest_stable_percent < self.error_percent

    def to_dict(self) -> dict[str, Any]:
        """Plain data."""
        return {
            "curve": self.curve,
            "index": self.index,
            "frequency_hz": self.frequency_hz,
            "force": self.force,
            "stable": self.stable,
            "balance": list(self.balance),
            "simulated": list(self.simulated),
            "error_percent": self.error_percent,
            "settled": self.settled,
            "nearest_stable_percent": self.nearest_stable_percent,
            "reached": self.reached,
        }


@dataclass(frozen=True)
class SweepCheck:
    """A simulated sweep's jump beside the continuation's fold.

    Attributes
    ----------
    curve
        The curve the sweep is compared with.
    direction
        ``"up"`` or ``"down"``.
    rate_hz_s
        Sweep rate (Hz/s).
    jump_hz
        Where the simulated amplitude jumps: the onset of its steepest change (NaN: no jump found).
    fold_hz
        Where the continuation's path in that direction jumps (NaN: it does not).
    difference_percent
        ``100 (jump - fold) / fold``.
    """

    curve: int
    direction: str
    rate_hz_s: float
    force: float
    jump_hz: float
    fold_hz: float
    difference_percent: float

    def to_dict(self) -> dict[str, Any]:
        """Plain data."""
        return dict(self.__dict__)


def _state(curve: ResponseCurve, i: int) -> tuple[np.ndarray, np.ndarray, float]:
    """``z(0)``, ``z'(0)`` and ``omega`` of point ``i``."""
    c = curve.coefficients[i]
    omega = 2 * np.pi * curve.frequency_hz[i]
    z0 = c[:, 0] + c[:, 1::2].sum(axis=1)
    k = np.arange(1, curve.harmonics + 1)
    v0 = omega * (c[:, 2::2] * k).sum(axis=1)
    return z0, v0, omega


def _settle(
    sim: Simulator, omega: float, force: float, pattern: np.ndarray, z0, v0, first: int = BLOCK
) -> tuple[np.ndarray, bool]:
    """Run ``first`` periods, then blocks until the first-harmonic amplitude settles; ``(amplitude, settled)``."""
    last = None
    done = 0
    periods = max(BLOCK, min(int(first), MAX_PERIODS))
    last_offset = None
    memory = sim.fitted.system().uses_memory  # the integrator starts a memory state at 0: one run from the start
    start = (z0, v0)
    while done < MAX_PERIODS:
        if memory:
            z, _, _ = sim.harmonic(omega, force, pattern, *start, done + periods)
        else:
            z, z0, v0 = sim.harmonic(omega, force, pattern, z0, v0, periods)
        done += periods
        periods = done if memory else BLOCK
        offset, amp = first_harmonic(z, STEPS, 4)
        tol = 1e-5 * max(float(np.max(amp)), 1e-300)
        # the offset too: a memory state that started away from its periodic regime drifts it slowly
        if last is not None and np.all(np.abs(amp - last) <= tol) and np.all(np.abs(offset - last_offset) <= tol):
            return amp, True
        last, last_offset = amp, offset
    return last, False


def _periods(multiplier: float, factor: float) -> int:
    """Periods for a perturbation to change by ``factor`` at the multiplier's rate (capped)."""
    rate = abs(np.log(max(multiplier, 1e-300)))
    if rate < 1e-12:
        return MAX_PERIODS
    return int(min(MAX_PERIODS, np.ceil(abs(np.log(factor)) / rate)))


def check_points(
    fitted: Fitted, curves: Sequence[ResponseCurve], pattern: np.ndarray, *, points: int = 8, unstable: int = 3
) -> list[PointCheck]:
    """Compare sampled points of each curve with time integration (module docstring).

    Parameters
    ----------
    fitted
        The model (:class:`~nlid.response.fitted.Fitted`, what :class:`~nlid.response.timesim.Simulator` integrates).
    curves
        The continued curves.
    pattern
        The force pattern per DOF.
    points, unstable
        How many stable and unstable points per curve (evenly spread along it).
    """
    sim = Simulator(fitted)
    out = []
    for ci, curve in enumerate(curves):
        for want, stable in ((points, True), (unstable, False)):
            folds = {e.index for e in curve.folds}
            idx = np.array([k for k in np.flatnonzero(curve.stable == stable) if k not in folds], dtype=int)
            if not stable:  # unstable points an amplitude cannot tell from a stable one (next to a fold) are not tried
                apart = [
                    k
                    for k in idx
                    if _nearest_stable(curves, curve, k, curve.basis.amplitude(curve.coefficients[k])) > 2
                ]
                idx = np.array(apart, dtype=int) if apart else idx
            if idx.size == 0 or want <= 0:
                continue
            chosen = idx[np.unique(np.linspace(0, idx.size - 1, min(want, idx.size)).round().astype(int))]
            for i in chosen:
                out.append(_check(sim, curves, curve, ci, int(i), pattern))
    return out


def _nearest_stable(curves: Sequence[ResponseCurve], curve: ResponseCurve, i: int, amp: np.ndarray) -> float:
    """Distance (percent of ``amp``) from ``amp`` to the nearest stable point at point ``i``'s frequency and force."""
    f, force = curve.frequency_hz[i], curve.force[i]
    scale = np.maximum(amp, 1e-300)
    best = np.inf
    for c in curves:
        if c.parameter != curve.parameter or not np.isclose(c.force[0], force) and c.parameter == "frequency":
            continue
        a = c.basis.amplitude(c.coefficients)
        for k in range(len(c) - 1):
            lo, hi = sorted((c.frequency_hz[k], c.frequency_hz[k + 1]))
            if c.stable[k] and c.stable[k + 1] and lo <= f <= hi:
                w = 0.0 if hi == lo else (f - c.frequency_hz[k]) / (c.frequency_hz[k + 1] - c.frequency_hz[k])
                other = (1 - w) * a[k] + w * a[k + 1]
                best = min(best, float(np.max(np.abs(other - amp) / scale)) * 100)
    return best if np.isfinite(best) else float("nan")


def _check(
    sim: Simulator, curves: Sequence[ResponseCurve], curve: ResponseCurve, ci: int, i: int, pattern: np.ndarray
) -> PointCheck:
    z0, v0, omega = _state(curve, i)
    force = float(curve.force[i])
    hb = curve.basis.amplitude(curve.coefficients[i])
    scale = np.maximum(hb, 1e-12 * max(float(np.max(hb)), 1e-300))
    mu = float(curve.multiplier[i])
    if curve.stable[i]:
        amp, settled = _settle(sim, omega, force, pattern, z0, v0, _periods(mu, 1e-7))
        err = float(np.max(np.abs(amp - hb) / scale)) * 100
        near = float("nan")
    else:
        best, settled, amp = np.inf, True, hb
        for sign in (1.0, -1.0):
            a, ok = _settle(sim, omega, force, pattern, z0 + sign * 0.01 * hb, v0, _periods(mu, 1e3))
            d = float(np.max(np.abs(a - hb) / scale)) * 100
            if d < best:
                best, amp, settled = d, a, ok and _periods(mu, 1e3) < MAX_PERIODS
        err = best
        near = _nearest_stable(curves, curve, i, amp)
    return PointCheck(
        ci,
        i,
        float(curve.frequency_hz[i]),
        force,
        bool(curve.stable[i]),
        tuple(float(x) for x in hb),
        tuple(float(x) for x in amp),
        err,
        bool(settled),
        near,
    )


def check_sweeps(
    fitted: Fitted,
    curves: Sequence[ResponseCurve],
    pattern: np.ndarray,
    band_hz: Sequence[float],
    rate: float,
    *,
    dof: int = 1,
) -> list[SweepCheck]:
    """Sweep up and down at ``rate`` Hz/s for each frequency curve and compare the jumps with its folds."""
    sim = Simulator(fitted)
    f_lo, f_hi = float(band_hz[0]), float(band_hz[1])
    out = []
    for ci, curve in enumerate(curves):
        if curve.parameter != "frequency":
            continue
        force = float(curve.force[0])
        for direction in ("up", "down"):
            f0, f1 = (f_lo, f_hi) if direction == "up" else (f_hi, f_lo)
            start = np.asarray(curve.start, dtype=float)
            t, phase, z = sim.swept(f0, f1, rate, force, pattern, start)
            sign = 1.0 if direction == "up" else -1.0
            freq, amp = envelope(phase, z, sign, f0, rate, t)
            a = amp[:, dof - 1]
            jump = _jump(freq, a)
            fold = _fold(curve, direction, jump)
            diff = 100 * (jump - fold) / fold if np.isfinite(jump) and np.isfinite(fold) else float("nan")
            out.append(SweepCheck(ci, direction, float(rate), force, jump, fold, diff))
    return out


def _jump(freq: np.ndarray, amp: np.ndarray) -> float:
    """Where the amplitude jumps: the onset of its steepest cycle-to-cycle change, if that stands out (else NaN).

    The onset is the last cycle before the steepest one whose change is under a tenth of the steepest: a
    sweep leaves the branch at the fold and falls (or rises) ever faster, so the steepest cycle lies some
    cycles past the fold, its onset next to it.
    """
    if amp.size < 8:
        return float("nan")
    skip = max(4, amp.size // 50)  # the start-up transient
    a = amp[skip:]
    f = freq[skip:]
    d = np.diff(a)
    k = int(np.argmax(np.abs(d)))
    typical = float(np.median(np.abs(d))) + 1e-300
    if abs(d[k]) < 20 * typical or abs(d[k]) < 0.02 * float(np.max(a)):
        return float("nan")
    j = k
    while j > 0 and np.sign(d[j - 1]) == np.sign(d[k]) and abs(d[j - 1]) >= 0.1 * abs(d[k]):
        j -= 1
    return float(f[j])


def _fold(curve: ResponseCurve, direction: str, near: float) -> float:
    """Where the continuation's sweep path in ``direction`` leaves the curve (a jump), nearest to ``near``.

    The path leaves it where it skips points (it jumps over an unstable stretch to a later stable point) or
    where it ends before the curve's far end (the curve turns back: the sweep lands somewhere else).
    """
    idx = curve.sweep(direction)
    if idx.size == 0:
        return float("nan")
    f = curve.frequency_hz
    gaps = list(idx[np.flatnonzero(np.abs(np.diff(idx)) > 1)])
    end = f[idx[-1]]
    far = f.max() if direction == "up" else f.min()
    if abs(end - far) > 1e-9 * max(abs(far), 1.0):
        gaps.append(idx[-1])
    if not gaps:
        return float("nan")
    candidates = f[np.array(gaps)]
    if not np.isfinite(near):
        return float(candidates[0])
    return float(candidates[np.argmin(np.abs(candidates - near))])


@dataclass(frozen=True)
class BackboneCheck:
    """A backbone point against a free run of the conservative model.

    Attributes
    ----------
    backbone, index
        The backbone (its position) and the point.
    frequency_hz
        The backbone's frequency there.
    balance, simulated
        First-harmonic amplitude per DOF: harmonic balance, and the free run from the point's state projected
        on the backbone's frequency over its last period (a wrong frequency shows as a phase drift) (m).
    error_percent
        The largest difference over the DOFs, in percent of the largest amplitude.
    """

    backbone: int
    index: int
    frequency_hz: float
    balance: tuple[float, ...]
    simulated: tuple[float, ...]
    error_percent: float

    def to_dict(self) -> dict[str, Any]:
        """Plain data."""
        return {**self.__dict__, "balance": list(self.balance), "simulated": list(self.simulated)}


def check_backbones(
    fitted: Fitted, backbones: Sequence[Backbone], *, points: int = 4, periods: int = 20
) -> list[BackboneCheck]:
    """Integrate the conservative model freely from sampled backbone points for ``periods`` periods."""
    sim = Simulator(fitted.conservative())
    out = []
    for bi, b in enumerate(backbones):
        if len(b.frequency_hz) < 2:
            continue
        for i in np.unique(np.linspace(1, len(b.frequency_hz) - 1, points).round().astype(int)):
            c = b.coefficients[i]
            omega = 2 * np.pi * b.frequency_hz[i]
            z0 = c[:, 0] + c[:, 1::2].sum(axis=1)
            z, _, _ = sim.harmonic(omega, 0.0, np.zeros(c.shape[0]), z0, np.zeros(c.shape[0]), periods)
            _, amp = first_harmonic(z, STEPS, 1)
            hb = b.basis.amplitude(c)
            err = float(np.max(np.abs(amp - hb)) / max(float(np.max(hb)), 1e-300)) * 100
            out.append(
                BackboneCheck(bi, int(i), float(b.frequency_hz[i]), tuple(map(float, hb)), tuple(map(float, amp)), err)
            )
    return out
