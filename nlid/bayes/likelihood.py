"""The likelihood of the coefficients: the restoring-force equation error, made honest.

The data enter through the force balance of Eq. 25 as
:func:`nlid.estimation.balance.regression_data` forms it (filtered in the equation band
``fc`` when a channel is estimated, edges trimmed)::

    y_k = f_k - m a_k = sum_i theta_i g_i(z_k, v_k) + e_k,   k = 1..N.

Raw likelihood
    Gaussian equation errors of unknown scale ``sigma``, marginalised with
    the prior ``p(sigma) ~ 1/sigma``: ``log p(y | theta) = -(n/2) log RSS(theta)``
    with ``RSS(theta) = y^T y - 2 theta^T G^T y + theta^T G^T G theta``. It needs
    only the sufficient statistics ``G^T G``, ``G^T y``, ``y^T y`` and ``N``
    (:class:`SufficientStatistics`), so one evaluation costs ``O(p^2)``
    whatever the record length.

Why the raw likelihood is wrong with ``n = N``
    It assumes ``N`` independent errors and exact regressors. After the
    zero-phase low-pass the residuals are correlated over about
    ``fs / (2 fc)`` samples (measured: 22 on ``paper-numerical``, 11 on
    ``paper-experimental``), and the regressors built from the noisy ``z``
    carry errors-in-variables bias: on ``paper-experimental`` with 2 % noise
    on ``z`` and ``a``, the 90 % intervals of the raw likelihood contain the
    true friction coefficients in 0 % of replicates.

Adjustments (:func:`build_likelihood`)
    1. *Degrees of freedom.* ``n`` is the residual's effective sample size
       ``nu = N gamma_e(0) / sum_l gamma_e(l)`` (its integrated
       autocorrelation time ``tau_e`` divides ``N``).
    2. *Location.* The least-squares estimate ``theta_hat`` is replaced by the
       bias-corrected ``theta_c`` that solves ``theta_hat = J theta_c + d``
       (:mod:`nlid.bayes.bias`: indirect inference by simulation).
    3. *Curvature.* The sampling covariance of ``theta_hat`` is the sandwich
       ``V = H^-1 Omega H^-1`` with ``H = G^T G`` and ``Omega`` the long-run
       covariance of the scores ``g_k e_k`` (overlapping batch means over
       blocks of ``50 tau_s`` samples, ``tau_s`` the scores' integrated
       autocorrelation time; Newey & West 1987, Flegal & Jones 2010); the
       corrected estimate has ``V_c = J^-1 V J^-T + (1 + 1/pairs) S``, ``S``
       the spread of the correction over simulated trajectories and noise.
       Following the "open-faced sandwich" adjustment of Chandler & Bate
       (2007), the raw likelihood is evaluated at
       ``phi(theta) = theta_hat + C (theta - theta_c)`` with ``C`` chosen so
       that its curvature at ``theta_c`` is ``-V_c^-1``.

    The adjusted log-likelihood ``-(nu/2) log RSS(phi(theta))`` equals, up to
    a constant, ``-(nu/2) log(1 + (theta - theta_c)^T V_c^-1 (theta - theta_c) / nu)``:
    a multivariate Student-t of ``nu`` degrees of freedom centred on the
    bias-corrected estimate with the sandwich covariance. It is computed in
    the first form, from the sufficient statistics.

Assumptions (stated in docs/posterior.md): the model's terms are the true
ones (no missing physics); the residual is stationary and its correlation
dies out within a block; the measurement noise on the displacement is white
(see :mod:`nlid.bayes.bias`); the mass (given or estimated) is exact.
Coefficients that are not sampled are integrated out (:meth:`Likelihood.reduced`)
or held at given values (:meth:`Likelihood.conditional`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..data.record import Record
from ..errors import DataError, InputError
from ..estimation.balance import RegressionData, regression_data
from ..model.terms import Model
from .bias import indirect_inference

__all__ = [
    "SufficientStatistics",
    "Likelihood",
    "DegenerateParametersError",
    "build_likelihood",
    "long_run_covariance",
    "block_length",
    "check_identifiable",
    "sandwich",
]

#: Blocks of the long-run covariance span this many integrated autocorrelation
#: times of the scores.
BLOCK_TAUS = 50.0
#: A sampled parameter set whose normalised information matrix has a larger
#: condition number than this is refused as degenerate (collinear).
MAX_CONDITION = 1e10
#: The whole model is refused beyond this (the normal equations lose every digit).
FULL_MAX_CONDITION = 1e14


class DegenerateParametersError(InputError):
    """The sampled coefficients cannot be told apart by the data (collinear regressors)."""


@dataclass(frozen=True)
class SufficientStatistics:
    """``G^T G``, ``G^T y``, ``y^T y`` and ``N`` of the force balance ``y = G theta + e``.

    Attributes
    ----------
    gtg, gty, yty, n
        The statistics (``y = f - m a``).
    """

    gtg: np.ndarray
    gty: np.ndarray
    yty: float
    n: int

    @classmethod
    def from_arrays(cls, G: np.ndarray, y: np.ndarray) -> SufficientStatistics:
        """Accumulate the statistics of a regressor matrix and a target."""
        G = np.asarray(G, dtype=float)
        y = np.asarray(y, dtype=float)
        return cls(G.T @ G, G.T @ y, float(y @ y), int(y.size))

    @property
    def scale(self) -> np.ndarray:
        """RMS of each regressor (columns are scaled by it before solving)."""
        s = np.sqrt(np.diag(self.gtg) / self.n)
        return np.where(s > 0, s, 1.0)

    def solve(self) -> np.ndarray:
        """The least-squares estimate ``(G^T G)^-1 G^T y``."""
        s = self.scale
        return np.linalg.solve(self.gtg / np.outer(s, s), self.gty / s) / s

    def rss(self, theta: np.ndarray) -> np.ndarray:
        """Residual sum of squares at ``theta`` (shape ``(p,)`` or ``(W, p)``)."""
        theta = np.asarray(theta, dtype=float)
        return self.yty - 2.0 * theta @ self.gty + np.einsum("...i,ij,...j->...", theta, self.gtg, theta)


def block_length(series: np.ndarray, taus: float = BLOCK_TAUS) -> tuple[int, float]:
    """Batch length for the long-run covariance of ``series`` (shape ``(N,)`` or ``(N, k)``).

    ``ceil(taus * tau)`` with ``tau`` the largest integrated autocorrelation
    time of the columns (:func:`integrated_times`), kept between 16 samples
    and a tenth of the record. Returns the length and ``tau``.
    """
    x = np.asarray(series, dtype=float)
    x = x.reshape(x.shape[0], -1)
    live = x[:, np.std(x, axis=0) > 0]
    tau = 1.0
    if live.size:
        tau = float(np.max(integrated_times(live)))
    return int(min(max(16, np.ceil(taus * tau)), max(16, x.shape[0] // 10))), tau


def integrated_times(x: np.ndarray, c: float = 5.0) -> np.ndarray:
    """Integrated autocorrelation time of each column of ``x`` (shape ``(N, k)``), in samples.

    :func:`emcee.autocorr.integrated_time` (``has_walkers=False``, ``tol=0``): the normalised autocorrelation
    from the FFT of the centred series zero-padded to twice the next power of two, ``tau(M) = 2 sum_{l<=M}
    rho(l) - 1``, and Sokal's window, the smallest ``M >= c tau(M)``. The same estimator with real transforms
    (``scipy.fft.rfft``) instead of emcee's complex ones: about three times faster on the posterior's scores
    (61 440 samples, 9 columns), equal to emcee's to rounding.
    """
    from scipy import fft as sp_fft

    x = np.asarray(x, dtype=float)
    n = x.shape[0]
    size = 2 * (1 << max(0, (n - 1).bit_length()))  # emcee: 2 * next_pow_two(n)
    out = np.empty(x.shape[1])
    for j in range(x.shape[1]):  # one column at a time: a long record's padded transforms are large
        col = x[:, j] - np.mean(x[:, j])
        spectrum = sp_fft.rfft(col, size)
        acf = sp_fft.irfft(spectrum.real**2 + spectrum.imag**2, size)[:n]
        acf /= acf[0]
        taus = 2.0 * np.cumsum(acf) - 1.0
        inside = np.arange(n) < c * taus
        out[j] = taus[int(np.argmin(inside)) if np.any(inside) else n - 1]
    return out


def long_run_covariance(scores: np.ndarray, block: int) -> np.ndarray:
    """Long-run covariance ``sum_l Cov(s_k, s_{k+l})`` by overlapping batch means.

    Parameters
    ----------
    scores
        Zero-mean series, shape ``(N, k)``.
    block
        Batch length (samples).

    Returns
    -------
    numpy.ndarray
        Shape ``(k, k)``; ``N`` times it is the covariance of the sum of the
        scores. Costs ``O(N k^2)`` time and ``O(N k)`` memory.
    """
    s = np.asarray(scores, dtype=float)
    s = s.reshape(s.shape[0], -1)
    n = s.shape[0]
    if not 1 <= block < n:
        raise InputError(f"block length must lie between 1 and the record length {n}, got {block}")
    csum = np.concatenate([np.zeros((1, s.shape[1])), np.cumsum(s, axis=0)])
    sums = csum[block:] - csum[:-block]
    return (sums.T @ sums) / (block * sums.shape[0])


def check_identifiable(information: np.ndarray, names: Sequence[str], max_condition: float = MAX_CONDITION) -> None:
    """Refuse a parameter set whose information (precision) matrix is (nearly) singular.

    Parameters
    ----------
    information
        ``G^T G`` or a posterior precision of the parameters, shape ``(k, k)``.
    names
        Their term names.
    max_condition
        Largest accepted condition number of the normalised matrix (unit
        diagonal); 1e10 means two coefficients whose regressors are
        correlated to within about 1e-10 of 1.

    Raises
    ------
    DegenerateParametersError
        Naming the terms of the degenerate combination.
    """
    info = np.asarray(information, dtype=float)
    d = np.diag(info)
    if np.any(~np.isfinite(info)) or np.any(d <= 0):
        bad = [names[i] for i in range(len(names)) if not (np.isfinite(d[i]) and d[i] > 0)]
        raise DegenerateParametersError(
            f"the data carry no information on {', '.join(bad)}: remove the term(s) or do not sample them"
        )
    norm = info / np.sqrt(np.outer(d, d))
    eigval, eigvec = np.linalg.eigh(0.5 * (norm + norm.T))
    if eigval[0] > eigval[-1] / max_condition:
        return
    weights = np.abs(eigvec[:, 0])
    involved = [names[i] for i in np.argsort(-weights) if weights[i] > 0.1 * weights.max()]
    pairs = [(abs(norm[i, j]), names[i], names[j]) for i in range(len(names)) for j in range(i)]
    rho, a, b = max(pairs) if pairs else (1.0, names[0], names[0])
    raise DegenerateParametersError(
        f"the sampled coefficients are degenerate: {', '.join(involved)} are (nearly) collinear on this record "
        f"(|correlation| of {a} and {b} = {rho:.10f}, condition number {eigval[-1] / max(eigval[0], 1e-300):.2g} "
        f"> {max_condition:.0e}); the data cannot tell them apart: sample fewer of them (params=) or remove one "
        "from the model"
    )


@dataclass(frozen=True)
class Likelihood:
    """The adjusted equation-error log-likelihood (see the module docstring).

    Call it on full coefficient vectors (model order), shape ``(p,)`` or
    ``(W, p)``.

    Attributes
    ----------
    names
        The model's term names.
    stats
        Sufficient statistics of the force balance.
    estimate
        Least-squares estimate ``theta_hat``.
    center
        Bias-corrected estimate ``theta_c`` (equal to ``estimate`` without
        correction): the likelihood's maximum.
    covariance
        ``V_c``: the likelihood's curvature is ``-V_c^-1`` at ``center``.
    dof
        Degrees of freedom ``nu`` (effective sample size of the residual).
    info
        Diagnostics (band, block length, autocorrelation times, noise levels).
    """

    names: tuple[str, ...]
    stats: SufficientStatistics
    estimate: np.ndarray
    center: np.ndarray
    covariance: np.ndarray
    dof: float
    info: dict[str, Any] = field(default_factory=dict)
    _transform: np.ndarray = field(init=False, repr=False, compare=False)
    _rss_min: float = field(init=False, repr=False, compare=False)
    _scale: np.ndarray = field(init=False, repr=False, compare=False)
    _gram: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        s = self.stats.scale
        corr_g = self.stats.gtg / np.outer(s, s)
        rss_min = float(self.stats.yty - self.estimate @ self.stats.gty)
        if not rss_min > 0:
            raise DataError("the force balance is fitted exactly (zero residual): no noise scale to infer")
        # C = M^-1 A with M^T M = nu G^T G / rss_min and A^T A = V_c^-1 (both via Cholesky, columns scaled).
        sv = np.sqrt(np.diag(self.covariance))
        prec_v = np.linalg.inv(self.covariance / np.outer(sv, sv))
        L = np.linalg.cholesky(corr_g)
        K = np.linalg.cholesky(0.5 * (prec_v + prec_v.T))
        C = np.sqrt(rss_min / self.dof) * (np.linalg.solve(L.T, K.T) / s[:, None]) / sv[None, :]
        object.__setattr__(self, "_transform", C)
        object.__setattr__(self, "_rss_min", rss_min)
        object.__setattr__(self, "_scale", s)
        object.__setattr__(self, "_gram", corr_g)

    def __call__(self, theta: np.ndarray) -> np.ndarray:
        """Log-likelihood ``-(nu/2) log RSS(phi(theta))``, without its constant ``(nu/2) log RSS_min``.

        ``RSS(phi) = RSS_min + (phi - theta_hat)^T G^T G (phi - theta_hat)`` with
        ``RSS_min = y^T y - theta_hat^T G^T y``: the expanded form of
        :meth:`SufficientStatistics.rss`, free of its cancellation.
        """
        theta = np.asarray(theta, dtype=float)
        step = ((theta - self.center) @ self._transform.T) * self._scale
        quad = np.einsum("...i,ij,...j->...", step, self._gram, step)
        return -0.5 * self.dof * np.log1p(quad / self._rss_min)

    def reduced(self, keep: Sequence[int]) -> Likelihood:
        """The likelihood of some coefficients with the others integrated out.

        The raw likelihood is profiled over the other coefficients, which for
        a linear model is exact and equals integrating them out under a flat
        prior: its statistics are the Schur complement
        ``S = G_k^T G_k - G_k^T G_o (G_o^T G_o)^-1 G_o^T G_k`` with
        ``RSS(theta_k) = RSS_min + (theta_k - theta_hat_k)^T S (theta_k - theta_hat_k)``.
        The adjustment then uses the marginal block of the covariance, so the
        result is the marginal Student-t of the kept coefficients.

        Parameters
        ----------
        keep
            Indices of the coefficients to keep (model order).
        """
        idx = np.asarray(keep, dtype=int)
        rest = np.setdiff1d(np.arange(len(self.names)), idx)
        gtg = self.stats.gtg
        schur = gtg[np.ix_(idx, idx)]
        if rest.size:
            so = self.stats.scale[rest]
            g_oo = gtg[np.ix_(rest, rest)] / np.outer(so, so)
            g_ok = gtg[np.ix_(rest, idx)] / so[:, None]
            schur = schur - g_ok.T @ np.linalg.solve(g_oo, g_ok)
        schur = 0.5 * (schur + schur.T)
        est = self.estimate[idx]
        stats = SufficientStatistics(schur, schur @ est, float(self._rss_min + est @ schur @ est), self.stats.n)
        cov = self.covariance[np.ix_(idx, idx)]
        return Likelihood(
            tuple(self.names[i] for i in idx), stats, est, self.center[idx], cov, self.dof, dict(self.info)
        )

    def conditional(self, sampled: Sequence[int], fixed_values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Mean and covariance of the sampled coefficients with the others fixed (Gaussian limit)."""
        idx = np.asarray(sampled, dtype=int)
        rest = np.setdiff1d(np.arange(len(self.names)), idx)
        sv = np.sqrt(np.diag(self.covariance))
        prec = np.linalg.inv(self.covariance / np.outer(sv, sv)) / np.outer(sv, sv)
        p_ss = prec[np.ix_(idx, idx)]
        cov = np.linalg.inv(p_ss)
        mean = self.center[idx]
        if rest.size:
            shift = np.asarray(fixed_values, dtype=float)[rest] - self.center[rest]
            mean = mean - cov @ prec[np.ix_(idx, rest)] @ shift
        return mean, 0.5 * (cov + cov.T)


def build_likelihood(
    record: Record,
    model: Model,
    mass: float,
    *,
    cutoff: float | None = None,
    bias_correction: bool = True,
    pairs: int = 4,
    iterations: int = 3,
    noise: Mapping[str, float] | None = None,
    rng: np.random.Generator | None = None,
    data: RegressionData | None = None,
) -> Likelihood:
    """Form the adjusted equation-error likelihood of a record.

    Parameters
    ----------
    record, model
        The data and the model (``px(z)`` roots set when used).
    mass
        Mass in kg (given or identified).
    cutoff
        Equation band in Hz (default: :func:`nlid.signal.derivatives.suggest_cutoff`).
    bias_correction
        Correct the errors-in-variables bias by simulation
        (:func:`nlid.bayes.bias.simulate_bias`).
    pairs
        Antithetic noise pairs per step of the correction.
    iterations
        Fixed-point steps of the correction.
    noise
        Noise standard deviation on ``z`` (and ``v``) if known.
    rng
        Random generator of the correction.
    data
        A pre-computed force balance of the record.
    """
    if not (mass is not None and np.isfinite(mass) and mass > 0):
        raise InputError("the posterior needs the mass: give mass= (in kg) or use a method that estimates it")
    data = data if data is not None else regression_data(record, model, cutoff=cutoff)
    y = data.restoring_force(mass)
    stats, theta_hat, cov, dof, info = sandwich(data.G, y, model.names)
    info = {"samples": info.pop("samples"), "band_hz": data.filtered_at, **info, "bias_correction": bias_correction}
    center = theta_hat
    if bias_correction:
        center, cov, corr_info = indirect_inference(
            record, model, theta_hat, mass, data, cov, pairs=pairs, iterations=iterations, noise=noise, rng=rng
        )
        info["noise_sd"] = corr_info["noise_sd"]
        info["noise"] = corr_info["noise"]
        info["noise_level_moves"] = corr_info["noise_level_moves"]
        info["bias_pairs"] = corr_info["pairs"]
        info["bias_iterations"] = corr_info["iterations"]
        info["bias_substeps"] = corr_info["substeps"]
        info["bias"] = {n: float(x) for n, x in zip(model.names, theta_hat - center, strict=True)}
        # how far the correction moved each estimate, in standard deviations of the corrected estimate
        info["bias_shift_sd"] = {
            n: float(x) for n, x in zip(model.names, (center - theta_hat) / np.sqrt(np.diag(cov)), strict=True)
        }
    return Likelihood(tuple(model.names), stats, theta_hat, center, cov, dof, info)


def sandwich(
    G: np.ndarray, y: np.ndarray, names: Sequence[str], group: int = 1
) -> tuple[SufficientStatistics, np.ndarray, np.ndarray, float, dict[str, Any]]:
    """The least-squares estimate of ``y = G theta + e`` with its sandwich covariance and effective sample size.

    Steps 1 and 3 of the module docstring: the residual's effective sample
    size ``nu`` and ``V = H^-1 Omega H^-1`` by overlapping batch means of the
    scores.

    Parameters
    ----------
    G, y
        Regressors ``(R, p)`` and target ``(R,)``.
    names
        The ``p`` coefficient names (for the diagnostics).
    group
        Consecutive rows that belong to one instant (a structure's DOFs,
        interleaved sample by sample: :func:`nlid.estimation.structure_regression.linear_design`).
        Their scores are summed per instant and their residuals' long-run
        variances added before the batch means, so a batch never splits an
        instant. ``1`` for one DOF.

    Returns
    -------
    tuple
        ``(stats, theta_hat, V, nu, info)``.
    """
    stats = SufficientStatistics.from_arrays(G, y)
    s = stats.scale
    corr_g = stats.gtg / np.outer(s, s)
    check_identifiable(corr_g, names, max_condition=FULL_MAX_CONDITION)
    theta_hat = stats.solve()
    resid = y - G @ theta_hat
    scores = (G / s) * resid[:, None]
    if group == 1:
        block, tau_scores = block_length(scores)
        omega = long_run_covariance(scores, block) * stats.n
        tau_resid = float(long_run_covariance(resid[:, None], block)[0, 0] / np.mean(resid**2))
    else:
        if resid.size % group:
            raise InputError(f"{resid.size} rows do not split into instants of {group}")
        instants = resid.size // group
        scores = scores.reshape(instants, group, -1).sum(axis=1)
        block, tau_scores = block_length(scores)
        omega = long_run_covariance(scores, block) * instants
        per_instant = resid.reshape(instants, group)
        tau_resid = float(np.trace(long_run_covariance(per_instant, block)) / np.sum(np.mean(per_instant**2, axis=0)))
    h_inv = np.linalg.inv(corr_g)
    cov = (h_inv @ omega @ h_inv) / np.outer(s, s)
    cov = 0.5 * (cov + cov.T)
    tau_resid = max(tau_resid, 1.0)
    dof = stats.n / tau_resid
    info: dict[str, Any] = {
        "samples": stats.n,
        "block_samples": block,
        "tau_scores_samples": tau_scores,
        "tau_residual_samples": tau_resid,
        "dof": dof,
        "residual_rms": float(np.sqrt(np.mean(resid**2))),
        "sandwich_over_iid_sd": {
            n: float(x)
            for n, x in zip(
                names,
                np.sqrt(np.diag(cov) / (np.diag(np.linalg.inv(corr_g)) / s**2 * float(resid @ resid) / stats.n)),
                strict=True,
            )
        },
    }
    return stats, theta_hat, cov, dof, info
