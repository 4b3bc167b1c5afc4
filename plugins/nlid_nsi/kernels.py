"""Compiled loops of the NSI plugin (numba), imported on first use.

numba is a dependency of nlid (the simulator), but ``import nlid_nsi`` does not
load it: this module is imported by the functions that need it.
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["allpole", "allpole_lagged"]


@numba.njit(cache=True)
def allpole(x: np.ndarray, den: np.ndarray, ext: np.ndarray) -> None:  # pragma: no cover - compiled
    """All-pole filter ``1 / den`` of every column of ``x``, continuing from a history.

    ``ext`` has ``n = len(den) - 1`` more rows than ``x``: on entry its first
    ``n`` rows hold the last ``n`` outputs before ``x`` (the filter state), on
    return ``ext[n + t] = x[t] - sum_{i=1..n} den[i] ext[n + t - i]`` (``den[0] = 1``).
    The columns are independent: the loop runs over them innermost, which
    keeps several recursions in flight at once.
    """
    rows, k = x.shape
    n = den.size - 1
    for t in range(rows):
        for j in range(k):
            acc = x[t, j]
            for i in range(1, n + 1):
                acc -= den[i] * ext[n + t - i, j]
            ext[n + t, j] = acc


@numba.njit(cache=True)
def allpole_lagged(x: np.ndarray, den: np.ndarray, hist: np.ndarray, lagged: np.ndarray) -> None:  # pragma: no cover
    """All-pole filter ``e = x / den`` of every column, written with its lags ``0..n``.

    ``lagged[t, l k + j] = e_j(t - l)`` for ``l = 0..n`` (``k`` columns,
    ``n = len(den) - 1``), ``e_j(t) = x[t, j] - sum_{i=1..n} den[i] e_j(t - i)``;
    ``hist`` holds ``e(-n .. -1)`` on entry (the filter state) and ``e(rows - n
    .. rows - 1)`` on return, so consecutive blocks continue one another.
    """
    rows, k = x.shape
    n = den.size - 1
    head = min(n, rows)
    for t in range(head):  # the first n rows reach into the history
        for j in range(k):
            acc = x[t, j]
            for i in range(1, n + 1):
                acc -= den[i] * (lagged[t - i, j] if t >= i else hist[n + t - i, j])
            lagged[t, j] = acc
            for lag in range(1, n + 1):
                lagged[t, lag * k + j] = lagged[t - lag, j] if t >= lag else hist[n + t - lag, j]
    if n == 2:  # the usual order: straight-line recursions, the columns interleaved
        d1, d2 = den[1], den[2]
        for t in range(head, rows):
            for j in range(k):
                e1 = lagged[t - 1, j]
                e2 = lagged[t - 2, j]
                lagged[t, j] = x[t, j] - d1 * e1 - d2 * e2
                lagged[t, k + j] = e1
                lagged[t, 2 * k + j] = e2
    else:
        for t in range(head, rows):
            for j in range(k):
                acc = x[t, j]
                for i in range(1, n + 1):
                    acc -= den[i] * lagged[t - i, j]
                lagged[t, j] = acc
                for lag in range(1, n + 1):
                    lagged[t, lag * k + j] = lagged[t - lag, j]
    for i in range(n):
        for j in range(k):
            hist[i, j] = lagged[rows - n + i, j] if rows - n + i >= 0 else hist[rows + i, j]
