"""Intersample behaviour: the inputs of the discrete model as means over each sample interval.

The discrete model is the exact zero-order-hold (ZOH) discretisation of the
continuous one (:func:`nlid_nsi.continuous.d2c_zoh`). It is exact when every
input is constant over each sample interval, which holds for a force held by
a DAC or a simulator (``record.force_hold == "zoh"``), but not for the
state-dependent extended inputs ``z, z^3, v*|v|, ...``: treating their samples
as held delays them by half a sample and biases the damping by about
``k~1 dt / 2`` (NOTES.md; -18 % on c_v at k~1 = 600, 2048 Hz). An input
``u(t)`` that varies within the interval enters a ZOH model correctly (to
O(dt^3)) through its **mean over the interval** ``[t_k, t_k+1)``.

State-dependent inputs (:func:`interval_mean`)
    3-point Gauss-Legendre quadrature of ``g(z(t), v(t))`` on the cubic Hermite
    interpolant of ``(z_k, v_k)``, ``(z_k+1, v_k+1)``. Measured on
    paper-numerical (noise 0, exact v, median of seeds 0-4, prototype): sample
    values (ZOH) bias c_v by -17.7 %, the trapezoid ``(g_k + g_k+1) / 2`` by
    -3.1 % (within an interval the held force gives a constant acceleration,
    so v is linear and the trapezoid overestimates the mean of v*|v| by
    ``(dv)^2 / 6``: a Coulomb-like 0.011 N), the Gauss-Hermite mean by 0.03 %.

Force (:func:`force_interval_mean`)
    ``"zoh"``: the held value is the interval mean. ``"sampled"`` (samples of
    a continuous force, the default of measured records): the mean over the
    interval of the cubic through ``f_k-1 .. f_k+2``,
    ``(-f_k-1 + 13 f_k + 13 f_k+1 - f_k+2) / 24``, exact for cubics.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

__all__ = ["interval_mean", "interval_means", "trapezoid_mean", "force_interval_mean"]

_GAUSS3 = (np.array([-math.sqrt(0.6), 0.0, math.sqrt(0.6)]), np.array([5.0, 8.0, 5.0]) / 9.0)


#: Samples per block of :func:`interval_means` (bounds its temporary memory).
BLOCK = 16384


def interval_means(
    funcs: Sequence[Callable[[np.ndarray, np.ndarray], np.ndarray]],
    z: np.ndarray,
    v: np.ndarray,
    dt: float,
    out: np.ndarray | None = None,
    block: int = BLOCK,
    signs: Sequence[float] | None = None,
) -> np.ndarray:
    """Mean of every ``func(z(t), v(t))`` over each sample interval ``[t_k, t_k+1)``.

    ``z(t)`` is the cubic Hermite interpolant of the samples of ``z`` with
    slopes ``v`` and ``v(t)`` its derivative; the mean is the 3-point
    Gauss-Legendre rule on it. The interpolant at the Gauss points is formed
    once for all functions, one block of samples at a time. The last sample
    (no following interval) keeps its point value.

    Parameters
    ----------
    funcs
        Vectorised functions of ``(z, v)``.
    z, v
        Samples, shape ``(N,)``.
    dt
        Sampling interval.
    out
        Array of shape ``(N, len(funcs))`` (or a view) to write into.
    block
        Samples per block.
    signs
        ``+1`` or ``-1`` per function: the mean of ``sign * func`` is written
        (exact: a sign flip rounds nothing).

    Returns
    -------
    numpy.ndarray
        ``out``, shape ``(N, len(funcs))``.
    """
    n = len(z)
    if out is None:
        out = np.empty((n, len(funcs)))
    signs = [1.0] * len(funcs) if signs is None else [float(x) for x in signs]
    for r0 in range(0, n - 1, block):
        r1 = min(r0 + block, n - 1)
        z0, z1, v0, v1 = z[r0:r1], z[r0 + 1 : r1 + 1], v[r0:r1], v[r0 + 1 : r1 + 1]
        acc = np.zeros((len(funcs), r1 - r0))
        for x, weight in zip(*_GAUSS3, strict=True):
            s = 0.5 * (x + 1.0)
            h00, h10, h01, h11 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2, s**3 - s**2
            d00, d10, d11 = (6 * s**2 - 6 * s) / dt, 3 * s**2 - 4 * s + 1, 3 * s**2 - 2 * s
            zs = h00 * z0 + h10 * dt * v0 + h01 * z1 + h11 * dt * v1
            vs = d00 * (z0 - z1) + d10 * v0 + d11 * v1
            for j, func in enumerate(funcs):
                acc[j] += (0.5 * weight * signs[j]) * func(zs, vs)
        for j in range(len(funcs)):
            out[r0:r1, j] = acc[j]
    for j, func in enumerate(funcs):
        out[n - 1, j] = signs[j] * func(z[-1:], v[-1:])[0]
    return out


def interval_mean(
    func: Callable[[np.ndarray, np.ndarray], np.ndarray], z: np.ndarray, v: np.ndarray, dt: float
) -> np.ndarray:
    """Mean of ``func(z(t), v(t))`` over each sample interval ``[t_k, t_k+1)`` (see :func:`interval_means`).

    ``z(t)`` is the cubic Hermite interpolant of the samples of ``z`` with
    slopes ``v`` and ``v(t)`` its derivative. The last sample (no following
    interval) keeps its point value.
    """
    return interval_means([func], z, v, dt)[:, 0]


def trapezoid_mean(x: np.ndarray) -> np.ndarray:
    """``(x_k + x_k+1) / 2``: the interval mean when only samples are known."""
    out = np.array(x, dtype=float)
    out[:-1] = 0.5 * (out[:-1] + out[1:])
    return out


def force_interval_mean(f: np.ndarray, hold: str) -> np.ndarray:
    """Mean of the force over each sample interval (see the module docstring)."""
    f = np.asarray(f, dtype=float)
    if hold == "zoh":
        return f
    if hold != "sampled":
        raise ValueError(f"unknown force hold {hold!r}")
    out = trapezoid_mean(f)
    out[1:-2] = (-f[:-3] + 13.0 * f[1:-2] + 13.0 * f[2:-1] - f[3:]) / 24.0
    return out
