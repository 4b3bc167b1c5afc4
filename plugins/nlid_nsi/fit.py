"""One NSI identification: subspace step, B, continuous time, extended FRF, spectra.

:func:`fit_extended` turns the Gram of the (perturbed) base channels into an
:class:`NSIFit`: PO-MOESP (A, C) and the order (:mod:`nlid_nsi.subspace`), the
ULS test of Eq. 18 *before* B is estimated (an unstable model never reaches
the output-error step, whose filters would overflow), B by output-error least
squares with the errors-in-variables correction, the exact ZOH inverse, the
extended FRF (Eq. 19), the coefficient spectra (Eq. 20) and the ULS fit
(:mod:`nlid_nsi.continuous`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from nlid.plugin import IdentificationError

from .channels import Channels
from .continuous import (
    ULS,
    CoefficientSpectrum,
    band_limits,
    coefficient_spectra,
    continuous_eigenvalues,
    d2c_zoh,
    extended_frf,
    fit_uls,
    uls_ok,
)
from .gram import transform_gram
from .subspace import PerturbedMOESP, channel_blocks, estimate_b, po_moesp

__all__ = ["UnstableULSError", "NSIFit", "fit_extended", "format_eigenvalues"]

#: Points of the band grid over which the coefficients are averaged and the ULS fitted.
BAND_POINTS = 256
#: Points of the frequency grid of the returned FRF and coefficient spectra.
PLOT_POINTS = 512


class UnstableULSError(IdentificationError):
    """The identified underlying-linear system is not a stable, clearly oscillatory pair (Eq. 18).

    Attributes
    ----------
    eigenvalues
        Its continuous-time eigenvalues (rad/s).
    """

    def __init__(self, message: str, eigenvalues: np.ndarray | None = None):
        super().__init__(message)
        self.eigenvalues = eigenvalues


def format_eigenvalues(lc: np.ndarray) -> str:
    """``"-2.91+22.19j, -2.91-22.19j"`` or ``"19.11, -24.87"`` (rad/s)."""
    return ", ".join(f"{x.real:.4g}{x.imag:+.4g}j" if abs(x.imag) > 0 else f"{x.real:.4g}" for x in lc)


@dataclass
class NSIFit:
    """Result of one NSI identification (one k~1, or one zero reference).

    Attributes
    ----------
    coefficients
        ``{basis name: theta}`` from the spectra (Eq. 20); the driver adds the
        linear, viscous and constant terms.
    uls
        The underlying-linear system.
    spectra
        Coefficient spectra on :attr:`w_plot`.
    w_plot
        Frequency grid (rad/s) of :attr:`frf` and the spectra.
    frf
        ``Hbar`` on :attr:`w_plot` (m/N).
    band
        ``(lo, hi)`` in rad/s.
    singular_values, order
        Of the subspace step.
    a, b, c
        Discrete model in physical units (``D = 0``).
    """

    coefficients: dict[str, float]
    uls: ULS
    spectra: list[CoefficientSpectrum]
    w_plot: np.ndarray
    frf: np.ndarray
    band: tuple[float, float]
    singular_values: np.ndarray
    order: int
    a: np.ndarray
    b: np.ndarray
    c: np.ndarray
    extras: dict = field(default_factory=dict)


def _unscale(ch: Channels, b: np.ndarray, cm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Undo the channel scaling: each input in units of its source channel, C in metres."""
    m = b.shape[1]
    off = 2 if ch.has_z else 1
    su = np.concatenate([[ch.scales[0]], ch.scales[off : off + m - 1]])  # fbar is in units of f's scale
    return b / su[None, :], cm * ch.scales[-1]


def unstable_message(k_tilde: float | None, lc: np.ndarray, zeta_max: float) -> str:
    """Why a ULS was rejected, naming its eigenvalues."""
    what = f"k~1 = {k_tilde:g} N/m: the" if k_tilde is not None else "The"
    return (
        f"{what} identified underlying-linear system has eigenvalues [{format_eigenvalues(lc)}] rad/s, "
        f"which are not a stable complex-conjugate pair with damping ratio <= {zeta_max:g} (Eq. 18)"
    )


def fit_extended(
    ch: Channels,
    t: np.ndarray,
    gram: np.ndarray,
    dt: float,
    band: str | tuple[float, float],
    order: int | None,
    max_order: int,
    zeta_max: float,
    k_tilde: float | None = None,
    mass: float | None = None,
    subspace: PerturbedMOESP | None = None,
) -> NSIFit:
    """Identify the extended-input model of the channels ``T w`` (Eq. 16-20).

    Parameters
    ----------
    ch
        Base channels.
    t
        Channel map (:func:`nlid_nsi.channels.perturbation_map`, or the identity).
    gram
        Gram of the base channels (possibly noise-corrected).
    dt
        Sampling interval.
    band
        See :func:`nlid_nsi.continuous.band_limits`.
    order, max_order
        Model order (``None``: largest gap) and its upper bound.
    zeta_max
        Acceptance margin of the ULS (see :func:`nlid_nsi.continuous.uls_ok`).
    k_tilde
        For messages only.
    mass
        Known mass (constrains the ULS fit), or ``None``.
    subspace
        The subspace step prepared for every map ``t0 + kappa t1`` of this
        ``gram`` (nsi-ip's k~1 values); ``None``: PO-MOESP on the transformed
        Gram (the same result, one full factorisation per call).

    Raises
    ------
    UnstableULSError
        The ULS fails the test of Eq. 18.
    """
    m_in = t.shape[0] - 1
    if subspace is not None:
        a, cm, sv, n = subspace.estimate(t, order, max_order)
    else:
        a, cm, sv, n = po_moesp(transform_gram(gram, t), m_in, order, max_order)
    lc = continuous_eigenvalues(a, dt)
    if not uls_ok(lc, zeta_max):
        raise UnstableULSError(unstable_message(k_tilde, lc, zeta_max), lc)
    noise = ch.noise.transformed(t) if ch.noise is not None else None
    b = estimate_b(a, cm, None, None, noise, output=m_in, blocks=channel_blocks(ch.base, t))
    b, cm = _unscale(ch, b, cm)
    ac, bc, lc = d2c_zoh(a, b, dt)
    wn = float(np.abs(lc[0]))
    zeta = float(-lc[0].real / wn)
    lo, hi = band_limits(wn, zeta, band)
    if not (0 <= lo < hi):
        raise IdentificationError(f"empty band [{lo / 2 / math.pi:g}, {hi / 2 / math.pi:g}] Hz")
    w_band = np.linspace(lo, hi, BAND_POINTS)
    he = extended_frf(ac, bc, cm, w_band)
    uls = fit_uls(w_band, he[:, 0], lc, mass)
    names = ch.names[-1 - (m_in - 1) : -1] if m_in > 1 else []
    in_band = np.ones(BAND_POINTS, dtype=bool)
    band_spectra = coefficient_spectra(he, in_band, names)
    w_plot = np.linspace(0.0, min(math.pi / dt, max(5.0 * wn, 2.0 * hi)), PLOT_POINTS + 1)[1:]
    he_plot = extended_frf(ac, bc, cm, w_plot)
    plot_spectra = [
        CoefficientSpectrum(s.name, he_plot[:, j] / he_plot[:, 0], s.estimate, s.quality)
        for j, s in enumerate(band_spectra, start=1)
    ]
    coefficients = {s.name: s.estimate for s in band_spectra}
    return NSIFit(coefficients, uls, plot_spectra, w_plot, he_plot[:, 0], (lo, hi), sv, n, a, b, cm)
