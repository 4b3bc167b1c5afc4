"""Linear recursive filters without ``scipy.signal``: the arithmetic of ``scipy.signal.lfilter``, compiled.

``scipy.signal.lfilter`` is the only part of ``scipy.signal`` the one-DOF
methods use, and importing ``scipy.signal`` costs ~0.5 s (it imports
``scipy.stats``), which ``nlid identify`` pays on its critical path before the
identification starts. :func:`lfilter` runs the same transposed direct form II
with the same operations in the same order (normalised by ``a[0]``, then per
sample ``y = z_0 + b_0 x``, ``z_i = z_{i+1} + x b_{i+1} - y a_{i+1}``, the last
delay ``x b_K - y a_K``), so it gives the same numbers to the bit
(tests/plugins/test_nsi_iir.py compares them), compiled by numba once per
machine (``cache=True``).
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["lfilter", "lfiltic_output"]


@numba.njit(cache=True)
def _filter_rows(b: np.ndarray, a: np.ndarray, x: np.ndarray, z: np.ndarray, y: np.ndarray) -> None:
    """Filter every row of ``x`` (rows, N) into ``y`` (N, rows); ``z`` (K - 1, rows): the delays, updated in place.

    The rows are independent recursions: the loop over them is innermost, so their steps overlap (and
    vectorise) instead of waiting on one recursion's latency.
    """
    k = b.shape[0]
    rows, n = x.shape
    for t in range(n):
        for r in range(rows):
            xn = x[r, t]
            yn = z[0, r] + b[0] * xn
            for i in range(k - 2):
                z[i, r] = z[i + 1, r] + xn * b[i + 1] - yn * a[i + 1]
            z[k - 2, r] = xn * b[k - 1] - yn * a[k - 1]
            y[t, r] = yn


def lfilter(
    b: np.ndarray, a: np.ndarray, x: np.ndarray, zi: np.ndarray | None = None
) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """``scipy.signal.lfilter(b, a, x, axis=-1, zi=zi)`` for real ``x`` (1-D or 2-D, filtered along the last axis).

    Parameters
    ----------
    b, a
        Numerator and denominator coefficients (``a[0] != 0``; at least two coefficients between them).
    x
        Signal(s), shape ``(N,)`` or ``(rows, N)``.
    zi
        Initial delays, shape ``(K - 1,)`` or ``(rows, K - 1)`` with ``K = max(len(a), len(b))``;
        ``None``: zero.

    Returns
    -------
    y, or (y, zf)
        The filtered signal(s), and the final delays when ``zi`` is given (as scipy returns them).
    """
    b = np.asarray(b, dtype=float)
    a = np.asarray(a, dtype=float)
    k = max(len(a), len(b))
    if k < 2:
        raise ValueError("lfilter needs at least two coefficients in a or b")
    bb = np.zeros(k)
    aa = np.zeros(k)
    bb[: len(b)] = b
    aa[: len(a)] = a
    a0 = aa[0]
    bb /= a0  # as scipy normalises, coefficient by coefficient
    aa /= a0
    x = np.asarray(x, dtype=float)
    rows = np.ascontiguousarray(x.reshape(-1, x.shape[-1]))
    if zi is None:
        state = np.zeros((k - 1, rows.shape[0]))
    else:
        state = np.array(np.asarray(zi, dtype=float).reshape(rows.shape[0], k - 1).T, order="C")
    out = np.empty((rows.shape[1], rows.shape[0]))
    _filter_rows(bb, aa, rows, state, out)
    y = np.ascontiguousarray(out.T).reshape(x.shape)
    if zi is None:
        return y
    return y, np.ascontiguousarray(state.T).reshape(np.shape(zi))


def lfiltic_output(a: np.ndarray, y_last: float = 1.0) -> np.ndarray:
    """``scipy.signal.lfiltic([1.0], a, [y_last])``: the delays of ``1 / a`` after the output ``y_last`` (input zero).

    ``zi[m] = -a[m + 1] y_last`` (``a[0] = 1``), computed as scipy does.
    """
    a = np.asarray(a, dtype=float)
    return 0.0 - a[1:] * float(y_last)
