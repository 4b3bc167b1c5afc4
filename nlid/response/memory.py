"""Memory terms in the harmonic balance: the hysteretic state integrated to its periodic regime.

A memory law (Bouc-Wen, Dahl: :mod:`nlid.model.terms.memory`) is rate-independent,
so its state ``w`` follows the path of the displacement. Inside each AFT step
the relative displacement is sampled on the uniform rule (``N`` samples per
period), and ``w`` is moved along it with the exact monotone steps of
:mod:`nlid.model.terms.memory_kernels`. The periodic regime is the fixed point
``w(2 pi) = w(0)``, found by Newton's method on the one-period map (warm
started from the previous solution; its slope ``dPhi/dw0 < 1`` for a
dissipative law). Its sensitivities to the motion's coefficients are
propagated with the steps' own derivatives (``dw/dw`` and ``dw/ddz``), and
the periodicity condition closes them: ``dw0/dc = (dPhi/dc) / (1 - dPhi/dw0)``.

For Hill's method the state is a variable of its own: the rate form
``w' = h(w, v)`` (``h = v - a |v| w - b v |w|`` for Bouc-Wen,
``(v / rho) (1 - w sign v)`` for Dahl) is linearised along the periodic
orbit (:func:`hill_blocks`).
"""

from __future__ import annotations

import numba
import numpy as np

from ..model.terms.memory_kernels import bouc_wen_step_d, dahl_step_d
from .system import Group

__all__ = ["memory_force", "periodic_state"]

_LAWS = {"bouc_wen": 1, "dahl": 2}


@numba.njit(cache=True)
def _step(law, w, dz, p1, p2):
    if law == 1:
        new, dw, ddz, _, _ = bouc_wen_step_d(w, dz, p1, p2)
    else:
        new, dw, ddz, _ = dahl_step_d(w, dz, p1)
    return new, dw, ddz


@numba.njit(cache=True)
def _periodic(z, E, law, p1, p2, w0, out_w, out_S):
    """The periodic state along the closed path ``z`` and ``dw/dc``; the Newton iterations used (-1: no fixed point)."""
    n = z.size
    P = E.shape[1]
    used = -1
    for it in range(60):
        w = w0
        slope = 1.0
        for j in range(n):
            dz = z[(j + 1) % n] - z[j]
            if dz != 0.0:
                w, dw, _ = _step(law, w, dz, p1, p2)
                slope *= dw
        r = w - w0
        if abs(r) <= 1e-14 * max(1.0, abs(w0)):
            used = it
            break
        w0 = w0 - r / (slope - 1.0) if slope < 1.0 - 1e-12 else w
    S = np.zeros(P)
    Dj = np.ones(n)
    w = w0
    D = 1.0
    out_w[0] = w0
    for k in range(P):
        out_S[0, k] = 0.0
    for j in range(n):
        nxt = (j + 1) % n
        dz = z[nxt] - z[j]
        if dz != 0.0:
            w, dw, ddz = _step(law, w, dz, p1, p2)
        else:
            dw = 1.0
            ddz = 0.0
        D *= dw
        for k in range(P):
            S[k] = dw * S[k] + ddz * (E[nxt, k] - E[j, k])
        if nxt != 0:
            out_w[nxt] = w
            Dj[nxt] = D
            for k in range(P):
                out_S[nxt, k] = S[k]
    if D < 1.0 - 1e-12:
        for k in range(P):
            S[k] = S[k] / (1.0 - D)  # dw0/dc
        for j in range(n):
            for k in range(P):
                out_S[j, k] += Dj[j] * S[k]
    return used


def periodic_state(law: str, params: tuple[float, ...], z: np.ndarray, E: np.ndarray, w0: float = 0.0) -> tuple:
    """The periodic state of a memory law along the closed sampled path ``z`` (one period, uniform phases).

    Parameters
    ----------
    law, params
        ``"bouc_wen"`` with ``(a, b)`` or ``"dahl"`` with ``(rho,)``.
    z
        The displacement samples of one period.
    E
        The basis at the samples' phases, ``(N, P)``: the sensitivities are to its coefficients.
    w0
        A first guess of the state at the first sample.

    Returns
    -------
    w, dw_dc, converged
        The state ``(N,)``, its derivative ``(N, P)`` and whether the fixed point converged.
    """
    p = tuple(float(x) for x in params) + (0.0,)
    w = np.empty(z.size)
    S = np.empty((z.size, E.shape[1]))
    used = _periodic(np.ascontiguousarray(z), np.ascontiguousarray(E), _LAWS[law], p[0], p[1], float(w0), w, S)
    return w, S, used >= 0


def _rates(law: str, params: tuple[float, ...], w: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``dh/dw`` and ``dh/dv`` of the rate form ``w' = h(w, v)`` on samples."""
    if law == "bouc_wen":
        a, b = params
        return -a * np.abs(v) - b * v * np.sign(w), 1.0 - a * np.sign(v) * w - b * np.abs(w)
    (rho,) = params
    return -np.abs(v) / rho, (1.0 - w * np.sign(v)) / rho


def memory_force(evaluator, index: int, group: Group, x: np.ndarray, V: np.ndarray) -> tuple:
    """The force ``theta w`` of a memory group: ``(F, dF/dx, Hill's blocks (theta, Hw, Hv, converged))``."""
    basis = evaluator.basis
    _, wts, E = basis.uniform(evaluator.memory_samples)
    term = group.terms[0]
    law, params = term.memory
    theta = float(group.theta[0])
    w, S, ok = periodic_state(law, params, E @ x, E, evaluator.states.get(index, 0.0))
    if ok:
        evaluator.states[index] = float(w[0])
    norms = basis.norms
    F = theta * norms * (E.T @ (wts * w))
    Jx = theta * norms[:, None] * (E.T @ (wts[:, None] * S))
    hw, hv = _rates(law, params, w, E @ V)
    Hw = norms[:, None] * (E.T @ ((wts * hw)[:, None] * E))
    Hv = norms[:, None] * (E.T @ ((wts * hv)[:, None] * E))
    return F, Jx, (theta, Hw, Hv, ok)
