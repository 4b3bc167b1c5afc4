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

import numpy as np
from scipy import linalg, signal

from .noise import NoiseModel

__all__ = ["select_order", "po_moesp", "estimate_b"]


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


def _state_filters(a: np.ndarray, cm: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
    """Denominator and numerators of ``C (qI - A)^-1 e_r``, ``r = 1..n``."""
    n = a.shape[0]
    den = np.poly(a)
    nums = []
    for r in range(n):
        e = np.zeros((n, 1))
        e[r] = 1.0
        num, _ = signal.ss2tf(a, e, cm, np.zeros((1, 1)))
        nums.append(np.atleast_1d(num[0]))
    return den, nums


def estimate_b(
    a: np.ndarray,
    cm: np.ndarray,
    u: np.ndarray,
    y: np.ndarray,
    noise: NoiseModel | None = None,
    output: int | None = None,
    ir_len: int = 16384,
) -> np.ndarray:
    """``B`` (n x m) by least squares of ``y`` on ``C (qI - A)^-1 e_r u_j`` plus an initial state.

    Parameters
    ----------
    a, cm
        ``A`` and ``C`` (must be stable: the regressors are filtered by ``A``).
    u, y
        Inputs ``(N, m)`` and output ``(N,)``.
    noise
        Model of the noise of the channels ``[u_1..u_m, y]``: its expected
        contributions are removed from the normal equations (errors in variables).
    output
        Index of ``y`` in ``noise``.
    ir_len
        Length of the impulse responses used for the noise correction.
    """
    nn, m = u.shape
    n = a.shape[0]
    den, nums = _state_filters(a, cm)
    phi = np.empty((nn, n * m + n))
    for r in range(n):
        for j in range(m):
            phi[:, r * m + j] = signal.lfilter(nums[r], den, u[:, j])
    imp = np.zeros(nn + 1)
    imp[0] = 1.0
    for r in range(n):  # C A^k e_r: the initial state (without it: 0.15 % errors even without noise)
        phi[:, n * m + r] = signal.lfilter(nums[r], den, imp)[1:]
    gram = phi.T @ phi / nn
    rhs = phi.T @ y / nn
    del phi
    if noise is not None:
        lag = noise.max_lag
        cov = noise.lag_covariance(exclude_output=output)
        imp2 = np.zeros(ir_len)
        imp2[0] = 1.0
        hr = np.array([signal.lfilter(nums[r], den, imp2) for r in range(n)])
        hc = np.zeros((n, n, 2 * lag + 1))  # hc[r, r', L + d] = sum_l h_r(l + d) h_r'(l)
        for d in range(-lag, lag + 1):
            if d >= 0:
                hc[:, :, lag + d] = hr[:, d:] @ hr[:, : ir_len - d].T
            else:
                hc[:, :, lag + d] = hr[:, : ir_len + d] @ hr[:, -d:].T
        enn = np.einsum("lab,rsl->rasb", cov[:, :m, :m], hc).reshape(n * m, n * m)
        ene = np.einsum("rl,lj->rj", hr[:, : lag + 1], cov[lag:, :m, output]).reshape(n * m)
        gram[: n * m, : n * m] -= enn
        rhs[: n * m] -= ene
    x = linalg.solve(gram, rhs, assume_a="sym")
    return x[: n * m].reshape(n, m)
