"""The compiled integrators: RK4 of ``m z'' + R(z, z') = f`` with the force held over each step.

:func:`simulate` integrates with one step per sample; :func:`free_run` with
:data:`FREE_RUN_OVERSAMPLE` sub-steps per sample and the force between the
samples interpolated (:func:`nlid.simulation.excitation.fine_force`). The
kernels are compiled with numba (``cache=True``: compiled once per machine into
``__pycache__``) and read the model as arrays (:mod:`nlid.simulation.encode`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numba
import numpy as np

from ..base.validate import MASS
from ..errors import InputError, NlidError
from ..model.terms import Model
from ..model.terms.memory_kernels import bouc_wen_step
from .encode import encode_memory, encode_model
from .excitation import fine_force

__all__ = ["simulate", "free_run", "SimulationError", "FREE_RUN_OVERSAMPLE"]

#: Sub-steps per sample of :func:`free_run` (measured on Silverbox: the RMS
#: simulation error of the cubic model is 0.576, 0.486, 0.499, 0.503 mV at 2, 4,
#: 8, 16 sub-steps; one step per sample gives 3.3 mV).
FREE_RUN_OVERSAMPLE = 8


class SimulationError(NlidError, RuntimeError):
    """The integration diverged (the state became non-finite)."""


# --------------------------------------------------------------------------- compiled kernel
#
# The restoring force is evaluated term by term exactly as ``Term.evaluate``
# defines it, ``theta_i * zpart * vpart * pxpart * special factors`` with each
# part ``|x|^p sign(x)^s``, and summed in model order. The kernel is
# specialised, not the arithmetic: the parts' powers are formed once per
# evaluation (square and multiply, the products numba's ``x ** p`` forms for an
# integer ``p``), a missing part or a sign ``+1`` is not multiplied in (both are
# exact), ``px(z)`` is evaluated only when a term uses it, and the special
# factors get their own instantiation of the step loop. Every value is
# therefore bitwise the one of a straightforward term-by-term evaluation; this
# matters because some presets are chaotic (paper-experimental: a change in the
# last bit of one force evaluation grows to O(1) differences within seconds).
#
# A new kind of term needs: a field in :func:`encode_model`'s arrays, its
# decoding in :func:`_plan`, and its factor in :func:`_term` (or, for factors
# that need a library call such as ``exp``, in :func:`_restoring_special`).


@numba.njit(cache=True)
def _plan(parts, special):
    """Per-term evaluation plan from :func:`encode_model`'s arrays.

    Returns
    -------
    plan : int64 array (p, 5)
        ``(pz, pv, ppx, signs, n_special)`` of each term: the powers of its z, v
        and px parts, a bit mask of the sign factors it carries (1: z, 2: v,
        4: px) and its number of special factors.
    top : int64 array (3,)
        Largest power of z, v and px any term uses (-1: no term has a part in
        that variable; px(z) is then not evaluated).
    """
    n = parts.shape[0]
    plan = np.zeros((n, 5), np.int64)
    top = np.full(3, -1, np.int64)
    for i in range(n):
        mask = 0
        for var in range(3):
            p = parts[i, 2 * var]
            s = parts[i, 2 * var + 1]
            plan[i, var] = p
            if s == 1:
                mask |= 1 << var
            if p > 0 or s > 0:
                top[var] = max(top[var], p)
        plan[i, 3] = mask
        k = 0
        for j in range(special.shape[1]):
            if special[i, j, 0] == 0.0:
                break
            k += 1
        plan[i, 4] = k
    return plan, top


@numba.njit(cache=True, inline="always")
def _sign(x):
    """``sign(x)`` (0 at 0 and for NaN)."""
    return 1.0 if x > 0 else (-1.0 if x < 0 else 0.0)


@numba.njit(cache=True, inline="always")
def _abs_power(ax, x2, x3, x4, p):
    """``|x|^p`` for ``p >= 1`` from the precomputed ``|x|^2..|x|^4``.

    Higher powers by square and multiply with the low bits first: the same
    products (hence the same rounding) as numba's ``x ** p`` for an integer
    ``p``, which is also how ``x2 = ax ax``, ``x3 = ax x2`` and ``x4 = x2 x2``
    are formed.
    """
    if p == 1:
        return ax
    if p == 2:
        return x2
    if p == 3:
        return x3
    if p == 4:
        return x4
    r = 1.0
    a = ax
    while p != 0:
        if p & 1:
            r *= a
        p >>= 1
        if p != 0:
            a *= a
    return r


@numba.njit(cache=True, inline="always")
def _term(i, theta, plan, az, z2, z3, z4, av, v2, v3, v4, apx, p2, p3, p4, sz, sv, spx):
    """``theta_i * zpart * vpart * pxpart`` of term ``i`` (without special factors)."""
    g = theta[i]
    p = plan[i, 0]
    if p != 0:
        g *= _abs_power(az, z2, z3, z4, p)
    p = plan[i, 1]
    if p != 0:
        g *= _abs_power(av, v2, v3, v4, p)
    p = plan[i, 2]
    if p != 0:
        g *= _abs_power(apx, p2, p3, p4, p)
    mask = plan[i, 3]
    if mask != 0:  # sign factors are +-1 or 0: exact wherever they are multiplied in
        if mask & 1:
            g *= sz
        if mask & 2:
            g *= sv
        if mask & 4:
            g *= spx
    return g


@numba.njit(cache=True, inline="always")
def _powers(z, v, pxc, has_px):
    """The powers and signs every term is built from: ``|z|^1..4``, ``|v|^1..4``, ``|px(z)|^1..4``, signs."""
    az = abs(z)
    av = abs(v)
    sz = _sign(z)
    sv = _sign(v)
    apx = 0.0
    spx = 0.0
    if has_px:
        px = ((pxc[0] * z + pxc[1]) * z + pxc[2]) * z + pxc[3]
        apx = abs(px)
        spx = _sign(px)
    z2 = az * az
    v2 = av * av
    p2 = apx * apx
    z3, z4 = az * z2, z2 * z2
    v3, v4 = av * v2, v2 * v2
    p3, p4 = apx * p2, p2 * p2
    return az, z2, z3, z4, av, v2, v3, v4, apx, p2, p3, p4, sz, sv, spx


@numba.njit(cache=True, inline="always")
def _special_factors(g, i, z, v, special, plan):
    """``g`` times the special factors of term ``i`` (``exp``, ``tanh``, gap, stop) of ``z`` or ``v``."""
    for j in range(plan[i, 4]):
        kind = special[i, j, 0]
        x = z if special[i, j, 1] == 0.0 else v
        scale = special[i, j, 2]
        mult = special[i, j, 3]
        if kind == 1.0:
            g *= np.exp(-abs(x) * mult / scale)
        elif kind == 2.0:
            g *= np.exp(-mult * (x / scale) ** 2)
        elif kind == 4.0:  # gap(x, d) = sign(x) max(|x| - d, 0)
            y = abs(x) - scale
            g *= (_sign(x) * y if y > 0 else 0.0) ** mult
        elif kind == 5.0:  # stop(x, d): max(x - d, 0) for d >= 0, min(x - d, 0) for d < 0
            y = x - scale
            if scale >= 0:
                y = y if y > 0 else 0.0
            else:
                y = y if y < 0 else 0.0
            g *= y**mult
        else:
            g *= np.tanh(x / scale) ** mult
    return g


@numba.njit(cache=True, inline="always")
def _restoring_plain(z, v, theta, special, pxc, plan, top):
    """``R(z, v)`` of a model without special factors."""
    az, z2, z3, z4, av, v2, v3, v4, apx, p2, p3, p4, sz, sv, spx = _powers(z, v, pxc, top[2] >= 0)
    total = 0.0
    for i in range(theta.size):
        total += _term(i, theta, plan, az, z2, z3, z4, av, v2, v3, v4, apx, p2, p3, p4, sz, sv, spx)
    return total


@numba.njit(cache=True, inline="always")
def _restoring_special(z, v, theta, special, pxc, plan, top):
    """``R(z, v)`` of a model with special factors (``exp``, ``tanh``), applied after the parts."""
    az, z2, z3, z4, av, v2, v3, v4, apx, p2, p3, p4, sz, sv, spx = _powers(z, v, pxc, top[2] >= 0)
    total = 0.0
    for i in range(theta.size):
        g = _term(i, theta, plan, az, z2, z3, z4, av, v2, v3, v4, apx, p2, p3, p4, sz, sv, spx)
        total += _special_factors(g, i, z, v, special, plan)
    return total


@numba.njit(cache=True, inline="always")
def _steps(restoring, force, dt, mass, theta, special, pxc, plan, top, z0, v0, out_z, out_v, out_a):
    """Classical RK4 with one step per force sample, the force held over the step.

    Returns the first sample whose state is not finite, or -1.
    """
    z = z0
    v = v0
    inv_m = 1.0 / mass
    h2 = 0.5 * dt
    for k in range(force.size):
        fk = force[k]
        a1 = (fk - restoring(z, v, theta, special, pxc, plan, top)) * inv_m
        out_z[k] = z
        out_v[k] = v
        out_a[k] = a1
        z2 = z + h2 * v
        v2 = v + h2 * a1
        a2 = (fk - restoring(z2, v2, theta, special, pxc, plan, top)) * inv_m
        z3 = z + h2 * v2
        v3 = v + h2 * a2
        a3 = (fk - restoring(z3, v3, theta, special, pxc, plan, top)) * inv_m
        z4 = z + dt * v3
        v4 = v + dt * a3
        a4 = (fk - restoring(z4, v4, theta, special, pxc, plan, top)) * inv_m
        z = z + dt / 6.0 * (v + 2.0 * v2 + 2.0 * v3 + v4)
        v = v + dt / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
        if not (np.isfinite(z) and np.isfinite(v)):
            return k
    return -1


@numba.njit(cache=True, nogil=True)  # releases the GIL: two free runs of a score at once
def _rk4(force, dt, mass, theta, parts, special, pxc, z0, v0, out_z, out_v, out_a):
    """Integrate over the whole record in one compiled loop (see :func:`simulate`).

    The model is decoded once (:func:`_plan`); a model without special factors
    runs a step loop whose force evaluation has no library calls (their
    register spills cost ~15 % even when never taken).
    """
    plan, top = _plan(parts, special)
    if plan[:, 4].max() > 0:
        return _steps(_restoring_special, force, dt, mass, theta, special, pxc, plan, top, z0, v0, out_z, out_v, out_a)
    return _steps(_restoring_plain, force, dt, mass, theta, special, pxc, plan, top, z0, v0, out_z, out_v, out_a)


@numba.njit(cache=True, inline="always")
def _memory_step(memory, w, dz, out):
    """Every memory state after a monotone displacement step ``dz``, exactly (:mod:`nlid.model.terms.memory`).

    The laws are rate-independent, so a state follows the path of ``z``: the
    integrator moves it along each stage's displacement from the step's start
    with the exact solution, which stays stable however stiff the law is
    (a Dahl pre-sliding displacement far below what the motion covers in
    one step).
    """
    for i in range(memory.shape[0]):
        law = memory[i, 0]
        if law == 1.0:
            out[i] = bouc_wen_step(w[i], dz, memory[i, 1], memory[i, 2]) if dz != 0.0 else w[i]
        elif law == 2.0:
            if dz != 0.0:
                s = 1.0 if dz > 0 else -1.0
                out[i] = s + (w[i] - s) * np.exp(-abs(dz) / memory[i, 1])
            else:
                out[i] = w[i]
        else:
            out[i] = 0.0


@numba.njit(cache=True, nogil=True)
def _rk4_memory(force, dt, mass, plain, theta, memory, parts, special, pxc, z0, v0, out_z, out_v, out_a):
    """RK4 of ``(z, v)`` with the memory terms' states moved exactly along each stage's displacement.

    The memory force is ``theta_i w_i``; each stage's states are those after
    the stage's displacement from the step's start (:func:`_memory_step`).
    """
    plan, top = _plan(parts, special)
    n = theta.size
    w = np.zeros(n)
    ws = np.zeros(n)
    z = z0
    v = v0
    inv_m = 1.0 / mass
    h2 = 0.5 * dt
    for k in range(force.size):
        fk = force[k]
        a1 = (fk - _restoring_special(z, v, plain, special, pxc, plan, top) - np.dot(theta, w)) * inv_m
        out_z[k] = z
        out_v[k] = v
        out_a[k] = a1
        z2 = z + h2 * v
        v2 = v + h2 * a1
        _memory_step(memory, w, z2 - z, ws)
        a2 = (fk - _restoring_special(z2, v2, plain, special, pxc, plan, top) - np.dot(theta, ws)) * inv_m
        z3 = z + h2 * v2
        v3 = v + h2 * a2
        _memory_step(memory, w, z3 - z, ws)
        a3 = (fk - _restoring_special(z3, v3, plain, special, pxc, plan, top) - np.dot(theta, ws)) * inv_m
        z4 = z + dt * v3
        v4 = v + dt * a3
        _memory_step(memory, w, z4 - z, ws)
        a4 = (fk - _restoring_special(z4, v4, plain, special, pxc, plan, top) - np.dot(theta, ws)) * inv_m
        z_new = z + dt / 6.0 * (v + 2.0 * v2 + 2.0 * v3 + v4)
        v = v + dt / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
        _memory_step(memory, w, z_new - z, ws)
        for i in range(n):
            w[i] = ws[i]
        z = z_new
        if not (np.isfinite(z) and np.isfinite(v)):
            return k
    return -1


def _sub_steps(force_hold: str, oversample: int) -> int:
    """The RK4 sub-steps per sample of a free run, ``oversample``, checked with its ``force_hold``."""
    q = int(oversample)
    if q < 1:
        raise InputError(f"oversample must be a positive integer, got {oversample}")
    if force_hold not in ("sampled", "zoh"):
        raise InputError(f"force_hold must be 'sampled' or 'zoh', got {force_hold!r}")
    return q


def simulate(
    model: Model,
    coefficients: dict[str, float] | np.ndarray,
    mass: float,
    force: np.ndarray,
    fs: float,
    x0: Sequence[float] = (0.0, 0.0),
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Integrate ``m z'' + R(z, z') = f`` with the force held over each sample.

    Parameters
    ----------
    model
        The terms of ``R``.
    coefficients
        Coefficient of each term (by name or as a vector in model order).
    mass
        Mass in kg.
    force
        Force samples in N, shape ``(N,)``.
    fs
        Sampling frequency in Hz (one RK4 step per sample).
    x0
        Initial displacement (m) and velocity (m/s).
    Returns
    -------
    z, v, a : numpy.ndarray
        Displacement, velocity and acceleration at the sample times.

    Raises
    ------
    SimulationError
        If the state becomes non-finite.
    """
    mass = MASS.check(mass, "mass=")
    theta = model.vector(coefficients)
    force = np.ascontiguousarray(force, dtype=float)
    parts, special, pxc = encode_model(model)
    n = force.size
    z, v, a = np.empty(n), np.empty(n), np.empty(n)
    if model.uses_memory:
        memory = encode_memory(model)
        plain = np.where(memory[:, 0] > 0, 0.0, theta)  # memory terms act through their states, not their parts
        bad = _rk4_memory(
            force, 1.0 / fs, float(mass), plain, theta, memory, parts, special, pxc, float(x0[0]), float(x0[1]), z, v, a
        )
    else:
        bad = _rk4(force, 1.0 / fs, float(mass), theta, parts, special, pxc, float(x0[0]), float(x0[1]), z, v, a)
    if bad >= 0:
        raise SimulationError(
            f"simulation diverged at sample {bad} (t = {bad / fs:.4g} s); the model may be unstable "
            "for this force (check the signs of the coefficients: they are coefficients of R = f - m z'')"
        )
    return z, v, a


def free_run(
    model: Model,
    coefficients: dict[str, float] | np.ndarray,
    mass: float,
    force: np.ndarray,
    fs: float,
    *,
    force_hold: str = "sampled",
    x0: Sequence[float] = (0.0, 0.0),
    oversample: int = FREE_RUN_OVERSAMPLE,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Free-run simulation of an identified model driven by a measured force.

    The response to a *measured* force (a sampled continuous signal) needs
    what happens between the samples: :func:`simulate` holds each sample for
    a whole interval, which delays the force by half a sample (at 70 Hz and
    610 Hz sampling that is a phase lag of 0.36 rad). Here each sample
    interval is split into ``oversample`` RK4 sub-steps and the force of each
    sub-step is the force interpolated within its band, its hold compensated
    (:func:`~nlid.simulation.fine_force`), which removes the delay and the
    discretisation error of one step per sample. A force that really was held
    (``force_hold="zoh"``, as in the presets) is held exactly.

    Parameters
    ----------
    model, coefficients, mass
        The identified model of ``R`` and the mass (kg).
    force
        Force samples (N), shape ``(N,)``.
    fs
        Sampling frequency of ``force`` in Hz.
    force_hold
        ``"sampled"`` or ``"zoh"`` (see :attr:`nlid.data.record.Record.force_hold`).
    x0
        Initial displacement and velocity.
    oversample
        Sub-steps per sample (default :data:`FREE_RUN_OVERSAMPLE`).

    Returns
    -------
    z, v, a : numpy.ndarray
        The simulated response at the force's sample times.

    Raises
    ------
    SimulationError
        If the simulated state becomes non-finite.
    """
    q = _sub_steps(force_hold, oversample)
    fine = fine_force(force, force_hold, q)
    z, v, a = simulate(model, coefficients, mass, fine, fs * q, x0)
    return z[::q], v[::q], a[::q]
