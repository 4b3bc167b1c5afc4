"""Time integration of a fitted model under a harmonic or swept force, for checking the harmonic balance.

The integrators are nlid's own (:func:`nlid.simulation.simulate` for one DOF,
:func:`nlid.simulation.structure.simulate` for a structure): classical RK4 with the
force held over each step. The force of a step is taken at the step's
midpoint, so that holding it costs no delay; with :data:`STEPS` steps per
period the error of the first-harmonic amplitude from the time step is about
``(2 pi / STEPS)^2 / 24`` (under ``10^-5``).

:func:`first_harmonic` projects the last whole periods of a run on
``[1, cos, sin]``; :func:`envelope` does the same cycle by cycle along a
sweep.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .fitted import Fitted

__all__ = ["Simulator", "first_harmonic", "envelope", "STEPS"]

#: RK4 steps per period of the force.
STEPS = 512


@dataclass(frozen=True)
class Simulator:
    """Integrates a fitted model (:class:`~nlid.response.fitted.Fitted`: one DOF or a structure) under a force."""

    fitted: Fitted

    @property
    def n(self) -> int:
        """Number of DOFs."""
        return self.fitted.n

    def run(
        self, force: np.ndarray, fs: float, z0: Sequence[float], v0: Sequence[float]
    ) -> tuple[np.ndarray, np.ndarray]:
        """Displacement and velocity ``(N, n)`` under ``force`` ``(N, n)`` held over each step of ``1/fs``."""
        force = np.ascontiguousarray(force, dtype=float)
        f = self.fitted
        if f.structure is None:
            from ..simulation import simulate

            z, v, _ = simulate(f.model, f.theta, f.mass, force[:, 0], fs, (float(z0[0]), float(v0[0])))
            return z[:, None], v[:, None]
        from ..simulation.structure import simulate as simulate_structure

        z, v, _ = simulate_structure(f.structure, force, fs, x0=(np.asarray(z0), np.asarray(v0)))
        return z, v

    def harmonic(
        self,
        omega: float,
        amplitude: float,
        pattern: np.ndarray,
        z0: np.ndarray,
        v0: np.ndarray,
        periods: int,
        steps: int = STEPS,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``periods`` periods of ``amplitude cos(omega t)`` from ``(z0, v0)`` at ``t = 0``.

        Returns
        -------
        z : numpy.ndarray
            The displacement ``(periods * steps, n)`` at the step times.
        z_end, v_end : numpy.ndarray
            The state after the last step (phase 0 again: where a following run starts).
        """
        dt = 2 * np.pi / omega / steps
        t = (np.arange(periods * steps + 1) + 0.5) * dt
        force = amplitude * np.cos(omega * t)[:, None] * pattern[None, :]
        z, v = self.run(force, 1.0 / dt, z0, v0)
        return z[:-1], z[-1], v[-1]

    def swept(
        self,
        f0: float,
        f1: float,
        rate: float,
        amplitude: float,
        pattern: np.ndarray,
        z0: np.ndarray,
        steps: int = 128,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """A linear sweep from ``f0`` to ``f1`` Hz at ``rate`` Hz/s: ``(t, phase, z)``, ``steps`` per top period."""
        duration = abs(f1 - f0) / rate
        dt = 1.0 / (steps * max(f0, f1))
        n = int(np.ceil(duration / dt))
        if n > 5e8:
            raise InputError(f"the sweep would need {n} steps: raise rate= or narrow the band")
        sign = 1.0 if f1 >= f0 else -1.0
        t = np.arange(n) * dt

        def phase(x: np.ndarray) -> np.ndarray:
            return 2 * np.pi * (f0 * x + sign * 0.5 * rate * x**2)

        force = amplitude * np.cos(phase(t + 0.5 * dt))[:, None] * pattern[None, :]
        z, _ = self.run(force, 1.0 / dt, z0, np.zeros_like(z0))
        return t, phase(t), z


def first_harmonic(z: np.ndarray, steps: int, periods: int) -> tuple[np.ndarray, np.ndarray]:
    """Offset and first-harmonic amplitude per DOF over the last ``periods`` periods of ``steps`` samples each."""
    tail = z[-periods * steps :]
    tau = 2 * np.pi * np.arange(tail.shape[0]) / steps
    c, s = np.cos(tau), np.sin(tau)
    a = 2 * (c @ tail) / tail.shape[0]
    b = 2 * (s @ tail) / tail.shape[0]
    return tail.mean(axis=0), np.hypot(a, b)


def envelope(phase: np.ndarray, z: np.ndarray, rate_sign: float, f0: float, rate: float, t: np.ndarray) -> tuple:
    """Cycle-by-cycle first-harmonic amplitude of a sweep: ``(frequency_hz, amplitude (cycles, n))``.

    Each whole cycle of the force's phase is projected on ``cos`` and ``sin`` of that phase (after removing
    the cycle's mean).
    """
    cycle = np.floor(phase / (2 * np.pi)).astype(np.int64)
    edges = np.flatnonzero(np.diff(cycle)) + 1
    if edges.size < 2:
        return np.empty(0), np.empty((0, z.shape[1]))
    starts = edges[:-1]
    counts = np.diff(edges)[:, None]
    part = slice(edges[0], edges[-1])
    zz, ph = z[part], phase[part]
    at = starts - edges[0]
    mean = np.add.reduceat(zz, at, axis=0) / counts
    c = np.add.reduceat(zz * np.cos(ph)[:, None], at, axis=0)
    s = np.add.reduceat(zz * np.sin(ph)[:, None], at, axis=0)
    c -= mean * np.add.reduceat(np.cos(ph), at)[:, None]
    s -= mean * np.add.reduceat(np.sin(ph), at)[:, None]
    amp = 2 * np.hypot(c, s) / counts
    mid = 0.5 * (t[starts] + t[edges[1:] - 1])
    return f0 + rate_sign * rate * mid, amp
