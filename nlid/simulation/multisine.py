"""Periodic multisine tests: the force of one period and the periodic steady-state response to it.

The Bouc-Wen benchmark (Noel & Schoukens 2016) was generated in MATLAB: its system (``m y'' + c y' + k y + w =
u``, ``w' = alpha y' - beta (gamma |y'| w + delta y' |w|)``, m = 2 kg, c = 10 N s/m, k = alpha = 5e4 N/m,
beta = 1e3, gamma = 0.8, delta = -1.1) driven by a random-phase multisine of 8192 samples at 750 Hz, flat over
its lines 5-150 Hz (lines 54 to 1639), 50 N RMS, integrated by Newmark at 15 kHz and kept in periodic steady
state for 5 periods (``train_multisine.mat``). Here the same test is generated in Python:

* :func:`multisine_period` synthesises one period from its lines, RMS and phases;
* :func:`benchmark_phases` reads the phases of the benchmark's own realisation from the force of
  ``train_multisine.mat`` (``$NLID_DATA_DIR``; random phases cannot be regenerated without MATLAB's generator
  and seed, which were not published), checking that its amplitudes are the flat spectrum described;
* :func:`periodic_response` runs :func:`~nlid.simulation.kernels.free_run` on the force repeated, the
  force between samples interpolated within its band (a multisine is band-limited: the interpolated force is
  the continuous one), 20 RK4 sub-steps per sample (15 kHz, the benchmark's rate), and keeps the periods after
  the transient.

With the benchmark's phases, the published system reproduces the measured displacement of
``train_multisine.mat`` to 7.5e-6 m RMS, the record's own noise (``tests/simulation/test_multisine.py``). The presets
``bouc-wen-multisine`` (a new realisation per seed) and ``bouc-wen-train`` (the benchmark's) use them
(:mod:`nlid.simulation.presets`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..errors import DataError, InputError

__all__ = ["multisine_period", "benchmark_phases", "periodic_response"]
#: Relative spread of the line amplitudes beyond which a force is not the flat multisine described.
FLAT = 1e-6


def _lines(lines: Sequence[int], period: int) -> np.ndarray:
    first, last = (int(x) for x in lines)
    if not 0 < first <= last < period // 2:
        raise InputError(f"multisine lines must satisfy 0 < first <= last < period/2 = {period // 2}, got {lines}")
    return np.arange(first, last + 1)


def multisine_period(period: int, lines: Sequence[int], rms: float, phases: np.ndarray) -> np.ndarray:
    """One period of ``sum_k a cos(2 pi k n / period + phi_k)`` over the lines ``first..last``, scaled to ``rms``.

    Parameters
    ----------
    period
        Samples per period.
    lines
        ``(first, last)``: the excited DFT lines (line ``k`` is ``k fs / period`` Hz).
    rms
        RMS of the force (N); every line has the amplitude ``rms sqrt(2 / L)`` for ``L`` lines.
    phases
        The phase of each line (rad), ``L`` of them.
    """
    k = _lines(lines, period)
    phases = np.asarray(phases, dtype=float)
    if phases.shape != k.shape:
        raise InputError(f"phases must hold one phase per line ({k.size}), got shape {phases.shape}")
    amplitude = float(rms) * np.sqrt(2.0 / k.size)
    spectrum = np.zeros(period // 2 + 1, dtype=complex)
    spectrum[k] = 0.5 * period * amplitude * np.exp(1j * phases)
    return np.fft.irfft(spectrum, period)


def benchmark_phases(period: int = 8192, lines: Sequence[int] = (54, 1639)) -> np.ndarray:
    """The phases of the Bouc-Wen benchmark's training multisine, read from ``train_multisine.mat``.

    Raises
    ------
    DataError
        The file is missing (``$NLID_DATA_DIR``), or its force is not the flat multisine of ``lines`` and
        ``period`` (a different file).
    """
    from ..data.datasets import load

    force = load("bouc-wen").f
    if force.size < period:
        raise DataError(f"the Bouc-Wen training force has {force.size} samples, fewer than one period ({period})")
    spectrum = np.fft.rfft(force[:period])
    k = _lines(lines, period)
    amplitude = np.abs(spectrum)
    others = np.delete(amplitude, k)
    if np.ptp(amplitude[k]) > FLAT * amplitude[k].max() or others.max(initial=0.0) > FLAT * amplitude[k].max():
        raise DataError(
            f"the Bouc-Wen training force is not a flat multisine over lines {lines[0]}-{lines[1]} of {period}: "
            "a different file than the benchmark's train_multisine.mat"
        )
    return np.angle(spectrum[k])


def periodic_response(
    model: Any,
    coefficients: Mapping[str, float],
    mass: float,
    force_period: np.ndarray,
    fs: float,
    *,
    periods: int,
    transient_periods: int,
    oversample: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The periodic steady-state response to a periodic force: ``(f, z, v, a)`` over ``periods`` periods.

    The force is repeated ``transient_periods + periods`` times from rest, integrated by
    :func:`~nlid.simulation.kernels.free_run` (the force between samples interpolated within its band,
    ``oversample`` RK4 sub-steps per sample), and the first ``transient_periods`` periods are dropped.
    """
    from .kernels import free_run

    if int(periods) < 1 or int(transient_periods) < 0:
        raise InputError(f"periods must be >= 1 and transient_periods >= 0, got {periods}, {transient_periods}")
    n = force_period.size
    force = np.tile(force_period, int(transient_periods) + int(periods))
    z, v, a = free_run(model, dict(coefficients), mass, force, fs, force_hold="sampled", oversample=int(oversample))
    keep = slice(int(transient_periods) * n, None)
    return force[keep], z[keep], v[keep], a[keep]
