"""The base channels of one NSI identification and their noise model.

The base channels are ``[f, <z>, -<g_1>, ..., -<g_p>, y]`` where ``<.>`` is the
mean over each sample interval (:mod:`nlid_nsi.intersample`), ``f`` the
force's interval mean, ``<z>`` present only for nsi-ip (the virtual
perturbation ``fbar = f + k~1 <z>`` of Eq. 13 is then a linear map of the base
channels) and ``y`` the measured displacement (possibly shifted, Sec. 3.1).
Every channel is centred (the constant of the static balance, e.g. ``m g``,
disappears with the means and comes back from the static balance, see
:func:`static_constant`) and scaled to unit variance (the channels differ by
10^7 between f and z^3; NOTES.md "Scale"); the scaling is undone on B and C.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .basis import Basis
from .intersample import BLOCK, interval_means, trapezoid_mean
from .noise import NoiseModel, jacobian_moments, noise_xcorr
from .reconstruction import Reconstruction
from .subspace import PerturbedMOESP

__all__ = ["Channels", "prepare_channels", "perturbation_map", "perturbation_subspace", "static_constant"]


@dataclass
class Channels:
    """Centred, scaled base channels.

    Attributes
    ----------
    base
        ``(N, c)`` array ``[f, (<z>), -<g_1>.., y]`` (column-major: one
        contiguous column per channel); ``None`` once the samples
        are no longer needed (nsi-ip drops pass 1's while pass 2 runs).
    means, scales
        Means removed and scales divided out.
    names
        Channel names.
    has_z
        Whether ``<z>`` is a channel (nsi-ip).
    noise
        Noise model (errors-in-variables correction) or ``None``.
    """

    base: np.ndarray | None
    means: np.ndarray
    scales: np.ndarray
    names: list[str]
    has_z: bool
    noise: NoiseModel | None

    @property
    def n_basis(self) -> int:
        """Number of basis-function channels."""
        return len(self.scales) - (3 if self.has_z else 2)


def prepare_channels(
    z: np.ndarray,
    v: np.ndarray,
    f_held: np.ndarray,
    dt: float,
    basis: tuple[Basis, ...],
    shift: float = 0.0,
    rec: Reconstruction | None = None,
    with_z: bool = True,
    noise_model: bool = True,
    max_lag: int = 128,
    intersample: str = "gauss",
    sign_calibration: bool = True,
) -> Channels:
    """Build the base channels (see the module docstring).

    Parameters
    ----------
    z, v
        Measured displacement and the velocity estimate.
    f_held
        The force's interval mean.
    dt
        Sampling interval.
    basis
        The extended inputs (functions of ``x = z - shift`` and ``v``).
    shift
        Zero reference (nsi-shift); 0 for nsi-ip.
    rec
        Reconstructed ``z``, ``v`` (second pass); ``None``: raw samples, for
        which the trapezoid interval mean is used (noisy samples are no basis
        for a Hermite interpolant).
    with_z
        Include the ``<z>`` channel (nsi-ip).
    noise_model
        Build the errors-in-variables noise model (needs ``rec``).
    max_lag
        Largest lag of the noise correction.
    intersample
        ``"gauss"`` (the method), ``"trapezoid"`` or ``"zoh"`` (for studies).
    sign_calibration
        Replace ``sign(v)`` by its expectation given the noisy velocity,
        ``erf(v / (sqrt(2) sigma_v))``, in terms that jump in v (regression
        calibration; needs ``rec`` with a velocity derived from z).
    """
    zz = (rec.z if rec is not None else np.asarray(z, dtype=float)) - shift
    vv = np.asarray(rec.v if rec is not None else v, dtype=float)
    if rec is None and intersample == "gauss":
        intersample = "trapezoid"
    if intersample not in ("gauss", "trapezoid", "zoh"):
        raise ValueError(f"unknown intersample treatment {intersample!r}")
    n = len(zz)
    c = len(basis) + (3 if with_z else 2)
    off = 2 if with_z else 1
    build_noise = noise_model and rec is not None and rec.has_noise
    sigma_v = 0.0
    if sign_calibration and rec is not None:
        sigma_v = float(np.sqrt(rec.velocity_noise_var))
    funcs = [_identity] if with_z else []
    funcs += [_calibrated(b.func, sigma_v) if b.jumps_in_v and sigma_v > 0 else b.func for b in basis]
    base = np.empty((n, c), order="F")  # one contiguous column per channel
    base[:, 0] = f_held
    inner = base[:, 1 : c - 1]
    signs = [1.0] * (off - 1) + [-1.0] * len(basis)  # the extended inputs are -g_j (Eq. 16)
    if intersample == "gauss":
        interval_means(funcs, zz, vv, dt, out=inner, signs=signs)
    else:
        for r0 in range(0, n, BLOCK):
            r1 = min(r0 + BLOCK, n)
            stop = min(r1 + 1, n)  # the trapezoid needs the next sample
            for j, func in enumerate(funcs):
                values = np.asarray(func(zz[r0:stop], vv[r0:stop]), dtype=float)
                if intersample == "trapezoid":
                    values = trapezoid_mean(values)
                inner[r0:r1, j] = signs[j] * values[: r1 - r0]
    base[:, c - 1] = np.asarray(z, dtype=float) - shift
    means = base.mean(axis=0)
    base -= means
    scales = np.sqrt(np.array([base[:, j] @ base[:, j] for j in range(c)]) / n)
    if np.any(scales == 0):
        names = ["f"] + (["z"] if with_z else []) + [b.name for b in basis] + ["y"]
        flat = [names[i] for i in np.flatnonzero(scales == 0)]
        raise ValueError(f"channel(s) {', '.join(flat)} are constant on this record")
    base /= scales
    noise = None
    if build_noise:
        jtj, jsum = _jacobian_sums(basis, zz, vv, with_z)
        mom = jacobian_moments(jtj, jsum, n, scales)
        noise = NoiseModel(1.0, mom, noise_xcorr(list(rec.sources), max_lag))
    names = ["f"] + (["z"] if with_z else []) + [b.name for b in basis] + ["y"]
    return Channels(base, means, scales, names, with_z, noise)


def _identity(z: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The ``<z>`` channel's function."""
    return z


def _jacobian_sums(
    basis: tuple[Basis, ...], z: np.ndarray, v: np.ndarray, with_z: bool
) -> tuple[np.ndarray, np.ndarray]:
    """``sum_t J J^T`` and ``sum_t J`` of the input channels' Jacobians, one block at a time.

    ``J(t) = [d<u_1>/dz, d<u_1>/dv, ...]`` at the samples: ``(1, 0)`` for
    ``<z>``, ``-(dg/dz, dg/dv)`` for the extended input ``-g`` (central
    differences, :meth:`nlid_nsi.basis.Basis.jacobian`, with steps from the
    whole record).
    """
    hz = 1e-6 * (float(np.std(z)) + 1e-300)
    hv = 1e-6 * (float(np.std(v)) + 1e-300)
    q = len(basis) + (1 if with_z else 0)
    jtj = np.zeros((2 * q, 2 * q))
    jsum = np.zeros(2 * q)
    for r0 in range(0, len(z), BLOCK):
        zb, vb = z[r0 : r0 + BLOCK], v[r0 : r0 + BLOCK]
        jac = np.zeros((len(zb), 2 * q))
        col = 0
        if with_z:
            jac[:, 0] = 1.0
            col = 2
        for b in basis:
            dz, dv = b.jacobian(zb, vb, hz, hv)
            jac[:, col] = -dz
            jac[:, col + 1] = -dv
            col += 2
        jtj += jac.T @ jac
        jsum += np.ones(len(zb)) @ jac
    return jtj, jsum


def _calibrated(func, sigma_v: float):
    """``g(z, v) sign(v) erf(v / (sqrt 2 sigma_v))``: ``E[g(z, v_true) | v]`` for a sign factor in v.

    With ``v = v_true + n``, ``n ~ N(0, sigma_v^2)`` and ``sigma_v`` small
    against the spread of ``v``, ``E[sign(v_true) | v] = erf(v / (sqrt 2 sigma_v))``:
    the input error is then uncorrelated with the input (regression calibration).
    """
    scale = 1.0 / (np.sqrt(2.0) * sigma_v)

    def calibrated(z: np.ndarray, v: np.ndarray) -> np.ndarray:
        from scipy import special

        return func(z, v) * np.sign(v) * special.erf(v * scale)

    return calibrated


def perturbation_map(ch: Channels, k_tilde: float) -> np.ndarray:
    """The map ``T`` with ``T [f, <z>, -<g>.., y] = [f + k~1 <z>, -<g>.., y]`` in scaled units (Eq. 13)."""
    c = len(ch.scales)
    if not ch.has_z:
        return np.eye(c)
    t = np.zeros((c - 1, c))
    t[0, 0] = 1.0
    t[0, 1] = k_tilde * ch.scales[1] / ch.scales[0]
    for a in range(2, c):
        t[a - 1, a] = 1.0
    return t


def perturbation_subspace(ch: Channels, gram: np.ndarray) -> PerturbedMOESP:
    """The subspace step of ``gram`` prepared for every ``perturbation_map(ch, k~1)``.

    ``T(k~1) = T(0) + kappa E`` with ``kappa = k~1 s_z / s_f`` and ``E`` the unit
    map of ``<z>`` into ``fbar`` (:class:`nlid_nsi.subspace.PerturbedMOESP`).
    """
    t0 = perturbation_map(ch, 0.0)
    t1 = np.zeros_like(t0)
    if ch.has_z:
        t1[0, 1] = 1.0
    return PerturbedMOESP(gram, t0, t1)


def static_constant(
    ch: Channels,
    mass: float,
    linear: float,
    viscous: float,
    coefficients: dict[str, float],
    basis: tuple[Basis, ...],
    v: np.ndarray,
    dt: float,
) -> float:
    """``theta_1`` from the static balance ``mean(f - m a - theta_z z - c_v v - sum theta_j g_j)``.

    The channel means are interval means (so ``mean(z)`` is the mean of the
    possibly shifted output); ``mean(a) = (v_end - v_0) / T``.
    """
    off = 2 if ch.has_z else 1
    mean_g = -ch.means[off : off + len(basis)]
    mean_y = ch.means[-1]
    mean_a = (v[-1] - v[0]) / (dt * (len(v) - 1))
    out = ch.means[0] - mass * mean_a - linear * mean_y - viscous * float(np.mean(v))
    return float(out - sum(coefficients[b.name] * g for b, g in zip(basis, mean_g, strict=True)))
