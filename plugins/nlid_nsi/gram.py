"""The Gram matrix of block-Hankel data, built without the Hankel matrix.

Subspace identification works on the block-Hankel matrix of the data
``W = [w(p + t)]`` (``s`` block rows of ``c`` channels, ``J = N - s + 1``
columns). Every quantity PO-MOESP needs is a function of its Gram matrix
``G = W W^T / J`` (the LQ factor of ``W`` is the Cholesky factor of ``G``), so
``W`` (``s c x J``: 2 GB for 10^6 samples) is never formed:

* the first block row ``G[0, q]`` holds cross-correlations of the channels at
  lags ``0..s-1``, accumulated by FFT over blocks of the record
  (:func:`lag_products`: one pass over the data, no array of the record's
  length);
* the other blocks follow from the Hankel recursion
  ``G[p+1, q+1] = G[p, q] + w(p+J) w(q+J)^T - w(p) w(q)^T``, one block row
  at a time; the lower half mirrors the upper.

Memory is O((s c)^2) besides the data, time O(c^2 N log s + s^2 c^2). The
result agrees with the explicit product ``W W^T / J`` to rounding
(tests/plugins/test_nsi_parts.py).

Changing the channels by a fixed linear map ``w' = T w`` changes the Gram by a
block congruence (:func:`transform_gram`); nsi-ip uses this so that one Gram
serves every trial value of the virtual stiffness k~1 (``fbar = f + k~1 z``,
Eq. 13).
"""

from __future__ import annotations

import numpy as np
from scipy import fft as sp_fft
from scipy import linalg

__all__ = ["block_hankel_gram", "lag_products", "transform_gram", "sub_gram", "clip_indefinite"]


#: FFT length of the blocks over which the lag products are accumulated.
LAG_FFT = 2048
#: Number of blocks transformed together (bounds the temporary memory to
#: about ``2 * LAG_CHUNK * LAG_FFT * c`` doubles, 1.6 MB for six channels).
LAG_CHUNK = 8


def lag_products(w: np.ndarray, lags: int, length: int) -> np.ndarray:
    """``P[d, a, b] = sum_{t < length} w_a(t) w_b(t + d)`` for ``d = 0..lags-1``.

    The sum is accumulated over blocks of ``L = LAG_FFT - lags + 1`` values of
    ``t`` in the frequency domain: for a block starting at ``t0``,
    ``conj(FFT(w[t0 : t0 + L], zero-padded)) * FFT(w[t0 : t0 + LAG_FFT])`` is the
    circular cross-correlation of the two windows, which equals the linear one
    for every lag below ``lags`` (``t + d < LAG_FFT``). The products of all
    blocks are summed per frequency and transformed back once. One pass over
    the data; memory O(LAG_FFT c^2), not O(N c).

    Parameters
    ----------
    w
        Data, shape ``(N, c)``.
    lags
        Number of lags.
    length
        Number of terms ``t`` (``length + lags - 1 <= N``).
    """
    n, c = w.shape
    size = max(LAG_FFT, sp_fft.next_fast_len(4 * lags, real=True))
    step = size - lags + 1
    acc = np.zeros((size // 2 + 1, c, c), dtype=complex)
    starts = np.arange(0, length, step)
    for first in range(0, len(starts), LAG_CHUNK):
        chunk = starts[first : first + LAG_CHUNK]
        head = np.zeros((len(chunk), size, c))
        tail = np.zeros((len(chunk), size, c))
        for k, t0 in enumerate(chunk):
            la = min(step, length - t0)
            lb = min(size, n - t0)
            head[k, :la] = w[t0 : t0 + la]
            tail[k, :lb] = w[t0 : t0 + lb]
        fh = sp_fft.rfft(head, axis=1)
        ft = sp_fft.rfft(tail, axis=1)
        del head, tail
        # sum over the blocks of conj(fh) x ft, per frequency: (F, c, k) @ (F, k, c)
        acc += np.matmul(fh.conj().transpose(1, 2, 0), ft.transpose(1, 0, 2))
    return sp_fft.irfft(acc, size, axis=0)[:lags]


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
        ``G[p, a, q, b] = sum_t w_a(p + t) w_b(q + t) / J``, shape ``(s, c, s, c)``
        (exactly symmetric).

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
    first = lag_products(w, s, j)  # first[d, a, b] = sum_{t<J} w_a(t) w_b(t + d) = J G[0, a, d, b]
    first[0] = 0.5 * (first[0] + first[0].T)
    sc = s * c
    out = np.empty((sc, sc))
    out[:c] = first.transpose(1, 0, 2).reshape(c, sc)
    # G[p, q] = G[p-1, q-1] + w(p-1+J) w(q-1+J)^T - w(p-1) w(q-1)^T for q >= p: the update of
    # block (p, q) is block (p-1, q-1) of the outer products of the stacked edge samples
    tl, hd = w[j:].reshape(-1), w[: s - 1].reshape(-1)  # s - 1 samples each
    step = np.multiply.outer(tl, tl)
    if len(hd):
        linalg.blas.dger(-1.0, hd, hd, a=step.T, overwrite_a=True)  # step -= hd hd^T in place (step.T: F order)
    for p in range(1, s):
        r, r0 = slice(p * c, (p + 1) * c), slice((p - 1) * c, p * c)
        np.add(out[r0, (p - 1) * c : (s - 1) * c], step[r0, (p - 1) * c : (s - 1) * c], out=out[r, p * c :])
    mirror_upper(out)  # the block-lower half mirrors the upper half (diagonal blocks are symmetric)
    out /= j
    return out.reshape(s, c, s, c)


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
    # gg is symmetric to the bit: gg.T is the same matrix in Fortran order, which LAPACK reads without the
    # transposing copy scipy makes of a C-ordered array
    try:
        linalg.cholesky(gg.T, lower=True, check_finite=False)
        return gram, False
    except linalg.LinAlgError:
        pass
    low = floor * float(np.trace(gg)) / len(gg)
    # only the eigenpairs below the floor (half the cost of the full decomposition)
    ev, vec = linalg.eigh(gg.T, subset_by_value=(-np.inf, low), driver="evr", check_finite=False)
    # gg + V diag(low - ev) V^T as a symmetric rank-k update (half the flops of the product), in place:
    # gg.T is gg in Fortran order, whose "upper" triangle is gg's lower one
    root = vec * np.sqrt(low - ev)
    linalg.blas.dsyrk(1.0, root, beta=1.0, c=gg.T, trans=0, lower=0, overwrite_c=1)
    mirror_upper(gg.T)
    return gg.reshape(shape), True


def mirror_upper(a: np.ndarray, block: int = 64) -> None:
    """Copy the upper triangle of the square matrix ``a`` into its lower triangle, in place."""
    n = len(a)
    for r in range(0, n, block):
        a[r + block :, r : r + block] = a[r : r + block, r + block :].T
        blk = a[r : r + block, r : r + block]
        low = _tril(len(blk))
        blk[low] = blk.T[low]


_TRIL: dict[int, tuple[np.ndarray, np.ndarray]] = {}


def _tril(n: int) -> tuple[np.ndarray, np.ndarray]:
    """``np.tril_indices(n, -1)``, cached."""
    if n not in _TRIL:
        _TRIL[n] = np.tril_indices(n, -1)
    return _TRIL[n]
