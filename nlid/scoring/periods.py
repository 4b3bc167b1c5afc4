"""Periods of a record: a force that repeats, or one that is whole periods of a multisine (:mod:`nlid.scoring.rules`).

A record in periodic steady state is scored so (:class:`~nlid.scoring.PeriodicSteadyState`) when
its period is declared (``record.meta["periodic"]``) or found here:

* a force that repeats at least twice within the record (:func:`detect_period`) whose response
  repeats too (:data:`RESPONSE_REPEAT`: a record that starts from rest is not in steady state);
* a force that does not repeat but is one whole period of a multisine (:func:`multisine_lines`):
  the DFT of the record has its energy on lines with empty bins between them (an odd or
  band-limited random-phase multisine, the validation record of a benchmark), which a random
  force, a sweep or a force cut at any other length does not have. Nothing in one period says
  whether the response had settled: a benchmark's one-period validation record is, by the
  convention its published figures follow (the PNLSS reproduction prepends a period), and the
  rule as applied says it was found this way.
"""

from __future__ import annotations

import numpy as np

from ..data.record import Record

__all__ = ["detect_period", "record_period", "multisine_lines", "RESPONSE_REPEAT", "LINE_GAP", "EMPTY_FRACTION"]

#: A force detected as periodic sets the default rule only if its response repeats too: consecutive periods of
#: ``z`` differ by at most this fraction of ``std(z)`` (RMS), and the first pair by at most twice the last
#: (a record that starts from rest with a periodic force is not in steady state).
RESPONSE_REPEAT = 0.1


def detect_period(force: np.ndarray, *, rtol: float = 1e-6) -> int | None:
    """The period of a force in samples, if it repeats at least twice within the record.

    The smallest ``P`` (``2 <= P <= n / 2``) with ``max |f[i + P] - f[i]| <= rtol max |f|`` over the record.
    Candidates come from the record's autocorrelation (computed with the FFT); each is then checked
    sample by sample.

    Parameters
    ----------
    force
        The force samples.
    rtol
        Largest difference between periods, relative to ``max |f|`` (a generated multisine repeats exactly;
        a measured force does not, and is not called periodic).

    Returns
    -------
    int or None
        The period, or ``None`` when the force does not repeat twice.
    """
    f = np.asarray(force, dtype=float).ravel()
    n = f.size
    top = float(np.max(np.abs(f))) if n else 0.0
    if n < 4 or top == 0.0:
        return None
    half = n // 2
    spectrum = np.fft.rfft(f, 2 * n)
    corr = np.fft.irfft(np.abs(spectrum) ** 2, 2 * n)[: half + 1]  # corr[P] = sum_i f[i] f[i + P]
    energy = np.concatenate([[0.0], np.cumsum(f * f)])
    lags = np.arange(2, half + 1)
    ssd = energy[n - lags] + (energy[n] - energy[lags]) - 2.0 * corr[lags]  # sum (f[i + P] - f[i])^2
    rms = np.sqrt(energy[n] / n)
    rel = np.sqrt(np.maximum(ssd, 0.0) / (n - lags)) / rms
    for lag in lags[rel < 1e-3][:64]:  # the FFT's rounding leaves ~1e-7 of a true period; checked exactly below
        if np.max(np.abs(f[lag:] - f[:-lag])) <= rtol * top:
            return int(lag)
    return None


def _response_repeats(z: np.ndarray, period: int) -> bool:
    """Whether consecutive periods of ``z`` repeat (:data:`RESPONSE_REPEAT`): the record is in steady state."""
    k = z.size // period
    if k < 2:
        return False
    blocks = z[: k * period].reshape(k, period)
    moves = np.sqrt(np.mean(np.diff(blocks, axis=0) ** 2, axis=1))
    scale = float(np.std(z))
    if scale == 0.0 or moves.max() > RESPONSE_REPEAT * scale:
        return False
    return bool(moves[0] <= 2.0 * moves[-1] + 1e-12 * scale)


def record_period(record: Record, *, response: bool = True) -> tuple[int | None, str]:
    """The period of a record in periodic steady state, and how it is known (``"declared"``, ``"detected..."``).

    ``record.meta["periodic"]`` declares it (``True``: the record is whole periods of its own length; an
    integer: the period in samples; ``False``: not periodic). Otherwise a force that repeats at least twice
    (:func:`detect_period`) whose response repeats too (:data:`RESPONSE_REPEAT`; not checked with
    ``response=False``) is periodic, and a force that does not repeat but is one period of a multisine
    (:func:`multisine_lines`) is one period of its own length. ``(None, "")`` when the record is not periodic.
    """
    declared = record.meta.get("periodic")
    if declared is True:
        return record.n, "declared"
    if declared is not None and declared is not False:
        return int(declared), "declared"
    if declared is False:
        return None, ""
    period = detect_period(record.f)
    if period is not None:
        if not response or _response_repeats(record.z, period):
            return period, "detected from the force"
        return None, ""
    lines = multisine_lines(record.f)
    if lines is not None:
        return (
            record.n,
            f"whole periods of a multisine, detected from the force's spectrum ({lines} lines, empty bins between)",
        )
    return None, ""


#: Decades of power between a multisine's weakest line and its strongest empty bin (:func:`multisine_lines`); a
#: generated multisine's empty bins sit at rounding (25 decades below), a measured one's at its noise floor.
LINE_GAP = 3.0
#: Fewest empty bins (below the gap), as a fraction of the DFT's bins: a random force's deepest bins are single.
EMPTY_FRACTION = 0.05


def multisine_lines(force: np.ndarray) -> int | None:
    """The number of lines of a force that is whole periods of a multisine, or ``None``.

    The power of the DFT of the record (without the mean and the Nyquist bin), sorted, splits into
    lines and empty bins at a gap of at least :data:`LINE_GAP` decades, with at least
    :data:`EMPTY_FRACTION` of the bins empty. A multisine cut at whole periods does (its lines fall on
    the record's bins, the others hold only rounding or noise); a random force's power spreads over
    every bin, and a sweep's, a periodic force cut at another length's (leakage) or a filtered
    force's (its roll-off) change smoothly.

    Parameters
    ----------
    force
        The force samples.

    Returns
    -------
    int or None
        The number of lines, ``None`` when the force is not whole periods of a multisine.
    """
    f = np.asarray(force, dtype=float).ravel()
    n = f.size
    if n < 16:
        return None
    power = np.abs(np.fft.rfft(f - f.mean())[1 : (n + 1) // 2]) ** 2  # bins 1 .. below Nyquist
    top = float(power.max())
    if not np.isfinite(top) or top == 0.0:
        return None
    level = np.sort(np.log10(np.maximum(power, 1e-20 * top)))  # rounding (and exact zeros) at one level
    jumps = np.diff(level)
    fewest = max(int(np.ceil(EMPTY_FRACTION * power.size)), 1)  # empty bins below the cut
    if jumps.size < fewest:
        return None
    cut = fewest - 1 + int(np.argmax(jumps[fewest - 1 :]))
    if jumps[cut] < LINE_GAP:
        return None
    return int(power.size - cut - 1)
