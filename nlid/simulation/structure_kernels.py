"""The compiled integrator of a structure: RK4 of ``M z'' + C z' + K z + s + sum_e b_e theta_e g_e = f``.

The elements reach the kernel as the arrays of the one-DOF simulator
(:func:`nlid.simulation.encode_model`'s ``parts``, ``special`` and the ``px``
coefficients, one row per element) and each element's force is evaluated on
its relative coordinate ``x = z_i - z_j``, ``x' = v_i - v_j`` with the
one-DOF kernel's own plan and term function (:mod:`nlid.simulation.kernels`);
:func:`_element` applies the special factors as ``_restoring_special`` does,
operation for operation: the same arithmetic, term by term. (Calling the
one-DOF ``_restoring_*`` functions on one-row slices would do the same five
times slower: numba builds a view per slice.) A memory element's state moves exactly along each
stage's relative displacement from the step's start, as for one DOF.

The restoring force of a DOF is accumulated in a fixed order: the static
force, then ``K z``, the elements and ``C z'`` at the places the one-DOF
simulator puts the terms ``z`` and ``v`` among the others (``slots``). With
one DOF and a diagonal mass this is the one-DOF kernel's order, so a
one-DOF structure without memory elements integrates bitwise like
:func:`nlid.simulation.free_run`.
"""

from __future__ import annotations

import numba
import numpy as np

from .kernels import _memory_step, _plan, _powers, _special_factors, _term

__all__ = ["integrate", "element_plans"]


@numba.njit(cache=True)
def element_plans(parts, special):
    """The one-DOF evaluation plan of each element on its own (:func:`nlid.simulation.kernels._plan`)."""
    count = parts.shape[0]
    plan = np.zeros((count, 5), np.int64)
    tops = np.full((count, 3), -1, np.int64)
    for e in range(count):
        p, t = _plan(parts[e : e + 1], special[e : e + 1])
        plan[e] = p[0]
        tops[e] = t
    return plan, tops


@numba.njit(cache=True, inline="always")
def _element_plain(e, x, xd, theta, special, pxc, plan, tops):
    """``theta_e g_e(x, x')`` of element ``e`` without special factors (as ``_restoring_plain`` for one term)."""
    az, z2, z3, z4, av, v2, v3, v4, apx, p2, p3, p4, sz, sv, spx = _powers(x, xd, pxc[e], tops[e, 2] >= 0)
    return _term(e, theta, plan, az, z2, z3, z4, av, v2, v3, v4, apx, p2, p3, p4, sz, sv, spx)


@numba.njit(cache=True, inline="always")
def _element_special(e, x, xd, theta, special, pxc, plan, tops):
    """``theta_e g_e(x, x')`` of element ``e`` with its special factors (as ``_restoring_special`` for one term)."""
    az, z2, z3, z4, av, v2, v3, v4, apx, p2, p3, p4, sz, sv, spx = _powers(x, xd, pxc[e], tops[e, 2] >= 0)
    g = _term(e, theta, plan, az, z2, z3, z4, av, v2, v3, v4, apx, p2, p3, p4, sz, sv, spx)
    return _special_factors(g, e, x, xd, special, plan)


@numba.njit(cache=True, inline="always")
def _accel(
    element, z, v, w, fk, Minv, K, C, static, theta, plain, memory, special, pxc, plan, tops, ci, cj, kpos, cpos, R, out
):
    """``out = M^-1 (f - R(z, v, w))``; ``R`` is scratch."""
    n = z.size
    for i in range(n):
        R[i] = static[i]
    count = theta.size
    for e in range(count + 1):
        if e == kpos:
            for i in range(n):
                s = 0.0
                for j in range(n):
                    s += K[i, j] * z[j]
                R[i] += s
        if e == cpos:
            for i in range(n):
                s = 0.0
                for j in range(n):
                    s += C[i, j] * v[j]
                R[i] += s
        if e == count:
            break
        i = ci[e]
        j = cj[e]
        if memory[e, 0] > 0.0:
            g = theta[e] * w[e]
        else:
            x = z[i] - z[j] if j >= 0 else z[i]
            xd = v[i] - v[j] if j >= 0 else v[i]
            g = element(e, x, xd, plain, special, pxc, plan, tops)
        R[i] += g
        if j >= 0:
            R[j] -= g
    for i in range(n):
        s = 0.0
        for j in range(n):
            s += Minv[i, j] * (fk[j] - R[j])
        out[i] = s


@numba.njit(cache=True, inline="always")
def _move_none(memory, w, ws, zs, z, ci, cj):
    """No memory element: nothing moves."""
    return


@numba.njit(cache=True, inline="always")
def _move(memory, w, ws, zs, z, ci, cj):
    """Every memory state after the stage's relative displacement from the step's start."""
    for e in range(w.size):
        if memory[e, 0] > 0.0:
            i = ci[e]
            j = cj[e]
            dx = (zs[i] - zs[j]) - (z[i] - z[j]) if j >= 0 else zs[i] - z[i]
            _memory_step(memory[e : e + 1], w[e : e + 1], dx, ws[e : e + 1])


@numba.njit(cache=True, inline="always")
def _steps(
    element, move, force, dt, stride, Minv, K, C, static, theta, plain, memory, special, pxc, plan, tops,
    ci, cj, kpos, cpos, z0, v0, out_z, out_v, out_a,
):  # fmt: skip
    """Classical RK4 with the force of each step held; states kept every ``stride`` steps.

    ``element`` evaluates one element, ``move`` moves the memory states: each
    combination is its own instantiation, so a structure without special
    factors or memory runs a loop without their library calls (compiled in,
    never taken, they cost a factor of 3 to 5 here).

    Returns the first step whose state is not finite, or -1.
    """
    n = z0.size
    count = theta.size
    z = z0.copy()
    v = v0.copy()
    w = np.zeros(count)
    ws = np.zeros(count)
    R = np.zeros(n)
    zs = np.zeros(n)
    vel = np.zeros((4, n))  # the velocity and acceleration of each stage
    acc = np.zeros((4, n))
    zn = np.zeros(n)
    h2 = 0.5 * dt
    for k in range(force.shape[0]):
        fk = force[k]
        for stage in range(4):
            if stage == 0:
                for i in range(n):
                    zs[i] = z[i]
                    vel[0, i] = v[i]
            else:
                h = dt if stage == 3 else h2
                for i in range(n):
                    zs[i] = z[i] + h * vel[stage - 1, i]
                    vel[stage, i] = v[i] + h * acc[stage - 1, i]
                move(memory, w, ws, zs, z, ci, cj)
            _accel(
                element, zs, vel[stage], w if stage == 0 else ws, fk, Minv, K, C, static, theta, plain, memory,
                special, pxc, plan, tops, ci, cj, kpos, cpos, R, acc[stage],
            )  # fmt: skip
        if k % stride == 0:
            row = k // stride
            for i in range(n):
                out_z[row, i] = z[i]
                out_v[row, i] = v[i]
                out_a[row, i] = acc[0, i]
        finite = True
        for i in range(n):
            zn[i] = z[i] + dt / 6.0 * (vel[0, i] + 2.0 * vel[1, i] + 2.0 * vel[2, i] + vel[3, i])
            v[i] = v[i] + dt / 6.0 * (acc[0, i] + 2.0 * acc[1, i] + 2.0 * acc[2, i] + acc[3, i])
            finite = finite and np.isfinite(zn[i]) and np.isfinite(v[i])
        move(memory, w, ws, zn, z, ci, cj)
        for e in range(count):
            w[e] = ws[e]
        for i in range(n):
            z[i] = zn[i]
        if not finite:
            return k
    return -1


@numba.njit(cache=True, nogil=True)  # nogil: oe's finite differences run free runs on threads
def integrate(
    force, dt, stride, Minv, K, C, static, theta, plain, memory, parts, special, pxc, ci, cj, kpos, cpos,
    z0, v0, out_z, out_v, out_a,
):  # fmt: skip
    """RK4 of a structure over the whole force (see :func:`_steps`); the first non-finite step, or -1."""
    plan, tops = element_plans(parts, special)
    general = False
    for e in range(theta.size):
        if plan[e, 4] > 0 or memory[e, 0] > 0.0:
            general = True
    if general:
        return _steps(
            _element_special, _move, force, dt, stride, Minv, K, C, static, theta, plain, memory, special, pxc,
            plan, tops, ci, cj, kpos, cpos, z0, v0, out_z, out_v, out_a,
        )  # fmt: skip
    return _steps(
        _element_plain, _move_none, force, dt, stride, Minv, K, C, static, theta, plain, memory, special, pxc,
        plan, tops, ci, cj, kpos, cpos, z0, v0, out_z, out_v, out_a,
    )  # fmt: skip
