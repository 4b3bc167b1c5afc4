"""The Gram matrix of block-Hankel data, built without the Hankel matrix.

Subspace identification works on the block-Hankel matrix of the data
``W = [w(p + t)]`` (``s`` block rows of ``c`` channels, ``J = N - s + 1``
columns). Every quantity PO-MOESP needs is a function of its Gram matrix
``G = W W^T / J`` (the LQ factor of ``W`` is the Cholesky factor of ``G``), so
``W`` (``s c x J``: 2 GB for 10^6 samples) is never formed:

* the first block row ``G[0, q]`` holds cross-correlations of the channels at
  lags ``0..s-1``, computed by FFT (one real FFT per channel, ``c`` inverse
  FFTs of length ``N``);
* the other blocks follow from the Hankel recursion
  ``G[p+1, q+1] = G[p, q] + w(p+J) w(q+J)^T - w(p) w(q)^T``, evaluated as
  cumulative sums along each block diagonal.

Memory is O(N c + (s c)^2), time O(c^2 N log N + s^2 c^2). The result agrees
with the explicit product ``W W^T / J`` to rounding (tests/plugins/nsi).

Changing the channels by a fixed linear map ``w' = T w`` changes the Gram by a
block congruence (:func:`transform_gram`); nsi-ip uses this so that one Gram
serves every trial value of the virtual stiffness k~1 (``fbar = f + k~1 z``,
Eq. 13).
"""

from __future__ import annotations

import numpy as np
from scipy import fft as sp_fft
from scipy import linalg

__all__ = ["block_hankel_gram", "transform_gram", "sub_gram", "clip_indefinite"]


def block_hankel_gram(w: np.ndarray, block_rows: int) -> np.ndarray:
    """Gram matrix of the block-Hankel matrix of ``w``.

    Parameters
    ----------
    w
        Data, shape ``(N, c)`` (one column per channel).
    block_rows
        Number of block rows ``s`` (past plus future horizons).

    Returns
    -------
    numpy.ndarray
        ``G[p, a, q, b] = sum_t w_a(p + t) w_b(q + t) / J``, shape ``(s, c, s, c)``.

    Raises
    ------
    ValueError
        If the record has fewer columns ``J`` than rows ``s c`` (too short).
    """
    w = np.asarray(w, dtype=float)
    n, c = w.shape
    s = int(block_rows)
    j = n - s + 1
    if j < s * c:
        raise ValueError(f"record too short ({n} samples) for {s} block rows of {c} channels")
    nfft = sp_fft.next_fast_len(n, real=True)  # t + d <= n - 1: no wrap-around
    spec = sp_fft.rfft(w, nfft, axis=0)
    first = np.empty((s, c, c))  # first[d, a, b] = sum_{t<J} w_a(t) w_b(t + d)
    for a in range(c):
        head = sp_fft.rfft(w[:j, a], nfft)
        first[:, a, :] = sp_fft.irfft(np.conj(head)[:, None] * spec, nfft, axis=0)[:s]
    del spec
    hd, tl = w[:s], w[j : j + s]
    out = np.empty((s, c, s, c))
    for d in range(s):
        length = s - d
        blocks = np.empty((length, c, c))
        blocks[0] = first[d]
        if length > 1:
            step = np.einsum("ka,kb->kab", tl[: length - 1], tl[d : d + length - 1])
            step -= np.einsum("ka,kb->kab", hd[: length - 1], hd[d : d + length - 1])
            np.cumsum(step, axis=0, out=blocks[1:])
            blocks[1:] += first[d]
        p = np.arange(length)
        out[p, :, p + d, :] = blocks
        if d:
            out[p + d, :, p, :] = blocks.transpose(0, 2, 1)
    out /= j
    return out


def transform_gram(gram: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Gram of the channels ``T w`` from the Gram of ``w`` (block congruence).

    Parameters
    ----------
    gram
        Shape ``(s, c, s, c)``.
    t
        Channel map, shape ``(c', c)``.
    """
    return np.einsum("ia,paqb,jb->piqj", t, gram, t, optimize=True)


def sub_gram(gram: np.ndarray, block_rows: int) -> np.ndarray:
    """The Gram of the ``2 * block_rows`` block rows centred on the past/future boundary."""
    half = gram.shape[0] // 2
    sl = slice(half - block_rows, half + block_rows)
    return gram[sl, :, sl, :]


def clip_indefinite(gram: np.ndarray, floor: float = 1e-8) -> tuple[np.ndarray, bool]:
    """The Gram projected onto the positive semi-definite matrices when it is indefinite.

    A noise-corrected Gram (:func:`nlid_nsi.noise.subtract_noise`) estimates
    the Gram of the noise-free data, which is positive semi-definite, but the
    subtraction can leave small negative eigenvalues. They are raised to
    ``floor`` times the mean diagonal (eigenvalue clipping: the nearest
    positive semi-definite matrix in the Frobenius norm, the other directions
    untouched). Without this, PO-MOESP's Cholesky loads the whole diagonal by
    up to ``1e-4`` of its mean, or clips at that level, for every fit
    (:func:`nlid_nsi.subspace.po_moesp`); on paper-experimental with the z/a
    fusion that load biased the viscous coefficient by about +5 %
    (docs/nsi.md). Clipping the base Gram once also makes every congruence
    ``T G T^T`` (:func:`transform_gram`, one per k~1) positive semi-definite,
    so the k~1 ensemble costs one eigendecomposition, not one per value.

    Parameters
    ----------
    gram
        Gram of shape ``(s, c, s, c)``.
    floor
        Eigenvalue floor relative to the mean diagonal.

    Returns
    -------
    gram, clipped
        The Gram (the same array when its Cholesky factor exists) and whether
        it was clipped.
    """
    shape = gram.shape
    gg = gram.reshape(shape[0] * shape[1], -1)
    gg = 0.5 * (gg + gg.T)
    try:
        linalg.cholesky(gg, lower=True, check_finite=False)
        return gram, False
    except linalg.LinAlgError:
        pass
    low = floor * float(np.trace(gg)) / len(gg)
    # only the eigenpairs below the floor (half the cost of the full decomposition)
    ev, vec = linalg.eigh(gg, subset_by_value=(-np.inf, low), driver="evr", check_finite=False)
    return (gg + (vec * (low - ev)) @ vec.T).reshape(shape), True
