"""The subspace step: PO-MOESP on the data Gram, order selection, B by output error.

Why PO-MOESP
    The extended-input model of NSI (Eq. 16-17) is a linear state-space model
    from ``[fbar, -g_1, ..., -g_p]`` to the displacement, with white
    measurement noise on the output. PO-MOESP (Verhaegen 1994) uses past
    inputs *and* past outputs as instruments, which makes it consistent for
    white output noise (and for process noise), and its LQ factorisation of
    ``[U_f; W_p; Y_f]`` is exactly the Cholesky factor of the Gram matrix of
    the block-Hankel data, so the whole step runs on a ``(2 i c) x (2 i c)``
    matrix built without the Hankel matrix (:mod:`nlid_nsi.gram`): memory
    linear in the record length, which N4SID implementations that form the
    Hankel matrices do not have (``nfoursid`` cannot allocate at 122 880
    samples, see benchmarks/bench_nsi.py). N4SID's oblique projection spans the
    same column space; CVA weighting was measured on the paper's example and
    changed no coefficient in the third decimal (it only reweights the
    singular-value plot), so the unweighted form is used.

Order
    The singular values of the projected future outputs; the order is at the
    largest gap ``log(s_n / s_{n+1})`` over the *even* orders ``n <=
    max_order``: the state of a vibrating structure comes in complex pairs (two
    states per mode, Eq. 16), while a lone real pole is no vibration mode (on a
    noise-free 10 s record of the paper's example a third singular value of
    1.7e-3 after 0.76, a drift pole at 6e-5 rad/s, would win the plain gap
    test: 7.5 against 6.1). The order is 2 on the paper's example in every
    run; ``order`` overrides the choice.

Many k~1 on one Gram (:class:`PerturbedMOESP`)
    nsi-ip fits the channels ``T(k~1) w`` for up to ~15 values of k~1 (search,
    re-checks, ensemble) on three Grams; only the ``fbar`` rows depend on k~1,
    so the rest of the factorisation is done once per Gram (see the class).

B by least squares in output-error form (D = 0)
    Given ``(A, C)`` the output is linear in ``B`` and the initial state:
    ``y = sum_j C (qI - A)^-1 b_j u_j + C A^k x0``. The MOESP Toeplitz
    formula for B was measured first: with 2 % output noise it biased z^3 by
    +3.6 to +12.9 % and z^2 by -9 %, against -0.1 % for the output-error
    least squares, which also admits the errors-in-variables correction of
    :mod:`nlid_nsi.noise`. D = 0: a zero-order-hold discretisation of a
    force-to-displacement model has no feedthrough (Eq. 17).
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator

import numpy as np
from scipy import fft as sp_fft
from scipy import linalg
from scipy.linalg import blas

from .filters import lfilter, lfiltic_output
from .gram import mirror_upper, transform_gram
from .noise import NoiseModel

__all__ = ["select_order", "po_moesp", "PerturbedMOESP", "estimate_b", "channel_blocks"]


def select_order(sv: np.ndarray, max_order: int = 10, even: bool = True) -> int:
    """Order at the largest gap ``log(s_n / s_{n+1})``, ``n = 1..max_order`` (even ``n`` only if ``even``)."""
    k = min(max_order, len(sv) - 1)
    logs = np.log(np.maximum(sv[: k + 1], np.finfo(float).tiny))
    gaps = logs[:k] - logs[1 : k + 1]
    orders = np.arange(1, k + 1)
    if even and k >= 2:
        gaps, orders = gaps[1::2], orders[1::2]
    return int(orders[np.argmax(gaps)])


def _cholesky(gg: np.ndarray, jitter: float = 1e-10) -> np.ndarray:
    """Lower Cholesky factor; a noise-corrected Gram can be marginally indefinite.

    The smallest diagonal load (relative ``1e-10`` to ``1e-4``) that makes it
    positive definite is used; as a last resort the eigenvalues are clipped.
    """
    scale = np.trace(gg) / len(gg)
    diag = np.diag_indices_from(gg)
    for jit in (0.0, jitter, jitter * 1e2, jitter * 1e4, jitter * 1e6):
        trial = gg.copy()
        trial[diag] += jit * scale
        try:
            return linalg.cholesky(trial, lower=True, check_finite=False)
        except linalg.LinAlgError:
            continue
    ev, vec = linalg.eigh(gg)
    ev = np.maximum(ev, jitter * 1e6 * scale)
    return linalg.cholesky((vec * ev) @ vec.T, lower=True, check_finite=False)


def po_moesp(
    gram: np.ndarray, n_inputs: int, order: int | None = None, max_order: int = 10
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """PO-MOESP estimate of ``(A, C)`` from the Gram of ``[u_1..u_m, y]``.

    Parameters
    ----------
    gram
        Gram of the block-Hankel data with ``2 i`` block rows, shape
        ``(2i, m + 1, 2i, m + 1)``; the last channel is the output.
    n_inputs
        ``m``.
    order
        Model order; ``None`` picks the largest singular-value gap.
    max_order
        Largest order considered by the automatic choice.

    Returns
    -------
    A, C : numpy.ndarray
        In the (normalised) units of the channels.
    singular_values : numpy.ndarray
    order : int
    """
    s, c = gram.shape[0], gram.shape[1]
    i, m = s // 2, n_inputs
    uf = [(p, a) for p in range(i, s) for a in range(m)]
    wp = [(p, a) for p in range(i) for a in range(c)]
    yf = [(p, m) for p in range(i, s)]
    idx = np.array(uf + wp + yf)
    gg = gram[idx[:, 0][:, None], idx[:, 1][:, None], idx[:, 0][None, :], idx[:, 1][None, :]]
    lo = _cholesky(0.5 * (gg + gg.T))
    nu, nw = len(uf), len(wp)
    l32 = lo[nu + nw :, nu : nu + nw]
    uu, sv, _ = linalg.svd(l32, full_matrices=False, check_finite=False)
    n = select_order(sv, max_order) if order is None else int(order)
    gam = uu[:, :n] * np.sqrt(sv[:n])
    a = linalg.lstsq(gam[:-1], gam[1:], check_finite=False)[0]
    return a, gam[:1].copy(), sv, n


def _schur(gram: np.ndarray, drop: int) -> np.ndarray:
    """Schur complement of the leading ``drop`` rows and columns of ``gram``.

    ``G[k, k] - G[k, d] G[d, d]^-1 G[d, k]`` with ``d`` the first ``drop``
    indices and ``k`` the others, through a Cholesky factor of ``G[d, d]``.

    Raises
    ------
    scipy.linalg.LinAlgError
        If ``G[d, d]`` is not (numerically) positive definite.
    """
    if drop == 0:
        return gram
    low = linalg.cholesky(gram[:drop, :drop], lower=True, check_finite=False)
    x = linalg.solve_triangular(low, gram[:drop, drop:], lower=True, check_finite=False)
    out = gram[drop:, drop:] - blas.dsyrk(1.0, x, trans=1, lower=0)  # x^T x: upper triangle only
    mirror_upper(out)
    return out


def _exactly_symmetric(a: np.ndarray, block: int = 64) -> bool:
    """Whether the square matrix ``a`` equals its transpose to the bit (compared one block of rows at a time)."""
    n = len(a)
    return all(np.array_equal(a[r : r + block, r:], a[r:, r : r + block].T) for r in range(0, n, block))


class PerturbedMOESP:
    """PO-MOESP of the channels ``T(kappa) w`` for many ``kappa`` from one base Gram.

    nsi-ip fits the extended-input model of ``T(kappa) w`` with ``T(kappa) =
    T0 + kappa T1`` (``fbar = f + k~1 <z>``, Eq. 13; only the rows of T1 that
    are not zero, the *varying* channels, depend on k~1). :func:`po_moesp`
    needs, for each ``kappa``, the Cholesky factor of the reordered Gram of
    ``[U_f; W_p; Y_f]`` (future inputs, past data, future output) and the SVD
    of its block ``L32``. Only two of its quantities matter: the left singular
    vectors and the singular values of ``L32``, and

        L32 L32^T = S(Y_f | U_f) - S(Y_f | U_f, W_p)

    (``S(Y | X)`` is the Schur complement of ``X`` in the Gram of ``[X; Y]``:
    the covariance of ``Y`` after projecting out ``X``). Schur complements
    commute with linear maps of the rows that are kept, so the rows that do
    not depend on ``kappa`` (the other inputs, the past output) are eliminated
    once per Gram, keeping both components ``T0 w`` and ``T1 w`` of every
    varying row; a value of ``kappa`` then only combines those components
    (a congruence of a matrix of ``(2 v + 1) i`` rows, ``v`` varying channels)
    and eliminates the ``2 v i`` varying rows. The eigendecomposition of the
    ``i x i`` difference gives the same ``(A, C)``, singular values and order
    as :func:`po_moesp` on ``transform_gram(gram, T(kappa))`` (to rounding,
    with the signs of the state coordinates possibly flipped, which leaves
    every transfer function unchanged).

    Precomputation: two Cholesky factorisations of at most ``2 i (c - v)``
    rows; per ``kappa``: ``O((v i)^3 + i^3)`` instead of ``O((2 i c)^3)``.
    When a factorisation fails (a Gram that is not positive definite)
    :meth:`estimate` falls back to :func:`po_moesp` on the transformed Gram,
    whose Cholesky loads the diagonal as needed: results never depend on
    which path ran.

    Parameters
    ----------
    gram
        Base Gram, shape ``(2 i, c, 2 i, c)``.
    t0, t1
        The channel map ``T(kappa) = t0 + kappa t1``, shape ``(m + 1, c)``;
        the last row (the output) must not depend on ``kappa``.
    """

    def __init__(self, gram: np.ndarray, t0: np.ndarray, t1: np.ndarray):
        self.gram = gram
        self.t0 = np.asarray(t0, dtype=float)
        self.t1 = np.asarray(t1, dtype=float)
        s, c = gram.shape[0], gram.shape[1]
        i = s // 2
        cp = self.t0.shape[0]
        m = cp - 1
        varying = [r for r in range(cp) if np.any(self.t1[r] != 0.0)]
        fixed = [r for r in range(cp) if r not in varying]
        self.varying, self.fixed, self.i, self.m = varying, fixed, i, m
        self.ok = m not in varying
        if not self.ok:
            return
        # augmented channels: the fixed rows, then T0 and T1 of every varying row
        aug = np.vstack([self.t0[fixed], self.t0[varying], self.t1[varying]])
        ca = aug.shape[0]
        pos_fixed = {r: k for k, r in enumerate(fixed)}
        nv = len(varying)

        def rows(blocks: range, channels: list[int]) -> list[int]:
            return [p * ca + a for p in blocks for a in channels]

        fut, past = range(i, s), range(i)
        u_fixed = rows(fut, [pos_fixed[r] for r in fixed if r < m])
        w_fixed = rows(past, [pos_fixed[r] for r in fixed])
        y_fut = rows(fut, [pos_fixed[m]])
        # the varying rows' components, ordered (component, horizon, varying channel, block row)
        comp0, comp1 = len(fixed), len(fixed) + nv

        def varying_rows(horizons: tuple[range, ...]) -> list[int]:
            return [p * ca + off + v for off in (comp0, comp1) for h in horizons for v in range(nv) for p in h]

        # eliminate U_f's fixed rows, then W_p's fixed rows (Schur complements nest)
        keep = varying_rows((fut, past)) + y_fut
        order = np.array(u_fixed + w_fixed + keep)
        if np.all((aug == 1.0).sum(axis=1) + (aug == 0.0).sum(axis=1) == c) and np.all(aug.sum(axis=1) == 1.0):
            # a selection of the base channels (nsi-ip): gather the reordered Gram directly
            pick = np.argmax(aug, axis=1)
            flat = (order // ca) * c + pick[order % ca]
            ga = gram.reshape(s * c, s * c)[np.ix_(flat, flat)]
        else:
            ga = transform_gram(gram, aug).reshape(s * ca, s * ca)[np.ix_(order, order)]
        if not _exactly_symmetric(ga):  # the Grams nsi builds are (and (x + x) / 2 == x)
            ga += ga.T
            ga *= 0.5
        nu, nw, nk = len(u_fixed), len(w_fixed), nv * i
        pick_u = np.r_[nw : nw + nk, nw + 2 * nk : nw + 3 * nk, nw + 4 * nk : nw + 4 * nk + i]
        try:
            s1 = _schur(ga, nu)  # rows [W_p fixed; T0 fut, T0 past, T1 fut, T1 past; Y_f]
            self.s_u = self._split(s1[np.ix_(pick_u, pick_u)], nk)
            self.s_uw = self._split(_schur(s1, nw), 2 * nk)
        except linalg.LinAlgError:
            self.ok = False

    @staticmethod
    def _split(schur: np.ndarray, nvar: int) -> tuple[np.ndarray, ...]:
        """The blocks of ``S`` over ``[T0 parts; T1 parts; Y]`` that :meth:`_combine` needs."""
        a, b = slice(0, nvar), slice(nvar, 2 * nvar)
        y = slice(2 * nvar, None)
        return schur[a, a], schur[a, b] + schur[b, a], schur[b, b], schur[a, y], schur[b, y], schur[y, y]

    @staticmethod
    def _combine(blocks: tuple[np.ndarray, ...], kappa: float) -> np.ndarray:
        """``S(Y | varying rows)`` at ``kappa`` from the blocks of :meth:`_split`.

        The varying rows are ``T0 part + kappa T1 part``: their Gram is
        ``S00 + kappa (S01 + S10) + kappa^2 S11`` and their cross-Gram with
        ``Y`` is ``S0y + kappa S1y``.
        """
        s00, s01, s11, s0y, s1y, syy = blocks
        if s00.shape[0] == 0:
            return syy
        gvv = s00 + kappa * s01 + kappa * kappa * s11
        low = linalg.cholesky(gvv, lower=True, check_finite=False)
        x = linalg.solve_triangular(low, s0y + kappa * s1y, lower=True, check_finite=False)
        return syy - x.T @ x

    def kappa(self, t: np.ndarray) -> float | None:
        """``kappa`` with ``t = t0 + kappa t1``, or ``None`` if ``t`` is not of that form."""
        if t.shape != self.t0.shape:
            return None
        idx = np.unravel_index(np.argmax(np.abs(self.t1)), self.t1.shape)
        kappa = float((t[idx] - self.t0[idx]) / self.t1[idx]) if self.t1[idx] != 0 else 0.0
        return kappa if np.array_equal(t, self.t0 + kappa * self.t1) else None

    def estimate(
        self, t: np.ndarray, order: int | None = None, max_order: int = 10
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
        """:func:`po_moesp` of the channels ``t w`` for ``t = T(kappa)`` (see the class docstring).

        Parameters
        ----------
        t
            The channel map; a map not of the form ``t0 + kappa t1`` goes
            through :func:`po_moesp` on the transformed Gram.
        order, max_order
            As in :func:`po_moesp`.
        """
        kappa = self.kappa(t) if self.ok else None
        if kappa is not None:
            try:
                proj = self._combine(self.s_u, kappa) - self._combine(self.s_uw, kappa)
                ev, vec = linalg.eigh(0.5 * (proj + proj.T), check_finite=False)
            except linalg.LinAlgError:
                pass
            else:
                ev, vec = ev[::-1], vec[:, ::-1]
                sv = np.sqrt(np.maximum(ev, 0.0))
                n = select_order(sv, max_order) if order is None else int(order)
                gam = vec[:, :n] * np.sqrt(sv[:n])
                a = linalg.lstsq(gam[:-1], gam[1:], check_finite=False)[0]
                return a, gam[:1].copy(), sv, n
        return po_moesp(transform_gram(self.gram, t), self.m, order, max_order)


def _state_filters(a: np.ndarray, cm: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
    """Denominator and numerators of ``C (qI - A)^-1 e_r``, ``r = 1..n``.

    The arithmetic of ``scipy.signal.ss2tf(A, e_r, C, 0)`` (``poly(A - e_r C) -
    poly(A)``, the same numbers to the bit) without its argument handling,
    which cost more than the polynomials for a 2 x 2 ``A``.
    """
    n = a.shape[0]
    den = np.poly(a)
    nums = []
    for r in range(n):
        shifted = np.array(a, dtype=float)
        shifted[r] -= cm[0]  # A - e_r C
        nums.append(np.atleast_1d(np.poly(shifted) + (0.0 - 1.0) * den))
    return den, nums


#: Samples of the data processed at a time by the B step: its temporaries (~1 MB) stay in cache; measured
#: at 10^6 samples, 4 096-8 192 samples 80-81 ms per call, 16 384 samples 86 ms, 65 536 samples 108 ms.
B_BLOCK = 8192


def _row_blocks(u: np.ndarray, y: np.ndarray, size: int = B_BLOCK) -> Iterator[np.ndarray]:
    """``[u, y]`` in consecutive blocks of samples, channel-major: shape ``(m + 1, rows)`` (new arrays)."""
    u = np.asarray(u, dtype=float).reshape(len(y), -1)
    for r0 in range(0, len(y), size):
        yield np.vstack([u[r0 : r0 + size].T, y[r0 : r0 + size]])


def channel_blocks(base: np.ndarray, t: np.ndarray, size: int = B_BLOCK) -> Iterator[np.ndarray]:
    """The channels ``t w`` (``w = base``: inputs, then the output) in consecutive blocks of samples.

    Each block is channel-major, shape ``(m + 1, rows)``: one contiguous row
    per channel. The mapped channels (``fbar = f + k~1 <z>`` for nsi-ip) are
    formed one block at a time: never a second copy of the record.
    """
    for r0 in range(0, len(base), size):
        yield t @ base[r0 : r0 + size].T


def _normal_equations(
    den: np.ndarray, nums: list[np.ndarray], blocks: Iterable[np.ndarray]
) -> tuple[np.ndarray, np.ndarray, int]:
    """Normal equations of the output-error regression of :func:`estimate_b`, in one pass.

    Every regressor is ``nums_r / den`` applied to a signal: ``C (qI - A)^-1
    e_r u_j`` for the inputs, the impulse response ``C A^t e_r`` for the
    initial state. The all-pole part ``e_j = u_j / den`` is run once per input
    (and once for an impulse at ``t = -1``, whose response at ``t >= 0`` is
    the initial-state regressor) by ``lfilter`` (:mod:`nlid_nsi.filters`), block by block
    with its state carried over; the regressors are the FIR ``nums_r`` over
    lags ``0..n`` of those signals. So ``phi^T phi`` and ``phi^T y`` are a
    fixed linear map of the Gram of ``[e(t), e(t-1), .., e(t-n), y(t)]``.
    Its blocks are lagged products of one signal: the block of lags ``(l,
    l + d)`` is ``sum_{s = -l}^{N-1-l} e(s) e(s - d)^T``, i.e. the ``n + 1``
    products ``sum_{0 <= s < N} e(s) e(s - d)^T`` (accumulated per block from
    ``e`` and its last ``2 n`` samples, channel-major: a product with a short
    output and a long inner dimension, which BLAS does at full speed) plus the
    ``l`` samples before ``s = 0`` minus the last ``l``. That is ``n + 1``
    products of ``m + 1`` rows per block instead of one of ``(n + 1)(m + 1)``
    lagged copies (35 % less time per pass at 10^6 samples, the same numbers
    to rounding: docs/performance.md, round four). No matrix of the record's
    length.

    ``blocks`` are consecutive channel-major blocks ``[u_1 .. u_m, y]`` of
    shape ``(m + 1, rows)`` (:func:`channel_blocks`; new arrays: they are
    overwritten).

    Returns
    -------
    gram, rhs
        ``phi^T phi`` and ``phi^T y`` (not divided by the length).
    length
        Number of rows.
    """
    n = len(den) - 1
    taps = np.array(nums)  # (n, n + 1); taps[:, 0] = 0 (no feedthrough)
    h = 2 * n  # samples of e kept before each block: e(s - d) for a lag d <= n of the first n samples
    hist = zi = prods = rhs = first = None
    total = m = 0
    for x in blocks:
        k1, rows = x.shape
        m = k1 - 1
        if hist is None:
            hist = np.zeros((k1, h))  # e(-2n .. -1): zero but the impulse at t = -1 in the last channel
            if n:
                hist[m, h - 1] = 1.0
            first = hist.copy()
            zi = np.zeros((k1, n))
            zi[m] = lfiltic_output(den, 1.0)
            prods = np.zeros((n + 1, k1, k1))
            rhs = np.zeros((n + 1, k1))
        y = x[m].copy()
        x[m] = 0.0  # the impulse channel's input (the impulse itself is in the state)
        e, zi = lfilter([1.0], den, x, axis=1, zi=zi)
        ext = np.concatenate([hist, e], axis=1)  # ext[:, h + s - t0] = e(s) for s >= t0 - 2n
        for d in range(n + 1):  # sum over the block's s of e(s) e(s - d)^T, and of e(t - d) y(t)
            lagged = ext[:, h - d : h - d + rows]
            prods[d] += e @ lagged.T
            rhs[d] += lagged @ y
        hist = ext[:, -h:] if h else hist
        total += rows
    k1 = m + 1
    # lag_gram[l k1 + j, l' k1 + k] = sum_{t < N} e_j(t - l) e_k(t - l'): for l' = l + d >= l this is the sum over
    # s = t - l in [-l, N - l) of e_j(s) e_k(s - d), i.e. prods[d] plus the l samples before 0 minus the last l
    start, end = first, hist  # e(-2n .. -1) and e(N - 2n .. N - 1)
    lag_gram = np.empty(((n + 1) * k1, (n + 1) * k1))
    for lag in range(n + 1):
        for d in range(n + 1 - lag):
            block = prods[d].copy()
            for q in range(1, lag + 1):  # s = -q: e(-q) e(-q - d)^T, s = N - q: subtracted
                block += np.outer(start[:, h - q], start[:, h - q - d])
                block -= np.outer(end[:, h - q], end[:, h - q - d])
            rows_, cols_ = slice(lag * k1, (lag + 1) * k1), slice((lag + d) * k1, (lag + d + 1) * k1)
            lag_gram[rows_, cols_] = block
            lag_gram[cols_, rows_] = block.T
    lag_gram = np.triu(lag_gram) + np.triu(lag_gram, 1).T  # exactly symmetric (a product need not be)
    lag_rhs = rhs.reshape(-1)
    # phi[:, r m + j] = sum_l taps[r, l] e_j(t - l), the initial-state column likewise from e_imp
    k = np.zeros(((n + 1) * k1, n * m + n))
    for rr in range(n):
        for lag in range(n + 1):
            for j in range(m):
                k[lag * k1 + j, rr * m + j] = taps[rr, lag]
            k[lag * k1 + m, n * m + rr] = taps[rr, lag]
    return k.T @ lag_gram @ k, k.T @ lag_rhs, total


def _impulse_products(den: np.ndarray, nums: list[np.ndarray], lag: int, ir_len: int) -> tuple[np.ndarray, np.ndarray]:
    """Impulse responses ``h_r`` (length ``ir_len``) and ``hc[r, r', L + d] = sum_l h_r(l + d) h_r'(l)``, ``|d| <= L``.

    The lag products are one FFT correlation (zero-padded: no wrap-around).
    """
    imp = np.zeros(ir_len)
    imp[0] = 1.0
    hr = np.array([lfilter(num, den, imp) for num in nums])
    size = sp_fft.next_fast_len(ir_len + lag + 1, real=True)
    spec = sp_fft.rfft(hr, size, axis=1)
    corr = sp_fft.irfft(spec[:, None, :] * spec[None, :, :].conj(), size, axis=2)
    hc = np.concatenate([corr[:, :, size - lag :], corr[:, :, : lag + 1]], axis=2)
    return hr, hc


def estimate_b(
    a: np.ndarray,
    cm: np.ndarray,
    u: np.ndarray | None,
    y: np.ndarray | None,
    noise: NoiseModel | None = None,
    output: int | None = None,
    ir_len: int = 16384,
    blocks: Iterable[np.ndarray] | None = None,
) -> np.ndarray:
    """``B`` (n x m) by least squares of ``y`` on ``C (qI - A)^-1 e_r u_j`` plus an initial state.

    Parameters
    ----------
    a, cm
        ``A`` and ``C`` (must be stable: the regressors are filtered by ``A``).
    u, y
        Inputs ``(N, m)`` and output ``(N,)``; or ``None`` with ``blocks``.
    noise
        Model of the noise of the channels ``[u_1..u_m, y]``: its expected
        contributions are removed from the normal equations (errors in variables).
    output
        Index of ``y`` in ``noise``.
    ir_len
        Length of the impulse responses used for the noise correction.
    blocks
        The data as consecutive channel-major blocks ``[u, y]`` of shape
        ``(m + 1, rows)`` (new arrays, e.g. :func:`channel_blocks`) instead of
        ``u`` and ``y``.
    """
    n = a.shape[0]
    den, nums = _state_filters(a, cm)
    gram, rhs, nn = _normal_equations(den, nums, _row_blocks(u, y) if blocks is None else blocks)
    m = (len(rhs) - n) // n
    gram /= nn
    rhs /= nn
    if noise is not None:
        lag = noise.max_lag
        cov = noise.lag_covariance(exclude_output=output)
        hr, hc = _impulse_products(den, nums, lag, ir_len)  # hc[r, r', L + d] = sum_l h_r(l + d) h_r'(l)
        enn = np.einsum("lab,rsl->rasb", cov[:, :m, :m], hc).reshape(n * m, n * m)
        ene = np.einsum("rl,lj->rj", hr[:, : lag + 1], cov[lag:, :m, output]).reshape(n * m)
        gram[: n * m, : n * m] -= enn
        rhs[: n * m] -= ene
    x = linalg.solve(gram, rhs, assume_a="sym")
    return x[: n * m].reshape(n, m)
