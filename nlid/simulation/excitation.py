"""Forces that drive the simulator: random excitation, stepped and swept sines, and the force between the samples.

A *held* force (``force_hold="zoh"``, the presets') is constant over each sample
interval, and the integrators read it as it is. A *sampled* force (a measured or
band-limited signal: the default) has a value at every instant, which the
samples determine exactly within their band (Shannon); :func:`fine_force` gives
it between the samples:

* for whole periods of a periodic signal (``periodic=True``), by trigonometric
  interpolation (the FFT of the samples, padded with zeros): exact;
* otherwise by a windowed-sinc interpolator of :data:`INTERPOLATION_TAPS`
  samples on each side (Kaiser window, :data:`INTERPOLATION_BETA`), whose gain is
  within 2e-6 of the ideal one from 0 to 0.8 of the Nyquist frequency (scipy's
  default ``resample_poly`` filter, which nlid used before, ripples by 4e-3); the
  record is continued beyond its ends by odd reflection about its end samples.

nlid's RK4 kernels hold one value of the force over each sub-step. A staircase
of the force's values at the sub-steps' midpoints carries a component of
frequency ``f`` with the gain ``sinc(f h)`` (``h`` the sub-step): a droop of 6e-5
at a twentieth of the sampling frequency with 8 sub-steps, which is larger than
the error of the models nlid ranks. The held values are therefore those whose
staircase carries the force's band with unit gain (the interpolator's response
divided by ``sinc``); the free run of a linear oscillator driven by a sampled
sine then matches its exact response to about 1e-6 of its amplitude, where
midpoint values leave 4e-5 at resonance (``benchmarks/accuracy_scorer.py``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..errors import InputError

__all__ = ["random_force", "fine_force", "SineTest", "INTERPOLATION_TAPS", "INTERPOLATION_BETA"]

#: Samples on each side of the windowed-sinc interpolator of a sampled force (:func:`fine_force`).
INTERPOLATION_TAPS = 32
#: Beta of the interpolator's Kaiser window. With :data:`INTERPOLATION_TAPS` = 32 the gain is within 2e-6 of the
#: ideal from 0 to 0.8 of the Nyquist frequency, 1e-6 to 0.6 (``python benchmarks/accuracy_scorer.py filter``).
INTERPOLATION_BETA = 12.0
#: Nodes of the Gauss-Legendre rule that integrates the compensated kernel (exact to far below its ripple).
_NODES = 400


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


def fine_force(
    force: np.ndarray, force_hold: str, oversample: int, *, periodic: bool = False, stages: bool = False
) -> np.ndarray:
    """The force between the samples, as an integrator with ``oversample`` RK4 sub-steps per sample reads it.

    Parameters
    ----------
    force
        The force samples, shape ``(N,)``.
    force_hold
        ``"zoh"``: the force is held over each sample interval (repeated); ``"sampled"``: a band-limited signal,
        interpolated exactly within its band (see the module).
    oversample
        Sub-steps per sample interval, ``q``.
    periodic
        The samples are whole periods of a periodic force: interpolated by the FFT (exact; the force before the
        first sample is the last period's).
    stages
        ``False`` (nlid's kernels): ``q`` values per sample interval, each held over one sub-step (those of a
        sampled force are compensated for the hold: see the module). ``True``: the force itself at every half
        sub-step, ``2 q`` values per sample (times ``k + i / (2 q)`` samples), for an integrator that evaluates
        the force at the times of its stages (the bench peer's).

    Returns
    -------
    numpy.ndarray
        Shape ``(N q,)`` (``(2 N q,)`` with ``stages=True``).

    Raises
    ------
    InputError
        An unknown ``force_hold`` or an ``oversample`` that is not a positive whole number.
    """
    force = np.asarray(force, dtype=float)
    if force_hold not in ("sampled", "zoh"):
        raise InputError(f"force_hold must be 'sampled' or 'zoh', got {force_hold!r}")
    if isinstance(oversample, bool) or int(oversample) != oversample or oversample < 1:
        raise InputError(f"oversample must be a positive integer, got {oversample!r}")
    q = int(oversample)
    per = 2 * q if stages else q
    if force_hold == "zoh":
        return np.repeat(force, per)
    if force.size == 0:
        return np.zeros(0)
    # times of the values within a sample interval (in samples), and the hold they are compensated for
    shift, hold = (0.0, 0) if stages else (0.5 / q, q)
    if periodic:
        return _trigonometric(force, per, shift, hold)
    taps = _interpolator(per, shift, hold)
    k = INTERPOLATION_TAPS
    padded = np.pad(force, k, mode="reflect", reflect_type="odd")[1:]  # padded[i] = force[i - k + 1]
    out = np.empty(force.size * per)
    for j in range(per):  # out[i per + j] = sum_m taps[j, m] force[i + m - k + 1]
        out[j::per] = np.correlate(padded, taps[j], mode="valid")[: force.size]
    return out


def _trigonometric(force: np.ndarray, per: int, shift: float, hold: int) -> np.ndarray:
    """The periodic band-limited force at ``k + shift + j / per`` (``j < per``) from its FFT (:func:`fine_force`)."""
    n = force.size
    spectrum = np.fft.rfft(force)
    lines = np.arange(spectrum.size) / n  # cycles per sample
    gain = np.exp(2j * np.pi * lines * shift)
    if hold:
        gain /= np.sinc(lines / hold)
    spectrum = spectrum * gain * per
    if n % 2 == 0:
        spectrum[-1] *= 0.5  # the Nyquist line is shared between +n/2 and -n/2 (a cosine): half on each
    return np.fft.irfft(spectrum, n * per)


@lru_cache(maxsize=32)
def _interpolator(per: int, shift: float, hold: int) -> np.ndarray:
    """Taps ``(per, 2 K)`` of the windowed-sinc interpolator at the offsets ``shift + j / per`` (cached, read-only).

    Row ``j`` gives the value at ``k + shift + j / per`` from the samples ``k - K + 1 .. k + K``. The ideal
    kernel is ``sinc``; held values (``hold = q``) divide its spectrum by ``sinc(nu / q)`` over the band, a
    kernel integrated numerically. Each row is normalised to unit gain at zero frequency.
    """
    k = INTERPOLATION_TAPS
    offsets = shift + np.arange(per) / per
    t = np.arange(-k + 1, k + 1)[None, :] - offsets[:, None]  # sample time minus the value's time
    if hold:
        x, w = np.polynomial.legendre.leggauss(_NODES)
        nu = 0.25 * (x + 1.0)  # [0, 1/2] cycles per sample
        response = w * 0.25 / np.sinc(nu / hold)
        ideal = 2.0 * np.cos(2.0 * np.pi * np.multiply.outer(t, nu)) @ response  # 2 int_0^1/2 H cos(2 pi nu t)
    else:
        ideal = np.sinc(t)
    window = np.i0(INTERPOLATION_BETA * np.sqrt(np.clip(1.0 - (t / k) ** 2, 0.0, None))) / np.i0(INTERPOLATION_BETA)
    taps = ideal * window
    taps /= taps.sum(axis=1, keepdims=True)
    taps.flags.writeable = False
    return taps


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
