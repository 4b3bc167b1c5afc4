"""Compiled path integrators of the memory laws (:mod:`nlid.terms.memory`); imported on first use."""

from __future__ import annotations

import math

import numba


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
            if abs(k) < 1e-300:
                cross = -w
            else:
                w_inf = 1.0 / k
                ratio = -w_inf / (w - w_inf)
                if not ratio > 0:
                    return new
                cross = -math.log(ratio) / k
            if cross * s <= 0 or abs(cross) >= abs(remaining):
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
