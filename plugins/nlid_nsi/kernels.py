"""Compiled loops of the NSI plugin (numba), imported on first use.

numba is a dependency of nlid (the simulator), but ``import nlid_nsi`` does not
load it: this module is imported by the functions that need it.
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["allpole"]


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
