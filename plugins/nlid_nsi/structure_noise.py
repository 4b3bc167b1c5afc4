"""Errors-in-variables correction of a structure's data Gram (the MIMO counterpart of :mod:`nlid_nsi.noise`).

The extended inputs ``-g_e(x_e, x_e')`` are computed from the measured
displacements, so they carry their noise. Measured on ``3dof-cubic`` (2 % noise
on z, seed 0): with noise-free basis functions and noisy outputs the cubic
coefficient is 0.04 % off; with noisy basis functions 1.9 %, of which 1.4 %
come from the subspace step (the damping ratio of the first mode +3.2 %) and
0.3 % from the B step.

Each DOF ``k`` has a white displacement noise (variance from the floor of its
spectrum, :func:`noise_variance`) that reaches the channels through three
paths: the de-noised ``z_k`` (the low-pass), the velocity ``v_k`` (the
differentiator, when ``v`` comes from ``z``) and the output ``z_k`` itself; a
measured velocity has its own noise and path. To first order channel ``a``
carries ``sum_k b_a[k] (dg_a/dx nu_z,k + dg_a/dx' nu_v,k)``; the expected
contribution ``mean_t(J_a J_b) xcorr(paths)`` is subtracted from the
input-input and input-output blocks of the Gram (:func:`nlid_nsi.noise.subtract_noise`;
the white output blocks are left to PO-MOESP), then the Gram is projected onto
the positive semi-definite matrices, and from the normal equations of the B
step (:func:`nlid_nsi.mimo.estimate_b`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy import signal

from nlid.plugin import derivatives

from .basis import Basis
from .noise import NoiseModel, _xcorr, impulse_response

__all__ = ["noise_variance", "noise_variances", "noise_paths", "structure_noise_model"]


def noise_variance(x: np.ndarray, fs: float) -> float:
    """Variance of a white noise on ``x`` from its spectrum's floor (the mean density over 0.35-0.45 fs).

    The first 65 536 samples are enough for a floor to about 1 % (Welch, 1 024-sample segments).
    """
    f, p = signal.welch(np.asarray(x[:65536], dtype=float), fs, nperseg=min(len(x), 1024))
    lo, hi = derivatives.NOISE_BAND
    band = (f >= lo * fs) & (f <= hi * fs)
    return float(np.mean(p[band]) * fs / 2.0)


def _fold(kernel: np.ndarray, sharpen: np.ndarray | None = None) -> np.ndarray:
    """The kernel followed by the 2-tap interval mean ``(n(k) + n(k+1)) / 2`` (and the 3-tap ``sharpen``, centred)."""
    half = (len(kernel) - 1) // 2
    avg = np.zeros(2 * half + 1)
    avg[half], avg[half - 1] = 0.5, 0.5
    out = np.convolve(kernel, avg, mode="same")
    if sharpen is not None:
        out = np.convolve(out, sharpen, mode="same")
    return out


def noise_variances(record: Any, motion: Any) -> tuple[list[float], list[float]]:
    """:func:`noise_variance` of every DOF's measured ``z`` and (when the motion uses it) ``v``."""
    fs = record.fs
    z = np.asarray(record.z, dtype=float)
    var_z = [noise_variance(z[:, k], fs) for k in range(record.n_dofs)]
    if not motion.velocity.startswith("measured"):
        return var_z, []
    return var_z, [noise_variance(np.asarray(record.v[:, k], dtype=float), fs) for k in range(record.n_dofs)]


def noise_paths(
    record: Any,
    motion: Any,
    max_lag: int,
    sharpen: np.ndarray | None = None,
    variances: tuple[list[float], list[float]] | None = None,
) -> np.ndarray:
    """``xcorr[i, j, L + l]`` of the noise paths (per DOF: de-noised z, velocity, output), variances included.

    It depends on the record and the de-noising (:class:`nlid_nsi.structure.Motion`) alone, not on the
    extended inputs: one array serves every identification on the same motion (nsi-shift's references).
    ``variances``: :func:`noise_variances` of the record when already computed (they do not depend on
    the de-noising). Other arguments as for :func:`structure_noise_model`.
    """
    n, fs = record.n_dofs, record.fs
    var_z, var_v = noise_variances(record, motion) if variances is None else variances
    xcorr = np.zeros((3 * n, 3 * n, 2 * max_lag + 1))
    measured_v = motion.velocity.startswith("measured")
    for k in range(n):
        fc = motion.cutoffs_hz[k]
        kz = _fold(impulse_response(lambda x, fc=fc: derivatives.lowpass(x, fs, fc), max_lag), sharpen)
        ky = np.zeros(2 * max_lag + 1)
        ky[max_lag] = 1.0
        if measured_v:
            kv = np.zeros_like(kz)
        else:
            kv = _fold(
                impulse_response(lambda x, fc=fc: derivatives.differentiate(x, fs, order=1, cutoff=fc)[0], max_lag),
                sharpen,
            )
        sl = slice(3 * k, 3 * k + 3)
        xcorr[sl, sl] += var_z[k] * _xcorr([kz, kv, ky], max_lag)
        if measured_v:
            kvm = _fold(impulse_response(lambda x, fc=fc: derivatives.lowpass(x, fs, fc), max_lag), sharpen)
            zero = np.zeros_like(kvm)
            xcorr[sl, sl] += var_v[k] * _xcorr([zero, kvm, zero], max_lag)
    return xcorr


def structure_noise_model(
    record: Any,
    motion: Any,
    columns: list[tuple[str, Any]],
    scales: np.ndarray,
    n_force: int,
    extra: tuple[int, ...],
    max_lag: int,
    sharpen: np.ndarray | None = None,
    paths: np.ndarray | None = None,
) -> NoiseModel:
    """The noise model of the base channels ``[f_d..., <z_d>..., -g_e..., z_1..z_n]`` (normalised).

    Parameters
    ----------
    record, motion
        The record and the de-noised motion (:class:`nlid_nsi.structure.Motion`) the basis is evaluated on.
    columns
        The extended inputs ``(name, (func, b))``.
    scales
        Scales of the base channels.
    n_force
        Number of force channels (noise-free).
    extra
        The driven DOFs whose de-noised displacement is a channel (nsi-ip), in order.
    max_lag
        Largest lag (samples) of the correction.
    sharpen
        The 3-tap filter applied to the interval means of the state-dependent
        channels (:func:`nlid_nsi.structure.sharpen`), or ``None``; folded into
        their noise paths like the interval mean (the Jacobian taken as constant over 3 samples).
    paths
        :func:`noise_paths` of the same record, motion, ``max_lag`` and ``sharpen`` when already computed.
    """
    n = record.n_dofs
    n_paths = 3 * n  # per DOF: de-noised z, velocity, output
    xcorr = noise_paths(record, motion, max_lag, sharpen) if paths is None else paths
    c = len(scales)
    # sensitivity of each channel to each path, per sample: J[t, a, path]
    sens: list[tuple[int, int, np.ndarray | float]] = []  # (channel, path, values)
    for j, d in enumerate(extra):
        sens.append((n_force + j, 3 * (d - 1), 1.0))
    first = n_force + len(extra)
    for j, (name, (func, b)) in enumerate(columns):
        x, xd = motion.z @ b, motion.v @ b
        gz, gv = Basis(name, func).jacobian(x, xd)
        for k in np.flatnonzero(b):
            sens.append((first + j, 3 * k, -b[k] * gz))  # the channel is -g
            sens.append((first + j, 3 * k + 1, -b[k] * gv))
    outputs = c - n
    mom = np.zeros((c, c, n_paths, n_paths))
    for a, i, ja in sens:
        for b_, jpath, jb in sens:
            mom[a, b_, i, jpath] += float(np.mean(np.asarray(ja) * np.asarray(jb)))
        for k in range(n):
            value = float(np.mean(np.asarray(ja) * np.ones(1)))
            mom[a, outputs + k, i, 3 * k + 2] += value
            mom[outputs + k, a, 3 * k + 2, i] += value
    # the outputs' own white blocks are left to PO-MOESP (mom[y, y] stays 0)
    mom /= scales[:, None, None, None] * scales[None, :, None, None]
    return NoiseModel(1.0, mom, xcorr)
