"""Errors-in-variables correction for extended inputs built from a noisy output.

The extended inputs ``g_j(z, v)`` of NSI are computed from the measured
displacement, so they carry its measurement noise, correlated with the noise
of the output channel; the near-collinearity of ``z, z^2, z^3`` magnifies it in
the directions that separate them (NOTES.md: "with few block rows the bias is
large"). Measured on paper-numerical at 2 % noise (prototype, 100 block rows,
median of seeds 0-4): without this correction c_v is 2.5 % off and the mass
0.6 %, with it 0.8 % and 0.2 %.

The noise ``e`` (white, variance ``sigma^2``) reaches each base channel ``a``
through known linear operators and, to first order, the Jacobian of the basis
function::

    nu_a(t) = dg_a/dz(t) (l * e)(t) + dg_a/dv(t) (d * e)(t)

where ``l`` and ``d`` are the impulse responses of the de-noising low-pass and
of the differentiator that produced the velocity (the 2-tap interval mean is
folded into both), and the output channel carries ``e`` itself. The expected
noise contribution ``sigma^2 mean_t(J_a J_b) xcorr(k_a, k_b)(lag)`` is
subtracted from the data Gram (input-input and input-output blocks, lags up to
``max_lag``) and from the normal equations of the B step. The white output
block is left to PO-MOESP (subtracting it makes the Gram lose its past-output
directions: the Cholesky fails). The linearisation error is about 1e-4 on the
paper's example.

Non-smooth terms (``sign(v)``, ``sign(z)``, Coulomb-type factors) have no
Jacobian in the variable they jump in: that part is left out (set to zero), so
the correction is first order for smooth terms only.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

__all__ = [
    "NoiseModel",
    "NoiseSource",
    "impulse_response",
    "build_noise_model",
    "jacobian_moments",
    "noise_xcorr",
    "subtract_noise",
]


@dataclass(frozen=True)
class NoiseModel:
    """First-order model of the measurement noise carried by each base channel.

    Channel ``a`` carries ``sum_i J[t, a, i] n_i(t)`` where the paths ``i`` =
    (de-noised z, reconstructed v, output) carry filtered white noise.

    Attributes
    ----------
    var
        Overall factor of the covariance (1 when ``xcorr`` already holds the
        variances, as :func:`build_noise_model` makes it).
    moments
        ``moments[a, b, i, j] = mean_t J_ai J_bj``.
    xcorr
        ``xcorr[i, j, L + l] = E[n_i(t) n_j(t + l)] / var`` for ``|l| <= L``
        (for one source with kernels ``k_i``: ``sum_r k_i(r) k_j(r + l)``).
    """

    var: float
    moments: np.ndarray
    xcorr: np.ndarray

    @property
    def max_lag(self) -> int:
        """Largest lag ``L`` modelled."""
        return (self.xcorr.shape[-1] - 1) // 2

    def lag_covariance(self, exclude_output: int | None = None) -> np.ndarray:
        """``C[L + l, a, b] = E[nu_a(t) nu_b(t + l)]``, optionally without the white output block."""
        mom = self.moments.copy()
        if exclude_output is not None:
            mom[exclude_output, exclude_output, 2, 2] = 0.0
        return self.var * np.einsum("abij,ijl->lab", mom, self.xcorr)

    def transformed(self, t: np.ndarray) -> NoiseModel:
        """The model of the channels ``T w``."""
        return NoiseModel(self.var, np.einsum("xa,abij,yb->xyij", t, self.moments, t), self.xcorr)


def impulse_response(op: Callable[[np.ndarray], np.ndarray], half: int) -> np.ndarray:
    """Impulse response ``k(-half..half)`` of a linear, time-invariant operator on signals.

    The impulse sits in the middle of a zero signal of ``6 half + 1`` samples,
    so the operator's end treatment does not reach it.
    """
    x = np.zeros(6 * half + 1)
    x[3 * half] = 1.0
    return np.asarray(op(x))[2 * half : 4 * half + 1]


def _xcorr(kernels: list[np.ndarray], max_lag: int) -> np.ndarray:
    ns, n = len(kernels), len(kernels[0])
    out = np.zeros((ns, ns, 2 * max_lag + 1))
    for i in range(ns):
        for j in range(ns):
            full = np.correlate(kernels[j], kernels[i], mode="full")  # index n-1+l: sum_r k_i(r) k_j(r+l)
            out[i, j] = full[n - 1 - max_lag : n + max_lag]
    return out


@dataclass(frozen=True)
class NoiseSource:
    """One white measurement noise and the linear operators that carry it into the basis.

    Attributes
    ----------
    name
        The channel it corrupts (``"z"`` or ``"a"``), for diagnostics.
    var
        Its variance (in the channel's units squared).
    kernel_z, kernel_v
        Centred impulse responses (odd length) from the noise to the
        displacement and the velocity used in the basis functions
        (``kernel_v`` is ``None`` when the velocity does not carry it).
    output
        The output channel (the measured displacement) carries it as it is.
    """

    name: str
    var: float
    kernel_z: np.ndarray
    kernel_v: np.ndarray | None
    output: bool


def noise_xcorr(sources: list[NoiseSource], max_lag: int) -> np.ndarray:
    """``xcorr[i, j, L + l]`` of the paths (displacement, velocity, output), summed over the sources.

    Independent noises add: each contributes ``var * xcorr(kernels)`` with the
    kernels folded with the 2-tap interval mean.
    """
    xc = np.zeros((3, 3, 2 * max_lag + 1))
    for src in sources:
        half = (len(src.kernel_z) - 1) // 2
        avg = np.zeros(2 * half + 1)
        avg[half], avg[half - 1] = 0.5, 0.5  # the interval mean: nu(k) ~ (n(k) + n(k+1)) / 2
        kz = np.convolve(src.kernel_z, avg, mode="same")
        kv = np.convolve(src.kernel_v, avg, mode="same") if src.kernel_v is not None else np.zeros_like(kz)
        ky = np.zeros_like(kz)
        if src.output:
            ky[half] = 1.0
        xc += src.var * _xcorr([kz, kv, ky], max_lag)
    return xc


def jacobian_moments(jtj: np.ndarray, jsum: np.ndarray, n: int, scales: np.ndarray) -> np.ndarray:
    """``moments[a, b, i, j] = mean_t J_ai J_bj`` of the base channels from sums over the samples.

    Parameters
    ----------
    jtj
        ``sum_t J(t) J(t)^T`` of the stacked Jacobian columns ``[dg_1/dz,
        dg_1/dv, ..., dg_q/dz, dg_q/dv]`` of the input channels ``u_1..u_q``
        (``2 q x 2 q``).
    jsum
        ``sum_t J(t)`` (``2 q``).
    n
        Number of samples.
    scales
        Scales of the base channels ``[f, u_1, ..., u_q, y]``.
    """
    q = len(jsum) // 2
    nch = q + 2
    mom = np.zeros((nch, nch, 3, 3))
    # input channels a = 1..q carry the paths 0 (z) and 1 (v); the output (last) carries path 2 alone
    mom[1 : q + 1, 1 : q + 1, :2, :2] = (jtj / n).reshape(q, 2, q, 2).transpose(0, 2, 1, 3)
    mom[1 : q + 1, -1, :2, 2] = (jsum / n).reshape(q, 2)
    mom[-1, 1 : q + 1, 2, :2] = (jsum / n).reshape(q, 2)
    mom[-1, -1, 2, 2] = 1.0
    return mom / (scales[:, None, None, None] * scales[None, :, None, None])


def build_noise_model(
    sources: list[NoiseSource],
    jacobians: list[tuple[np.ndarray, np.ndarray]],
    scales: np.ndarray,
    max_lag: int = 128,
) -> NoiseModel:
    """Noise model of the base channels ``[f, u_1, ..., u_q, y]`` (divided by ``scales``).

    Independent noises add: the lag covariance of the three paths
    (displacement, velocity, output) is the sum over the sources of
    ``var * xcorr(kernels)``. The model's ``var`` is then 1.

    Parameters
    ----------
    sources
        The white noises (measured displacement, measured acceleration...).
    jacobians
        ``(dg/dz, dg/dv)`` at the samples for each input channel ``u_a``.
    scales
        Channel scales (the base channels are divided by them).
    max_lag
        Largest lag of the correction.
    """
    n = len(jacobians[0][0]) if jacobians else 1
    jac = np.column_stack([col for pair in jacobians for col in pair]) if jacobians else np.zeros((n, 0))
    mom = jacobian_moments(jac.T @ jac, jac.sum(axis=0), n, scales)
    return NoiseModel(1.0, mom, noise_xcorr(sources, max_lag))


def subtract_noise(gram: np.ndarray, model: NoiseModel, output: int) -> np.ndarray:
    """The data Gram without the expected noise contribution (white output block kept).

    Parameters
    ----------
    gram
        Base Gram, shape ``(s, c, s, c)``.
    model
        Noise model of the same channels.
    output
        Index of the output channel.
    """
    cov = model.lag_covariance(exclude_output=output)
    s = gram.shape[0]
    lmax = min(model.max_lag, s - 1)
    big, c = model.max_lag, gram.shape[1]
    cov_t = np.ascontiguousarray(cov.transpose(1, 0, 2)).reshape(c, -1)  # [a, (L + lag) c + b]
    out = np.array(gram, dtype=float, order="C")
    rows = out.reshape(s, c, s * c)
    for p in range(s):  # block row p: out[p, :, q, :] -= cov[L + q - p] for |q - p| <= lmax
        q0, q1 = max(0, p - lmax), min(s, p + lmax + 1)
        rows[p, :, q0 * c : q1 * c] -= cov_t[:, (big + q0 - p) * c : (big + q1 - p) * c]
    return out
