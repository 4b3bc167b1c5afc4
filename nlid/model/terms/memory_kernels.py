"""Compiled path integrators of the memory laws (:mod:`nlid.model.terms.memory`), shared with the simulator and
discovery."""

from __future__ import annotations

import math

import numba


@numba.njit(cache=True, inline="always")
def _crossing(w, k, s, remaining):
    """Displacement at which the Bouc-Wen state ``w`` reaches zero within the step (``k`` fixed), else NaN."""
    if abs(k) < 1e-300:
        cross = -w
    else:
        w_inf = 1.0 / k
        ratio = -w_inf / (w - w_inf)
        if not ratio > 0:
            return math.nan
        cross = -math.log(ratio) / k
    if cross * s <= 0 or abs(cross) >= abs(remaining):
        return math.nan
    return cross


@numba.njit(cache=True)
def bouc_wen_step(w, dz, a, b):
    """``w`` after a monotone displacement step ``dz``, exact, split where ``w`` changes sign."""
    remaining = dz
    s = 1.0 if dz > 0 else -1.0
    for _ in range(3):  # at most one sign change of w per monotone step
        if remaining == 0.0:
            break
        sigma = s if w == 0.0 else (1.0 if w > 0 else -1.0)
        k = a * s + b * sigma
        if abs(k * remaining) < 1e-12:
            new = w + remaining * (1.0 - k * w)
        else:
            w_inf = 1.0 / k
            new = w_inf + (w - w_inf) * math.exp(-k * remaining)
        if w != 0.0 and new != 0.0 and (new > 0) != (w > 0):
            # w crosses zero inside the step: go there, then on with the other sign
            cross = _crossing(w, k, s, remaining)
            if math.isnan(cross):
                return new
            remaining -= cross
            w = 0.0
            continue
        return new
    return w


@numba.njit(cache=True)
def bouc_wen_loop(z, a, b, w0, out):
    """Bouc-Wen state along ``z`` into ``out``."""
    w = w0
    out[0] = w
    for k in range(1, z.size):
        dz = z[k] - z[k - 1]
        if dz != 0.0:
            w = bouc_wen_step(w, dz, a, b)
        out[k] = w


@numba.njit(cache=True)
def dahl_loop(z, rho, w0, out):
    """Dahl state along ``z`` into ``out`` (exact per monotone step)."""
    w = w0
    out[0] = w
    for k in range(1, z.size):
        dz = z[k] - z[k - 1]
        if dz != 0.0:
            s = 1.0 if dz > 0 else -1.0
            w = s + (w - s) * math.exp(-abs(dz) / rho)
        out[k] = w


@numba.njit(cache=True)
def play_loop(z, width, out):
    """The play (backlash) operator of ``width`` along ``z``, minus ``z``, into ``out``."""
    p = z[0]
    for k in range(z.size):
        x = z[k]
        if p < x - width:
            p = x - width
        elif p > x + width:
            p = x + width
        out[k] = p - x


# --------------------------------------------------------------------------- derivatives of the exact steps
# Used by the sensitivity simulator (:func:`nlid.simulation.simulate_segments`). Each monotone step solves
# the scalar autonomous ODE dw/dz = g(w) = 1 - k w (Bouc-Wen, k = a s + b sign(w)) exactly. Because g is
# continuous where w changes sign (g(0) = 1 on both sides), moving the split point contributes nothing: the
# derivatives are the chain of each piece's own derivatives, the crossing taken as fixed.


@numba.njit(cache=True)
def _bw_piece(w, r, k):
    """One piece of constant ``k``: ``(new, dnew/dw, dnew/dr, dnew/dk)``."""
    if abs(k * r) < 1e-12:
        return w + r * (1.0 - k * w), 1.0 - k * r, 1.0 - k * w, -r * w
    e = math.exp(-k * r)
    w_inf = 1.0 / k
    new = w_inf + (w - w_inf) * e
    return new, e, (1.0 - k * w) * e, -w_inf * w_inf * (1.0 - e) - (w - w_inf) * r * e


@numba.njit(cache=True)
def bouc_wen_step_d(w, dz, a, b):
    """:func:`bouc_wen_step` and its derivatives: ``(new, d/dw, d/ddz, d/da, d/db)``.

    The same pieces as :func:`bouc_wen_step` (hence the same value); at ``dz = 0`` the derivative with
    respect to ``dz`` is the one-sided rate for a positive step.
    """
    if dz == 0.0:
        k = a + (b if w >= 0 else -b)
        return w, 1.0, 1.0 - k * w, 0.0, 0.0
    remaining = dz
    s = 1.0 if dz > 0 else -1.0
    d_w = 1.0
    d_a = 0.0
    d_b = 0.0
    d_r = 1.0
    for _ in range(3):
        if remaining == 0.0:
            break
        sigma = s if w == 0.0 else (1.0 if w > 0 else -1.0)
        k = a * s + b * sigma
        new, p_w, p_r, p_k = _bw_piece(w, remaining, k)
        if w != 0.0 and new != 0.0 and (new > 0) != (w > 0):
            cross = _crossing(w, k, s, remaining)
            if math.isnan(cross):
                return new, d_w * p_w, p_r, d_a * p_w + p_k * s, d_b * p_w + p_k * sigma
            # derivatives at the crossing (w = 0 there, travel fixed): the chain through the first piece
            _, c_w, _, c_k = _bw_piece(w, cross, k)
            d_w *= c_w
            d_a = d_a * c_w + c_k * s
            d_b = d_b * c_w + c_k * sigma
            remaining -= cross
            w = 0.0
            continue
        return new, d_w * p_w, p_r, d_a * p_w + p_k * s, d_b * p_w + p_k * sigma
    return w, d_w, d_r, d_a, d_b


@numba.njit(cache=True)
def dahl_step_d(w, dz, rho):
    """The exact Dahl step and its derivatives: ``(new, d/dw, d/ddz, d/drho)``."""
    if dz == 0.0:
        return w, 1.0, (1.0 - w) / rho, 0.0
    s = 1.0 if dz > 0 else -1.0
    e = math.exp(-abs(dz) / rho)
    return s + (w - s) * e, e, (1.0 - s * w) * e / rho, (w - s) * e * abs(dz) / (rho * rho)
