"""The noise floor of a record and the default cut-off it sets (re-exported by :mod:`nlid.signal.derivatives`).

:func:`suggest_cutoff` places the shared filters' default cut-off where the
signal's spectrum meets ``CUTOFF_SNR`` times its noise floor; :func:`noise_sd`
reads the white measurement noise's standard deviation off the same floor.
Both estimate the floor in the band ``NOISE_BAND`` of the Welch spectrum,
where a structure's response has died away.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError

__all__ = ["suggest_cutoff", "noise_sd", "CUTOFF_SNR", "CUTOFF_ENERGY", "CUTOFF_MAX_FRACTION", "NOISE_BAND"]

#: Required ratio of the signal's power spectral density to the noise floor
#: below the default cut-off (100 = 20 dB in amplitude).
CUTOFF_SNR = 100.0
#: Fraction of the signal variance that must lie below the default cut-off.
CUTOFF_ENERGY = 0.99
#: Highest default cut-off as a fraction of the sampling frequency.
CUTOFF_MAX_FRACTION = 0.4
#: Band (fractions of fs) where the noise floor is estimated.
NOISE_BAND = (0.35, 0.45)


def suggest_cutoff(x: np.ndarray, fs: float) -> float:
    """Suggest a low-pass cut-off for differentiating ``x``.

    The rule: estimate the power spectral density of ``x`` (Welch, segments
    of 4096 samples) and its noise floor (the median density between
    ``NOISE_BAND`` = 0.35 and 0.45 fs, where a structure's response has died
    away and only measurement noise is left). The cut-off is the first
    frequency above the spectral peak where the density falls below
    ``CUTOFF_SNR`` (100) times that floor; it is raised, if needed, to the
    frequency below which ``CUTOFF_ENERGY`` (99 %) of the variance above the
    floor lies, and capped at ``CUTOFF_MAX_FRACTION`` (0.4) of fs. On
    noise-free data the cut-off is therefore high; with 2 % noise on the
    paper's example it is about 45 Hz, just above the band of the response.

    Parameters
    ----------
    x
        The signal (usually displacement).
    fs
        Sampling frequency in Hz.

    Returns
    -------
    float
        The cut-off in Hz.
    """
    freqs, psd, band = _welch_noise_band(x, fs)
    cap = CUTOFF_MAX_FRACTION * fs
    floor = float(np.median(psd[band])) if band.any() else 0.0
    cumulative = np.cumsum(np.clip(psd - floor, 0.0, None))
    if cumulative[-1] <= 0:
        return cap
    f_energy = freqs[min(int(np.searchsorted(cumulative / cumulative[-1], CUTOFF_ENERGY)), freqs.size - 1)]
    peak = int(np.argmax(psd[1:])) + 1
    below = np.flatnonzero(psd[peak:] < CUTOFF_SNR * floor)
    f_snr = freqs[peak + below[0]] if below.size else cap
    return float(min(max(f_snr, f_energy, freqs[1]), cap))


def noise_sd(x: np.ndarray, fs: float) -> float:
    """Standard deviation of the white measurement noise on ``x``, from its noise floor.

    The floor is the median Welch power spectral density (segments of 4096
    samples) between ``NOISE_BAND`` = 0.35 and 0.45 fs, the band
    :func:`suggest_cutoff` also treats as noise only; white noise of standard
    deviation ``s`` has the one-sided density ``2 s^2 / fs``. Signal content
    in that band makes this an overestimate.

    Parameters
    ----------
    x
        The signal (usually displacement).
    fs
        Sampling frequency in Hz.

    Returns
    -------
    float
        The estimated noise standard deviation, in the unit of ``x``.
    """
    freqs, psd, band = _welch_noise_band(x, fs)
    if not band.any():
        raise InputError(f"too few samples ({np.size(x)}) to estimate a noise floor")
    return float(np.sqrt(np.median(psd[band]) * fs / 2.0))


def _welch_noise_band(x: np.ndarray, fs: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Welch PSD of ``x`` (segments of up to 4096 samples) and the mask of the noise-only band ``NOISE_BAND``."""
    x = np.asarray(x, dtype=float)
    freqs, psd = welch_density(x - x.mean(), fs, int(min(x.size, 4096)))
    band = (freqs >= NOISE_BAND[0] * fs) & (freqs <= NOISE_BAND[1] * fs)
    return freqs, psd, band


def welch_density(x: np.ndarray, fs: float, nperseg: int) -> tuple[np.ndarray, np.ndarray]:
    """``scipy.signal.welch(x, fs=fs, nperseg=nperseg)`` of the 1-D ``x``, without importing ``scipy.signal``.

    Welch's one-sided power spectral density with its defaults: periodic Hann
    window, half-overlapping segments, each segment's mean removed, density
    scaling, the mean over the segments. The same operations in the same
    order as scipy 1.17's ``welch`` (its ``ShortTimeFFT`` path), so the same
    numbers to the bit there (tests/signal/test_derivatives.py compares them).
    Importing ``scipy.signal`` costs ~0.5 s (it imports ``scipy.stats``),
    which every ``nlid identify`` paid before its identification started.

    Parameters
    ----------
    x
        The signal, 1-D, at least ``nperseg`` samples.
    fs
        Sampling frequency in Hz.
    nperseg
        Samples per segment.

    Returns
    -------
    freqs, psd
        The frequencies (Hz) and the density (unit of ``x`` squared per Hz).
    """
    from scipy import fft as sp_fft

    x = np.asarray(x, dtype=float)
    nperseg = int(nperseg)
    noverlap = nperseg // 2
    hop = nperseg - noverlap
    # scipy.signal.windows.hann(nperseg, sym=False): the general cosine window of nperseg + 1 points, truncated
    phase = np.linspace(-np.pi, np.pi, nperseg + 1)
    window = np.zeros(nperseg + 1)
    for k, weight in enumerate((0.5, 0.5)):
        window += weight * np.cos(k * phase)
    window = window[:-1]
    # the density scaling folded into the window, the factor summed in order as ShortTimeFFT does
    window = window * (1 / np.sqrt(sum(window**2) / (1 / fs)))
    segments = (x.size - noverlap) // hop
    power = np.zeros((nperseg // 2 + 1, segments))
    for p in range(segments):
        seg = x[p * hop : p * hop + nperseg]
        seg = seg - np.mean(seg, axis=-1, keepdims=True)
        spectrum = sp_fft.rfft(seg * window, n=nperseg)
        power[:, p] = spectrum.real**2 + spectrum.imag**2
    power[1 : -1 if nperseg % 2 == 0 else None] *= 2  # one-sided: the other half's power
    return sp_fft.rfftfreq(nperseg, 1 / fs), power.mean(axis=-1)
