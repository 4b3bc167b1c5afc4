"""The force of one RK4 stage with its derivatives, and the value-only run of a segment.

The pieces :mod:`nlid.simulation.sensitivity` (one DOF) and :mod:`nlid.simulation.structure_sensitivity`
(several DOFs) evaluate every term with: each term's value and its derivatives in ``z``, ``v`` and the
scales of its special factors from its normal form (a product of signed powers and special factors,
:mod:`nlid.model.terms.term`), the memory states' exact steps with their derivatives
(:func:`nlid.model.terms.memory_kernels.bouc_wen_step_d`, ``dahl_step_d``), and :func:`_segment_v`, the run
of a segment when no sensitivity is asked for: every product and sum is the one the run with
sensitivities forms for the values, in the same order, so both give the same states to the bit.
"""

from __future__ import annotations

import numba
import numpy as np

from ..model.terms.memory_kernels import bouc_wen_step_d, dahl_step_d
from .kernels import _plan, _sign

# numba's on-disk cache of a kernel is invalidated by changes of its own file only: after editing _plan or
# _sign in kernels.py (or the memory steps of nlid.model.terms), delete
# nlid/simulation/__pycache__/stage_terms.*.nb[ci] and sensitivity.*.nb[ci].


@numba.njit(cache=True, inline="always")
def _pow_d(x, p, s):
    """``|x|^p sign(x)^s`` and its derivative (a.e.)."""
    if p == 0:
        if s == 0:
            return 1.0, 0.0
        return _sign(x), 0.0
    ax = abs(x)
    if p == 1:
        pm = 1.0
    elif p == 2:
        pm = ax
    elif p == 3:
        pm = ax * ax
    else:
        pm = ax ** (p - 1)
    if s == 1:
        return pm * ax * _sign(x), p * pm
    return pm * ax, p * pm * _sign(x)


@numba.njit(cache=True, inline="always")
def _special_d(kind, x, c, mult):
    """A special factor, its derivative in its variable and in its scale: ``(f, df/dx, df/dc)``."""
    m = int(mult)
    if kind == 1.0:  # exp(-|x| m / c)
        e = np.exp(-abs(x) * mult / c)
        return e, -(mult / c) * _sign(x) * e, e * abs(x) * mult / (c * c)
    if kind == 2.0:  # exp(-m (x / c)^2)
        e = np.exp(-mult * (x / c) ** 2)
        return e, -2.0 * mult * x / (c * c) * e, 2.0 * mult * x * x / (c * c * c) * e
    if kind == 4.0:  # gap(x, c)^m
        y = abs(x) - c
        if y > 0:
            u = _sign(x) * y
            du = m * u ** (m - 1)
            return u**m, du, -du * _sign(x)
        return 0.0, 0.0, 0.0
    if kind == 5.0:  # stop(x, c)^m
        y = x - c
        if (c >= 0 and y > 0) or (c < 0 and y < 0):
            d = m * y ** (m - 1)
            return y**m, d, -d
        return 0.0, 0.0, 0.0
    t = np.tanh(x / c)  # tanh(x / c)^m
    base = t ** (m - 1)
    d = m * base * (1.0 - t * t)
    return base * t, d / c, -d * x / (c * c)


@numba.njit(cache=True, inline="always")
def _powers(x, top, out):
    """``|x|^k`` for ``k = 0..top`` into ``out`` (products in increasing order)."""
    ax = abs(x)
    out[0] = 1.0
    for k in range(1, top + 1):
        out[k] = out[k - 1] * ax


@numba.njit(cache=True, inline="always")
def _part_d(pw, p, s, sx):
    """``|x|^p sign(x)^s`` and its derivative (a.e.) from the powers ``pw`` of ``|x|``."""
    if p == 0:
        return (sx if s == 1 else 1.0), 0.0
    if s == 1:
        return pw[p] * sx, p * pw[p - 1]
    return pw[p], p * pw[p - 1] * sx


@numba.njit(cache=True, inline="always")
def _terms_d(z, v, parts, special, pxc, memory, top, g, gz, gv, gs, fac, dfac, pz, pv, pp):
    """Every non-memory term's value and derivatives at ``(z, v)``.

    Fills ``g[i]``, ``gz[i] = dg_i/dz``, ``gv[i] = dg_i/dv`` and ``gs[i, j]`` (derivative with respect to
    the scale of special factor ``j``, for the factors the term has); memory terms get zeros (they act
    through their states). ``top`` holds the largest power of z, v and px(z) any term uses (-1: none).
    """
    sz = _sign(z)
    sv = _sign(v)
    _powers(z, top[0], pz)
    _powers(v, top[1], pv)
    px = 0.0
    dpx = 0.0
    spx = 0.0
    if top[2] >= 0:
        px = ((pxc[0] * z + pxc[1]) * z + pxc[2]) * z + pxc[3]
        dpx = (3.0 * pxc[0] * z + 2.0 * pxc[1]) * z + pxc[2]
        spx = _sign(px)
        _powers(px, top[2], pp)
    for i in range(parts.shape[0]):
        if memory[i, 0] != 0.0:
            g[i] = 0.0
            gz[i] = 0.0
            gv[i] = 0.0
            continue
        val, dz_ = _part_d(pz, parts[i, 0], parts[i, 1], sz)
        f, fv = _part_d(pv, parts[i, 2], parts[i, 3], sv)
        dz_ *= f
        dv_ = val * fv
        val *= f
        if parts[i, 4] != 0 or parts[i, 5] != 0:
            f, fp = _part_d(pp, parts[i, 4], parts[i, 5], spx)
            dz_ = dz_ * f + val * fp * dpx
            dv_ *= f
            val *= f
        if special[i, 0, 0] != 0.0:
            base = val
            k = 0
            for j in range(special.shape[1]):
                kind = special[i, j, 0]
                if kind == 0.0:
                    break
                x = z if special[i, j, 1] == 0.0 else v
                f, fx, fc = _special_d(kind, x, special[i, j, 2], special[i, j, 3])
                fac[j] = f
                dfac[j] = fc
                if special[i, j, 1] == 0.0:
                    dz_ = dz_ * f + val * fx
                    dv_ *= f
                else:
                    dv_ = dv_ * f + val * fx
                    dz_ *= f
                val *= f
                k += 1
            for j in range(k):
                other = base
                for jj in range(k):
                    if jj != j:
                        other *= fac[jj]
                gs[i, j] = other * dfac[j]
        g[i] = val
        gz[i] = dz_
        gv[i] = dv_


@numba.njit(cache=True)
def _memory_d(memory, mem_terms, w, dz, ws, mw, mdz, ma, mb):
    """Every memory state after the displacement ``dz`` from ``w`` with the step's derivatives."""
    for r in range(mem_terms.size):
        i = mem_terms[r]
        if memory[i, 0] == 1.0:
            ws[r], mw[r], mdz[r], ma[r], mb[r] = bouc_wen_step_d(w[r], dz, memory[i, 1], memory[i, 2])
        else:
            ws[r], mw[r], mdz[r], ma[r] = dahl_step_d(w[r], dz, memory[i, 1])
            mb[r] = 0.0


# fmt: off
@numba.njit(cache=True, inline="always")
def _accel_v(fk, z, v, ws, inv_m, theta, parts, special, pxc, memory, mem_terms, top, pz, pv, pp):
    """Acceleration ``(f - R) / m`` at a stage without derivatives: the values of :func:`_accel_d` to the bit.

    Every product and sum is the one :func:`_terms_d` and :func:`_accel_d` form for the value (the same
    order), so a run without sensitivities is the run with them, minus the derivatives' work.
    """
    sz = _sign(z)
    sv = _sign(v)
    _powers(z, top[0], pz)
    _powers(v, top[1], pv)
    spx = 0.0
    if top[2] >= 0:
        px = ((pxc[0] * z + pxc[1]) * z + pxc[2]) * z + pxc[3]
        spx = _sign(px)
        _powers(px, top[2], pp)
    R = 0.0
    for i in range(theta.size):
        if memory[i, 0] != 0.0:
            R += theta[i] * 0.0
            continue
        val, _ = _part_d(pz, parts[i, 0], parts[i, 1], sz)
        f, _ = _part_d(pv, parts[i, 2], parts[i, 3], sv)
        val *= f
        if parts[i, 4] != 0 or parts[i, 5] != 0:
            f, _ = _part_d(pp, parts[i, 4], parts[i, 5], spx)
            val *= f
        if special[i, 0, 0] != 0.0:
            for j in range(special.shape[1]):
                kind = special[i, j, 0]
                if kind == 0.0:
                    break
                x = z if special[i, j, 1] == 0.0 else v
                f, _, _ = _special_d(kind, x, special[i, j, 2], special[i, j, 3])
                val *= f
        R += theta[i] * val
    for r in range(mem_terms.size):
        R += theta[mem_terms[r]] * ws[r]
    return (fk - R) * inv_m


@numba.njit(cache=True)
def _segment_v(fine, q, dt, mass, theta, parts, special, pxc, memory, mem_terms, x0, start, n, out_z, out_v, out_a,
               end_x):
    """:func:`_segment_d` without sensitivities (the same states to the bit, a quarter of the work)."""
    M = mem_terms.size
    _, top = _plan(parts, special)
    pz = np.zeros(max(top[0], 0) + 1)
    pv = np.zeros(max(top[1], 0) + 1)
    pp = np.zeros(max(top[2], 0) + 1)
    w = np.zeros(M)
    ws = np.zeros(M)
    mw = np.zeros(M)
    mdz = np.zeros(M)
    ma = np.zeros(M)
    mb = np.zeros(M)
    A = np.zeros(4)
    V = np.zeros(4)
    z = x0[0]
    v = x0[1]
    for r in range(M):
        w[r] = x0[2 + r]
    inv_m = 1.0 / mass
    h2 = 0.5 * dt
    h6 = dt / 6.0
    for k in range(n):
        out_z[start + k] = z
        out_v[start + k] = v
        for sub in range(q):
            fk = fine[(start + k) * q + sub]
            for st in range(4):  # the four stages through one call site (one inlined copy: compile time)
                if st == 0:
                    zs = z
                    vs = v
                    for r in range(M):
                        ws[r] = w[r]
                else:
                    h = dt if st == 3 else h2
                    zs = z + h * V[st - 1]
                    vs = v + h * A[st - 1]
                    if M > 0:
                        _memory_d(memory, mem_terms, w, zs - z, ws, mw, mdz, ma, mb)
                V[st] = vs
                A[st] = _accel_v(fk, zs, vs, ws, inv_m, theta, parts, special, pxc, memory, mem_terms, top, pz, pv,
                                 pp)
            if sub == 0:
                out_a[start + k] = A[0]
            z_new = z + h6 * (v + 2.0 * V[1] + 2.0 * V[2] + V[3])
            v_new = v + h6 * (A[0] + 2.0 * A[1] + 2.0 * A[2] + A[3])
            if M > 0:
                _memory_d(memory, mem_terms, w, z_new - z, ws, mw, mdz, ma, mb)
            for r in range(M):
                w[r] = ws[r]
            z = z_new
            v = v_new
        if not (np.isfinite(z) and np.isfinite(v)):
            return k
    end_x[0] = z
    end_x[1] = v
    for r in range(M):
        end_x[2 + r] = w[r]
    return -1
# fmt: on
