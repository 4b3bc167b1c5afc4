"""Zero references of nsi-shift: the modes of a displacement histogram and the Taylor shift of a polynomial."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["histogram_modes", "taylor_shift"]


def histogram_modes(z: np.ndarray, degree: int = 4, bins: int = 100, min_count: int = 5) -> np.ndarray:
    """Modes of the displacement histogram: maxima of a polynomial fit to its logarithm.

    Parameters
    ----------
    z
        Displacement samples.
    degree
        Degree of the polynomial fitted to ``log(counts)`` (weights ``sqrt(counts)``).
    bins
        Histogram bins.
    min_count
        Bins with fewer samples are left out of the fit.
    """
    h, e = np.histogram(z, bins)
    c = 0.5 * (e[1:] + e[:-1])
    ok = h > min_count
    if ok.sum() <= degree:  # too few populated bins to fit (a very short record): no mode found
        return np.zeros(0)
    sc = float(np.std(z))
    p = np.polyfit(c[ok] / sc, np.log(h[ok]), degree, w=np.sqrt(h[ok]))
    d = np.polyder(p)
    r = np.roots(d)
    r = np.sort(r[np.abs(r.imag) < 1e-9].real)
    return np.array([x * sc for x in r if np.polyval(np.polyder(d), x) < 0 and e[0] < x * sc < e[-1]])


def taylor_shift(c_asc: np.ndarray, shift: float) -> np.ndarray:
    """Ascending coefficients of ``P(x + shift)`` from the ascending coefficients of ``P``."""
    out = np.zeros(len(c_asc))
    for k, ck in enumerate(c_asc):
        for j in range(k + 1):
            out[j] += ck * math.comb(k, j) * shift ** (k - j)
    return out
