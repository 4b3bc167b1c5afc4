"""NSI with several outputs: the subspace step, B, the underlying linear FRF matrix and M, C, K.

A structure of ``n`` DOFs with localised elements obeys (Marchesiello &
Garibaldi 2008)::

    M z'' + C z' + K z = sum_d e_d f_d + sum_e b_e theta_e (-g_e(x_e, x_e'))

so one linear state-space model of order ``2 n`` maps the extended input
``[f_d..., -g_1, ..., -g_E]`` to the ``n`` displacements. Its extended FRF is
``H_E = [H e_d..., H b_1 theta_1, ...]`` with ``H(w)`` the receptance of the
underlying linear system (ULS).

Subspace step (:func:`mimo_moesp`)
    PO-MOESP on the Gram of the block-Hankel data (:mod:`nlid_nsi.gram`), as
    for one DOF, with ``n`` future outputs; the order is ``2 n``.

B (:func:`estimate_b`)
    Output-error least squares over every output jointly, with the initial
    state, in the real modal form of ``A`` (one second-order filter per
    mode: well conditioned for any number of modes, unlike the polynomial of
    ``A``).

The ULS (:func:`structure_uls`)
    The second-order realisation: in the coordinates ``[z; z'] = [C; C A_c] x``
    the model is ``z'' = -M^-1 K z - M^-1 C z' + M^-1 (forces)``; the force
    inputs give the columns ``M^-1 e_d``, and reciprocity (``K``, ``C``
    symmetric) the rest of ``M^-1`` (the mass is estimated when it is not
    given). The eigenvalues of the realisation are those of the identified
    model (the moments ``M^-1 = Phi Lambda Phi^T``... of the modal expansion
    were tried first: their modes were 0.7 % off in damping on a noise-free
    record, against 1e-4 % for the eigenvalues).

Coefficients (:func:`element_spectra`)
    ``theta_e(w) = H_E[d, e] / (b_e^T H_E[:, f_d])`` per element: by
    reciprocity the row ``d`` of ``H b_e`` is ``b_e^T`` times the force column
    of the driven DOF ``d`` (least squares over the driven DOFs) (the coefficient
    spectrum, Eq. 20 with several outputs); the estimate is the real part of
    its least-squares average over the half-power bands of every mode (the
    weight ``|H b_e|^2`` is where the element is loaded), the quality
    ``E[Re/Im]`` as for one DOF.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import fft as sp_fft
from scipy import linalg

from .continuous import band_limits, d2c_zoh
from .filters import lfilter
from .noise import NoiseModel
from .subspace import _cholesky

__all__ = ["mimo_moesp", "estimate_b", "ULSModes", "structure_uls", "frf_matrix", "element_spectra", "band_grid"]


def mimo_moesp(gram: np.ndarray, m: int, l: int, order: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # noqa: E741
    """PO-MOESP ``(A, C, singular values)`` from the Gram of ``[u_1..u_m, y_1..y_l]`` (shape ``(2i, c, 2i, c)``)."""
    s, c = gram.shape[0], gram.shape[1]
    i = s // 2
    uf = [(p, a) for p in range(i, s) for a in range(m)]
    wp = [(p, a) for p in range(i) for a in range(c)]
    yf = [(p, m + o) for p in range(i, s) for o in range(l)]
    idx = np.array(uf + wp + yf)
    gg = gram[idx[:, 0][:, None], idx[:, 1][:, None], idx[:, 0][None, :], idx[:, 1][None, :]]
    low = _cholesky(0.5 * (gg + gg.T))
    nu, nw = len(uf), len(wp)
    l32 = low[nu + nw :, nu : nu + nw]
    uu, sv, _ = linalg.svd(l32, full_matrices=False, check_finite=False)
    gam = uu[:, :order] * np.sqrt(sv[:order])
    a = linalg.lstsq(gam[:-l], gam[l:], check_finite=False)[0]
    return a, gam[:l].copy(), sv


def _real_modal(a: np.ndarray) -> tuple[np.ndarray, list[slice]]:
    """``T`` with ``T^-1 A T`` block diagonal (2 x 2 per complex pair, 1 x 1 per real eigenvalue), and the blocks."""
    lam, vec = linalg.eig(a)
    cols: list[np.ndarray] = []
    blocks: list[slice] = []
    used = np.zeros(len(lam), dtype=bool)
    for r in np.argsort(-np.abs(lam.imag), kind="stable"):
        if used[r]:
            continue
        used[r] = True
        if abs(lam[r].imag) > 1e-12 * max(1.0, abs(lam[r])):
            partner = np.argmin(np.abs(lam - lam[r].conj()) + used * 1e300)
            used[partner] = True
            blocks.append(slice(len(cols), len(cols) + 2))
            cols += [vec[:, r].real, vec[:, r].imag]
        else:
            blocks.append(slice(len(cols), len(cols) + 1))
            cols.append(vec[:, r].real)
    return np.column_stack(cols), blocks


def estimate_b(
    a: np.ndarray,
    cm: np.ndarray,
    u: np.ndarray,
    y: np.ndarray,
    noise: NoiseModel | None = None,
    ir_len: int = 16384,
) -> np.ndarray:
    """``B`` (``nx x m``) by output-error least squares of every output on ``C (qI - A)^-1 B u`` and an initial state.

    ``A`` must be stable. Each mode's regressors are one second-order filter
    of each input (and of an impulse for the initial state) followed by a
    short FIR (the numerators of ``C_o (qI - A_k)^-1 e_r``), so the normal
    equations come from the Gram of a few lagged signals: no matrix of the
    record's length times the parameters.

    ``noise`` (the model of the channels ``[u, y]``, :mod:`nlid_nsi.structure_noise`)
    removes the expected noise contributions from the normal equations, as
    the one-DOF :func:`nlid_nsi.subspace.estimate_b` does (errors in
    variables): per output ``o`` the regressor of ``(state r, input j)`` is
    ``h_or * u_j``, so ``E[phi^T phi]`` gains ``sum_d hc_o[r, r', d] cov[d, j, j']``
    and ``E[phi^T y_o]`` gains ``sum_l h_or(l) cov[l, j, y_o]`` (``ir_len``:
    length of the impulse responses ``h_or``).
    """
    nx = a.shape[0]
    n_samples, m = u.shape
    nout = y.shape[1]
    t, blocks = _real_modal(a)
    am = linalg.solve(t, a @ t)
    cmod = cm @ t
    x = np.zeros((m + 1, n_samples + 1))  # index 0 is t = -1 (the impulse of the initial state)
    x[:m, 1:] = u.T
    x[m, 0] = 1.0
    rows: list[np.ndarray] = []
    maps: list[tuple[int, slice, list[np.ndarray]]] = []  # (first lagged row, block, numerators per output)
    offset = 0
    for blk in blocks:
        ab = am[blk, blk]
        d = ab.shape[0]
        den = np.poly(ab)
        e = lfilter([1.0], den, x, axis=1)
        for lag in range(d + 1):
            lagged = np.zeros((m + 1, n_samples))
            start = max(lag - 1, 0)
            lagged[:, start:] = e[:, start - lag + 1 : n_samples - lag + 1]
            rows.append(lagged)
        nums = []
        for o in range(nout):
            per_state = []
            for r in range(d):
                shifted = ab.copy()
                shifted[r] -= cmod[o, blk]
                per_state.append(np.poly(shifted) - den)
            nums.append(np.array(per_state))  # (d, d + 1)
        maps.append((offset, blk, nums))
        offset += (d + 1) * (m + 1)
    lag_rows = np.vstack(rows)
    gram = lag_rows @ lag_rows.T
    rhs = lag_rows @ y
    npar = nx * m + nx
    normal = np.zeros((npar, npar))
    vec = np.zeros(npar)
    for o in range(nout):
        k = np.zeros((offset, npar))
        for first, blk, nums in maps:
            d = blk.stop - blk.start
            for rr in range(d):
                r = blk.start + rr
                for lag in range(d + 1):
                    base = first + lag * (m + 1)
                    k[base : base + m, r * m : (r + 1) * m] += nums[o][rr, lag] * np.eye(m)
                    k[base + m, nx * m + r] += nums[o][rr, lag]
        normal += k.T @ gram @ k
        vec += k.T @ rhs[:, o]
    if noise is not None:
        normal, vec = _subtract_b_noise(normal, vec, noise, maps, am, n_samples, m, nout, ir_len)
    theta = linalg.solve(normal, vec, assume_a="sym")
    return t @ theta[: nx * m].reshape(nx, m)


def _subtract_b_noise(
    normal: np.ndarray,
    vec: np.ndarray,
    noise: NoiseModel,
    maps: list,
    am: np.ndarray,
    n_samples: int,
    m: int,
    nout: int,
    ir_len: int,
) -> tuple[np.ndarray, np.ndarray]:
    """The normal equations of :func:`estimate_b` without the expected contribution of the channels' noise."""
    nx = am.shape[0]
    lag = noise.max_lag
    cov = noise.lag_covariance() * n_samples  # [L + l, a, b], summed over the samples
    imp = np.zeros(ir_len)
    imp[0] = 1.0
    size = sp_fft.next_fast_len(ir_len + lag + 1, real=True)
    normal, vec = normal.copy(), vec.copy()
    for o in range(nout):
        hr = np.zeros((nx, ir_len))
        for _, blk, nums in maps:
            den = np.poly(am[blk, blk])
            for rr in range(blk.stop - blk.start):
                hr[blk.start + rr] = lfilter(nums[o][rr], den, imp)
        spec = sp_fft.rfft(hr, size, axis=1)
        corr = sp_fft.irfft(spec[:, None, :] * spec[None, :, :].conj(), size, axis=2)
        hc = np.concatenate([corr[:, :, size - lag :], corr[:, :, : lag + 1]], axis=2)  # sum_l h_r(l + d) h_s(l)
        enn = np.einsum("lab,rsl->rasb", cov[:, :m, :m], hc).reshape(nx * m, nx * m)
        ene = np.einsum("rl,lj->rj", hr[:, : lag + 1], cov[lag:, :m, m + o]).reshape(nx * m)
        normal[: nx * m, : nx * m] -= enn
        vec[: nx * m] -= ene
    return normal, vec


@dataclass(frozen=True)
class ULSModes:
    """The identified model in continuous time and the ULS it realises.

    Attributes
    ----------
    ac, bc, cm
        Continuous-time ``A``, ``B`` (physical input units) and ``C`` (m) of the extended model.
    eigenvalues
        ``lambda_r`` of ``A_c`` (rad/s), ``2 n`` of them.
    M, C, K
        The ULS matrices (symmetric) of the second-order realisation.
    asymmetry
        Relative antisymmetric part of ``K`` and ``C`` before they were symmetrised, and the
        relative size of ``C B`` (a displacement that jumps with the force; 0 for a mechanical system).
    """

    ac: np.ndarray
    bc: np.ndarray
    cm: np.ndarray
    eigenvalues: np.ndarray
    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    asymmetry: dict

    @property
    def fn_hz(self) -> np.ndarray:
        """Natural frequencies (Hz) of the modes in the upper half-plane, increasing."""
        up = self.eigenvalues[self.eigenvalues.imag > 0]
        return np.sort(np.abs(up)) / (2 * math.pi)

    @property
    def zeta(self) -> np.ndarray:
        """Damping ratios in the order of :attr:`fn_hz`."""
        up = self.eigenvalues[self.eigenvalues.imag > 0]
        up = up[np.argsort(np.abs(up))]
        return -up.real / np.abs(up)


def _symmetric_inverse_mass(p: np.ndarray, q: np.ndarray, columns: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """``S = M^-1`` (symmetric) with ``S P^T = P S``, ``S Q^T = Q S`` (``K``, ``C`` symmetric) and ``S d = columns``.

    Least squares over the unknowns of a symmetric ``S``, each group of
    equations divided by its scale.
    """
    n = p.shape[0]
    pairs = [(i, j) for i in range(n) for j in range(i, n)]
    index = {}
    for k, (i, j) in enumerate(pairs):
        index[(i, j)] = index[(j, i)] = k
    rows, rhs = [], []
    for mat in (p, q):
        w = 1.0 / max(float(np.linalg.norm(mat)), 1e-300)
        for i in range(n):
            for j in range(i + 1, n):
                row = np.zeros(len(pairs))
                for k in range(n):  # (P S)_ij - (S P^T)_ij
                    row[index[(k, j)]] += w * mat[i, k]
                    row[index[(i, k)]] -= w * mat[j, k]
                rows.append(row)
                rhs.append(0.0)
    for col, d in zip(columns.T, directions.T, strict=True):
        w = 1.0 / max(float(np.linalg.norm(col)), 1e-300)
        for i in range(n):  # (S d)_i
            row = np.zeros(len(pairs))
            for k in range(n):
                row[index[(i, k)]] += w * d[k]
            rows.append(row)
            rhs.append(w * col[i])
    x = linalg.lstsq(np.array(rows), np.array(rhs))[0]
    s = np.empty((n, n))
    for k, (i, j) in enumerate(pairs):
        s[i, j] = s[j, i] = x[k]
    return s


def structure_uls(
    a: np.ndarray, b: np.ndarray, cm: np.ndarray, dt: float, directions: np.ndarray, mass: np.ndarray | None = None
) -> ULSModes:
    """The ULS of an identified extended model: its second-order realisation.

    The state ``[z; z']`` is ``T x`` with ``T = [C; C A_c]``; in it ``A_c``
    is ``[[0, I], [-M^-1 K, -M^-1 C]]`` and the force inputs' ``B`` rows are
    ``M^-1 d``. ``M^-1`` is the symmetric matrix that makes ``K`` and ``C``
    symmetric and matches those columns (:func:`_symmetric_inverse_mass`),
    or the inverse of the given mass. ``K`` and ``C`` are then symmetrised;
    their eigenvalues are those of ``A_c`` up to that (``asymmetry``).

    Parameters
    ----------
    a, b, cm
        Discrete model in physical units (``b``: every extended input; ``cm``: ``n`` outputs).
    dt
        Sampling interval (s).
    directions
        ``(n, k)``: the force direction of each of the first ``k`` inputs (``e_d`` for the force on DOF ``d``).
    mass
        The mass matrix when known.
    """
    n = cm.shape[0]
    ac, bc, lam = d2c_zoh(a, b, dt)
    ac = np.real(ac)
    bc = np.real(bc)
    t = np.vstack([cm, cm @ ac])
    aq = linalg.solve(t.T, (t @ ac).T).T  # T A_c T^-1
    bq = t @ bc
    p, q = -aq[n:, :n], -aq[n:, n:]
    k = directions.shape[1]
    if mass is None:
        s = _symmetric_inverse_mass(p, q, bq[n:, :k], directions)
        M = linalg.inv(s)
    else:
        M = np.asarray(mass, dtype=float)
    K, C = M @ p, M @ q
    asym = {
        "K": float(np.linalg.norm(K - K.T) / max(np.linalg.norm(K), 1e-300)),
        "C": float(np.linalg.norm(C - C.T) / max(np.linalg.norm(C), 1e-300)),
        "CB": float(np.linalg.norm(bq[:n]) / max(np.linalg.norm(bq[n:]) * dt, 1e-300)),
    }
    sym = [0.5 * (x + x.T) for x in (M, C, K)]
    return ULSModes(ac, bc, cm, lam, *sym, asym)


def frf_matrix(uls: ULSModes, w: np.ndarray) -> np.ndarray:
    """``H(w) = (K - w^2 M + i w C)^-1``, shape ``(len(w), n, n)`` (m/N)."""
    dyn = uls.K[None] - (w**2)[:, None, None] * uls.M[None] + 1j * w[:, None, None] * uls.C[None]
    return np.linalg.inv(dyn)


def extended_frf(uls: ULSModes, w: np.ndarray) -> np.ndarray:
    """``H_E(w) = C (i w I - A_c)^-1 B_c``, shape ``(len(w), n, m)``."""
    lam, vec = linalg.eig(uls.ac)
    left = uls.cm @ vec
    right = linalg.solve(vec, uls.bc)
    inv = 1.0 / (1j * w[:, None] - lam[None, :])
    return np.einsum("ir,wr,rj->wij", left, inv, right)


def band_grid(uls: ULSModes, band: str | tuple[float, float], points: int = 256) -> np.ndarray:
    """Frequencies (rad/s) of the coefficient average: the half-power band (or ``band``) of every mode, joined."""
    if not isinstance(band, str):
        return np.linspace(2 * math.pi * band[0], 2 * math.pi * band[1], points)
    parts = []
    for fn, zeta in zip(uls.fn_hz, uls.zeta, strict=True):
        lo, hi = band_limits(2 * math.pi * fn, float(zeta), band)
        parts.append(np.linspace(lo, hi, points))
    return np.sort(np.concatenate(parts))


def element_spectra(
    uls: ULSModes, w: np.ndarray, columns: Sequence[int], connectivity: np.ndarray, forces: Sequence[tuple[int, int]]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Coefficient spectra ``theta_e(w)`` of the extended inputs ``columns`` and their estimates and qualities.

    By reciprocity the row ``d`` of ``H b_e`` is ``b_e^T`` times the force
    column of DOF ``d``, so ``theta_e(w) = H_E[d, e] / (b_e^T H_E[:, f_d])``
    uses the identified model's own columns (no realisation); several driven
    DOFs are combined by least squares.

    Parameters
    ----------
    uls
        The identified model.
    w
        Frequencies (rad/s).
    columns
        The extended inputs of the elements (fed as ``-g_e``).
    connectivity
        ``(n, E)``: ``b_e`` of each.
    forces
        ``(input column, DOF from 0)`` of every force input.

    Returns
    -------
    spectra
        ``(len(w), E)`` complex.
    estimates
        Real part of the weighted least-squares average over ``w``.
    quality
        ``E[Re/Im]`` over ``w``.
    """
    he = extended_frf(uls, w)
    num = np.zeros((len(w), len(columns)), dtype=complex)
    den = np.zeros((len(w), len(columns)))
    for j, col in enumerate(columns):
        for f_col, d in forces:
            h = he[:, :, f_col] @ connectivity[:, j]  # (H b_e)[d] by reciprocity
            num[:, j] += h.conj() * he[:, d, col]
            den[:, j] += np.abs(h) ** 2
    spectra = num / den
    estimates = np.real(num.sum(axis=0) / den.sum(axis=0))
    quality = np.mean(np.abs(spectra.real) / np.maximum(np.abs(spectra.imag), 1e-300), axis=0)
    return spectra, estimates, quality
