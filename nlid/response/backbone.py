"""Backbone curves: the free periodic motions of the conservative part (nonlinear normal modes).

The conservative part keeps the mass, the stiffness and the static force,
and drops every velocity-dependent and memory term
(:meth:`~nlid.response.system.HarmonicSystem.conservative`). Its free
periodic motions with zero velocity at ``t = 0`` are even in time, so they
are sought on the cosine harmonics alone, ``z = c_0 + sum a_k cos k tau``,
with the frequency as one more unknown; the curve of solutions is continued
in pseudo-arclength (:mod:`nlid.response.continuation`) from a small motion
along a linear mode, towards larger amplitudes.

* **In-well** backbones start at each stable equilibrium, along each linear
  mode there (``modes=``); in a double well they soften towards the
  separatrix, where the period grows without bound and the continuation stops
  (it says so).
* The **cross-well** backbone of a one-DOF double well starts from a motion
  large enough to enclose every equilibrium (found with one harmonic, then
  refined), and is continued both ways: down towards the separatrix and up.

:func:`duffing_frequency` is the textbook single-harmonic backbone
``omega^2 = omega_0^2 + (3/4) (k_3 / m) A^2`` and :func:`duffing_exact` the
exact one (an elliptic integral), for checks.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import InputError
from .balance import Balance, time_residual
from .continuation import Continuation
from .harmonics import Harmonics
from .system import HarmonicSystem

__all__ = ["Backbone", "backbones", "duffing_frequency", "duffing_exact"]


@dataclass(frozen=True, eq=False)
class Backbone:
    """One backbone curve.

    Attributes
    ----------
    label
        ``"in-well z*=..."``, ``"cross-well"`` or ``"mode k at ..."`` for a structure.
    start
        The equilibrium it grows from (per DOF); for the cross-well backbone, the unstable one it encloses.
    mode
        The linear mode it follows at small amplitude (1-based; 0 for cross-well).
    frequency_hz
        Frequency of each point (Hz).
    coefficients
        ``(points, n, 2H + 1)`` (the sine coefficients are zero).
    stopped
        Why the continuation stopped.
    dofs
        DOF names.
    """

    label: str
    start: tuple[float, ...]
    mode: int
    frequency_hz: np.ndarray
    coefficients: np.ndarray
    stopped: str
    dofs: tuple[str, ...] = ("z",)

    @property
    def basis(self) -> Harmonics:
        """The basis of the coefficients."""
        return Harmonics((self.coefficients.shape[-1] - 1) // 2)

    def dof_index(self, dof: int | str) -> int:
        """The row of a DOF given by number (1-based) or name."""
        return self.dofs.index(dof) if isinstance(dof, str) else int(dof) - 1

    def amplitude(self, dof: int | str = 1, order: int = 1) -> np.ndarray:
        """First-harmonic amplitude of a DOF along the backbone (m)."""
        return self.basis.amplitude(self.coefficients[:, self.dof_index(dof), :], order)

    def peak(self, dof: int | str = 1) -> np.ndarray:
        """``max |z - c_0|`` over the period (m)."""
        c = self.coefficients[:, self.dof_index(dof), :]
        fine = self.basis.fine(c, 256)
        return np.max(np.abs(fine - c[:, :1]), axis=1)

    def to_dict(self) -> dict[str, Any]:
        """Plain data."""
        return {
            "label": self.label,
            "start": list(self.start),
            "mode": self.mode,
            "frequency_hz": self.frequency_hz.tolist(),
            "coefficients": self.coefficients.tolist(),
            "stopped": self.stopped,
            "dofs": list(self.dofs),
        }


def duffing_frequency(omega0: float, cubic_per_mass: float, amplitude: np.ndarray) -> np.ndarray:
    """The single-harmonic backbone ``sqrt(omega0^2 + (3/4) k3/m A^2)`` (rad/s)."""
    return np.sqrt(omega0**2 + 0.75 * cubic_per_mass * np.asarray(amplitude) ** 2)


def duffing_exact(omega0: float, cubic_per_mass: float, peak: np.ndarray) -> np.ndarray:
    """The exact backbone of ``x'' + omega0^2 x + beta x^3 = 0`` for the peak displacement ``X`` (rad/s).

    ``omega = pi sqrt(omega0^2 + beta X^2) / (2 K(m))`` with ``m = beta X^2 / (2 (omega0^2 + beta X^2))``.
    """
    from scipy.special import ellipk

    X2 = np.asarray(peak, dtype=float) ** 2
    s = omega0**2 + cubic_per_mass * X2
    return np.pi * np.sqrt(s) / (2 * ellipk(cubic_per_mass * X2 / (2 * s)))


class _Reduced:
    """The cosine-only equations of the conservative system, for the continuation: ``y = (cos coefficients, omega)``."""

    def __init__(self, balance: Balance):
        self.balance = balance
        n, P = balance.n, balance.P
        cos = [0] + list(range(1, P, 2))
        self.sel = np.array([i * P + k for i in range(n) for k in cos])
        self.size = self.sel.size

    def full(self, yc: np.ndarray) -> np.ndarray:
        X = np.zeros(self.balance.size)
        X[self.sel] = yc
        return X

    def __call__(self, y: np.ndarray):
        X = self.full(y[:-1])
        r, J, dw, _, _ = self.balance.evaluate(X, y[-1], 0.0)
        sel = self.sel
        return r[sel], np.column_stack([J[np.ix_(sel, sel)], dw[sel]]), None


#: A backbone stops where the equations, evaluated between the harmonics it balances, miss by more than this
#: fraction of the inertia force (:func:`nlid.response.balance.time_residual`): measured on the paper's double
#: well towards its separatrix, the frequency is then still exact to 0.005 % (at 1e-4 it was 0.6 % off).
TRUNCATION = 1e-5


def _branch(
    reduced: _Reduced,
    y0: np.ndarray,
    fix: int,
    x_ref: float,
    w_ref: float,
    limit: float,
    step: float,
    guides,
    saddles: Sequence[float] = (),
    truncation: float | None = TRUNCATION,
) -> list[tuple[list[np.ndarray], str]]:
    """Solve at ``y0`` with unknown ``fix`` held, then continue along each guide; ``[(points, stopped)]``.

    A branch stops at the amplitude ``limit``, where the harmonics no longer hold (:data:`TRUNCATION`), or
    (``saddles``: an in-well branch of one DOF) where the motion reaches an unstable equilibrium.
    """
    scale = np.r_[np.full(reduced.size, x_ref), w_ref]
    basis = reduced.balance.basis
    n, H = reduced.balance.n, basis.H
    zero = np.zeros(n)

    def stop(y):
        c = y[:-1].reshape(n, H + 1)
        amp = np.abs(c[:, 1])
        if np.max(amp) > limit:
            return f"reached the largest amplitude asked ({limit:.4g} m)"
        miss = (
            time_residual(reduced.balance.system, reduced.full(y[:-1]).reshape(n, -1), y[-1], 0.0, zero, basis, "force")
            if truncation is not None
            else 0.0
        )
        if truncation is not None and miss > truncation:
            return f"the {H} harmonics no longer hold (the equations miss by {miss:.1g} between them): more harmonics="
        if saddles:
            z = c[0] @ np.cos(np.outer(np.arange(H + 1), np.linspace(0, np.pi, 129)))
            for s in saddles:
                if z.min() < s < z.max():
                    return f"the motion reached the unstable equilibrium z = {s:.4g} m (the separatrix)"
        return None

    cont = Continuation(
        reduced, scale, max(x_ref * w_ref**2, 1e-12), (1e-3 * w_ref, 1e3 * w_ref), h_max=step, stop=stop
    )
    first = cont.solve_at(y0, fix=fix)
    if first is None:
        return []
    out = []
    for guide in guides:
        branch = cont.run(first, guide=guide)
        reason = branch.stopped
        if reason.startswith("turned back") or reason.startswith("reached the end"):
            reason = "the frequency left its range (towards a separatrix, where the period grows without bound)"
        out.append((branch.y, reason))
    return out


def _pack(reduced: _Reduced, points: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    b = reduced.balance
    coeffs = np.array([reduced.full(y[:-1]).reshape(b.n, b.P) for y in points])
    return np.array([y[-1] for y in points]) / (2 * np.pi), coeffs


def backbones(
    system: HarmonicSystem,
    stable: Sequence[np.ndarray],
    unstable: Sequence[np.ndarray],
    amplitude: float,
    *,
    harmonics: int = 7,
    modes: Sequence[int] | None = None,
    samples: int | None = None,
    step: float = 0.02,
    truncation: float | None = TRUNCATION,
) -> list[Backbone]:
    """The backbones of the conservative part up to a first-harmonic ``amplitude`` (m) (module docstring).

    Parameters
    ----------
    system
        The full system (its conservative part is taken here).
    stable, unstable
        Its equilibria.
    amplitude
        The largest first-harmonic amplitude to continue to (m).
    harmonics
        Number of harmonics.
    modes
        Linear modes to follow from each stable equilibrium (1-based; default: all of them).
    samples
        Quadrature size.
    step
        Largest continuation step.
    truncation
        Stop where the harmonics no longer hold (:data:`TRUNCATION`); ``None``: continue to the amplitude
        asked whatever the truncation (one harmonic, the textbook approximation, always does).
    """
    if not amplitude > 0:
        raise InputError(f"the backbone needs a positive amplitude, got {amplitude}")
    cons = system.conservative()
    balance = Balance(cons, harmonics, np.zeros(cons.n), samples)
    reduced = _Reduced(balance)
    n, H = cons.n, balance.basis.H
    if H == 1:
        truncation = None
    out = []
    for z0 in stable:
        K = cons.stiffness(z0)
        from scipy.linalg import eigh

        w2, phi = eigh(K, cons.M)
        if np.any(w2 <= 0):
            continue
        for j in modes or range(1, n + 1):
            if not 1 <= j <= n:
                raise InputError(f"modes= must be mode numbers from 1 to {n}, got {j}")
            w = float(np.sqrt(w2[j - 1]))
            shape = phi[:, j - 1] / np.max(np.abs(phi[:, j - 1]))
            lead = int(np.argmax(np.abs(shape)))
            small = 1e-3 * amplitude
            yc = np.zeros((n, H + 1))
            yc[:, 0] = z0
            yc[:, 1] = small * shape
            y0 = np.r_[yc.ravel(), w]
            fix = lead * (H + 1) + 1
            guide = np.zeros(y0.size)
            guide[fix] = np.sign(shape[lead])
            saddles = [float(u[0]) for u in unstable] if n == 1 else []
            found = _branch(reduced, y0, fix, amplitude, w, amplitude, step, [guide], saddles, truncation)
            if not found:
                continue
            points, stopped = found[0]
            f, c = _pack(reduced, points)
            label = (
                f"in-well z*={z0[0]:.4g}"
                if n == 1 and unstable
                else ("backbone" if n == 1 else f"mode {j} at z*=({', '.join(f'{x:.3g}' for x in z0)})")
            )
            out.append(Backbone(label, tuple(float(x) for x in z0), j, f, c, stopped, cons.dofs))
    if n == 1 and unstable and len(stable) >= 2:
        cross = _cross_well(cons, reduced, stable, unstable, amplitude, step, truncation)
        if cross is not None:
            out.append(cross)
    return out


def _cross_well(
    cons, reduced: _Reduced, stable, unstable, amplitude: float, step: float, truncation: float | None
) -> Backbone | None:
    """The cross-well backbone of a one-DOF double well, continued down and up from an enclosing motion."""
    H = reduced.balance.basis.H
    wells = [float(s[0]) for s in stable]
    saddle = float(unstable[0][0])
    span = max(abs(w - saddle) for w in wells)
    if amplitude <= 0.5 * span:  # no cross-well motion of that amplitude
        return None
    A = max(1.6 * span, 0.5 * amplitude)
    # one harmonic: c0 and omega for the amplitude A (Newton on two equations), then all harmonics
    one = Balance(cons, 1, np.zeros(1))
    c0, w = saddle, float(np.sqrt(abs(cons.stiffness(np.array([saddle]))[0, 0]) / cons.M[0, 0]) + 1.0)
    for _ in range(50):
        r, J, dw, _, _ = one.evaluate(np.array([c0, A, 0.0]), w, 0.0)
        F = np.array([r[0], r[1]])
        Jr = np.array([[J[0, 0], dw[0]], [J[1, 0], dw[1]]])
        try:
            d = np.linalg.solve(Jr, -F)
        except np.linalg.LinAlgError:
            return None
        c0, w = c0 + d[0], abs(w + d[1])
        if np.max(np.abs(d / np.array([max(A, 1e-12), max(w, 1e-12)]))) < 1e-12:
            break
    yc = np.zeros(H + 1)
    yc[0], yc[1] = c0, A
    y0 = np.r_[yc, w]
    fix = 1
    down, up = np.zeros(y0.size), np.zeros(y0.size)
    down[fix], up[fix] = -1.0, 1.0
    found = _branch(reduced, y0, fix, max(amplitude, A), w, max(amplitude, 1.05 * A), step, [down, up], (), truncation)
    if not found:
        return None
    (low, why_low), (high, _) = found
    points = low[::-1] + high[1:]
    f, c = _pack(reduced, points)
    return Backbone("cross-well", (saddle,), 0, f, c, why_low, cons.dofs)
