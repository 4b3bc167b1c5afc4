"""Forces that drive the simulator: random excitation, stepped and swept sines, and the force of every RK4 sub-step."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import InputError

__all__ = ["random_force", "fine_force", "SineTest"]


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


@dataclass(frozen=True)
class SineTest:
    """A stepped-sine or swept-sine test: the force ``amplitude cos(phase(t))`` over a frequency band.

    Attributes
    ----------
    kind
        ``"stepped"`` (constant-frequency steps, the phase continuous from one step to the next) or
        ``"swept"`` (a linear sweep).
    amplitude
        Force amplitude (N).
    band
        ``(low, high)`` frequencies (Hz).
    steps
        Stepped: frequencies per direction, evenly spaced over the band.
    periods
        Stepped: periods of the force per step (the first half is left for the transient).
    rate
        Swept: sweep rate (Hz/s).
    directions
        ``"up"``, ``"down"`` or ``"up-down"`` (up, then down from the top).
    """

    kind: str
    amplitude: float
    band: tuple[float, float]
    steps: int = 41
    periods: int = 80
    rate: float = 0.05
    directions: str = "up-down"

    def __post_init__(self) -> None:
        if self.kind not in ("stepped", "swept"):
            raise InputError(f"a sine test is 'stepped' or 'swept', got {self.kind!r}")
        if self.directions not in ("up", "down", "up-down"):
            raise InputError(f"directions must be 'up', 'down' or 'up-down', got {self.directions!r}")
        lo, hi = (float(x) for x in self.band)
        if not (np.isfinite(lo) and np.isfinite(hi) and 0 < lo < hi):
            raise InputError(f"the band of a sine test must satisfy 0 < low < high, got {self.band}")
        if not (np.isfinite(self.amplitude) and self.amplitude > 0 and self.rate > 0):
            raise InputError("a sine test needs a positive amplitude and rate")
        if int(self.steps) < 2 or int(self.periods) < 4:
            raise InputError("a stepped sine needs at least 2 steps of 4 periods")

    def frequencies(self) -> np.ndarray:
        """Stepped: the frequency of every step, in the order played."""
        up = np.linspace(self.band[0], self.band[1], int(self.steps))
        return {"up": up, "down": up[::-1], "up-down": np.concatenate([up, up[-2::-1]])}[self.directions]

    def duration(self) -> float:
        """Length of the test (s)."""
        if self.kind == "stepped":
            return float(np.sum(int(self.periods) / self.frequencies()))
        span = self.band[1] - self.band[0]
        return (2 if self.directions == "up-down" else 1) * span / self.rate

    def force(self, fs: float) -> tuple[np.ndarray, list[list[float]]]:
        """The force at ``fs`` (each sample the value at the middle of its interval, held over it) and the
        segments ``[frequency (Hz), first sample, last sample + 1]`` of a stepped test (empty when swept)."""
        dt = 1.0 / fs
        if self.kind == "swept":
            n = int(round(self.duration() * fs))
            t = (np.arange(n) + 0.5) * dt
            lo, hi = self.band
            half = (hi - lo) / self.rate
            if self.directions == "down":
                f = hi - self.rate * t
            elif self.directions == "up":
                f = lo + self.rate * t
            else:
                f = np.where(t < half, lo + self.rate * t, hi - self.rate * (t - half))
            phase = 2 * np.pi * np.cumsum(f) * dt
            return self.amplitude * np.cos(phase), []
        pieces, segments, phase0, start = [], [], 0.0, 0
        for freq in self.frequencies():
            n = int(round(int(self.periods) / freq * fs))
            t = (np.arange(n) + 0.5) * dt
            pieces.append(self.amplitude * np.cos(phase0 + 2 * np.pi * freq * t))
            phase0 += 2 * np.pi * freq * n * dt
            segments.append([float(freq), start, start + n])
            start += n
        return np.concatenate(pieces), segments
