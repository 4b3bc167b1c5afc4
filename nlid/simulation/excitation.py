"""Forces that drive the simulator: random excitation, and the force of every RK4 sub-step."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..errors import InputError

__all__ = ["random_force", "fine_force"]


def random_force(
    n: int,
    fs: float,
    rms: float,
    rng: np.random.Generator,
    band: Sequence[float] | None = None,
) -> np.ndarray:
    """Zero-mean Gaussian random force with a given RMS.

    Parameters
    ----------
    n
        Number of samples.
    fs
        Sampling frequency in Hz.
    rms
        Target RMS in N (met exactly on the generated record).
    rng
        Random generator (``numpy.random.default_rng(seed)``).
    band
        ``(low, high)`` in Hz for a band-limited force (zero-phase
        Butterworth band-pass of order 4); ``None`` for white.
    """
    x = rng.standard_normal(n)
    if band is not None:
        from scipy import signal

        low, high = float(band[0]), float(band[1])
        if not (0 <= low < high < fs / 2):
            raise InputError(f"force band must satisfy 0 <= low < high < fs/2, got {band}")
        if low > 0:
            sos = signal.butter(4, [low, high], btype="band", fs=fs, output="sos")
        else:
            sos = signal.butter(4, high, btype="low", fs=fs, output="sos")
        x = signal.sosfiltfilt(sos, x)
    x -= x.mean()
    return x * (rms / np.sqrt(np.mean(x**2)))


def fine_force(force: np.ndarray, force_hold: str, oversample: int) -> np.ndarray:
    """The force of every RK4 sub-step of a free run: held (``"zoh"``) or band-limited interpolated.

    A sampled force is interpolated (polyphase) at the midpoint of each of the
    ``oversample`` sub-steps of every sample interval (:func:`nlid.simulation.free_run`);
    a held one is repeated.
    """
    force = np.asarray(force, dtype=float)
    if force_hold == "zoh":
        return np.repeat(force, oversample)
    if oversample == 1:
        return force
    from scipy import signal

    return signal.resample_poly(force, 2 * oversample, 1)[1::2]  # at the midpoint of every sub-step
