"""Derivative estimation and the filters shared by every identifier.

Every identifier in nlid gets its derivatives from here, so that methods are
compared on the same estimates.

One zero-phase filter
    :func:`lowpass`, :func:`differentiate` and :func:`zoh_equivalent` apply
    their frequency response exactly, in the frequency domain, so that they
    all treat a record identically and can be mixed in one equation without a
    phase or gain mismatch. The record is first made smoothly periodic (the
    straight line through its end samples is removed and transformed
    analytically; the rest is reflected oddly at both ends and the
    reflections are tapered to zero), which keeps the FFT's circular
    wrap-around away from the data:

    * low-pass magnitude ``|H(f)| = 1 / (1 + (f / fc)^(2 n))`` - the response
      of an order-``n`` Butterworth filter applied forwards and backwards
      (``n = 4`` by default), with no phase shift;
    * differentiation by ``(i w)^k`` - exact at every frequency, unlike finite
      differences (a 5-point stencil is 3 % low at 0.15 fs);
    * the zero-order-hold response ``sinc(w dt / 2) exp(-i w dt / 2)`` of a
      signal held over each sample (see :func:`zoh_equivalent`).

    The padding is ``10 fs / fc`` samples (at most the record length): the
    Butterworth impulse response has decayed long before that. The first and
    last few filter lengths of a record are less reliable than the rest, as
    with any filter.

Cut-off
    :func:`suggest_cutoff` places the default cut-off where the signal's
    spectrum meets 100 times its noise floor (see there; it and
    :func:`noise_sd` live in :mod:`nlid.signal.noisefloor`, re-exported here). Pass ``cutoff``
    explicitly when the band of interest is known.

Complementary filter (:func:`complementary`)
    Displacement or velocity from a displacement trusted below a crossover
    frequency and an acceleration trusted above it: ``L(f)`` on the
    (differentiated) displacement plus ``1 - L(f)`` on the acceleration
    integrated twice (once), with ``L`` the low-pass above at the crossover.
    The two responses add up to one at every frequency, so nothing of the
    motion is lost or counted twice, and the integration needs no high-pass
    of its own (``1 - L`` vanishes like ``f^(2 n)`` at zero frequency).

Integration (:func:`integrate`)
    Cumulative trapezoidal integration followed by a zero-phase Butterworth
    high-pass (order 2, forwards-backwards) that removes the unknown constant
    and the drift that noise and offsets cause. Content below the high-pass
    frequency (default ``10 / duration``) cannot be recovered from an
    acceleration record and is removed.
"""

from __future__ import annotations

import functools
import threading
from collections import OrderedDict
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from ..base.validate import check_cutoff
from ..errors import InputError
from .noisefloor import CUTOFF_MAX_FRACTION, NOISE_BAND, noise_sd, suggest_cutoff

__all__ = [
    "DerivativeFilter",
    "complementary",
    "differentiate",
    "integrate",
    "lowpass",
    "lowpass_and_derivatives",
    "lowpass_columns",
    "noise_sd",
    "suggest_cutoff",
    "zoh_equivalent",
    "FILTER_ORDER",
    "CUTOFF_MAX_FRACTION",
    "NOISE_BAND",
]

#: Butterworth order of the default low-pass (applied forwards and backwards).
FILTER_ORDER = 4
#: Padding (in cut-off periods) added at each end before filtering.
PAD_PERIODS = 10.0


@dataclass(frozen=True)
class DerivativeFilter:
    """Settings of the zero-phase differentiating filter.

    Attributes
    ----------
    cutoff
        Low-pass cut-off in Hz.
    order
        Butterworth order (the magnitude is that of the filter applied twice).
    """

    cutoff: float
    order: int = FILTER_ORDER

    def describe(self) -> str:
        """One line saying what was done, for result provenance."""
        return (
            f"zero-phase low-pass (Butterworth order {self.order} magnitude, squared; fc={self.cutoff:.4g} Hz) "
            "+ spectral differentiation"
        )


def _pad_length(n: int, fs: float, cutoff: float | None) -> int:
    if cutoff is None:
        return min(n - 1, 64)
    return int(min(n - 1, max(64, np.ceil(PAD_PERIODS * fs / cutoff))))


def _extend(x: np.ndarray, pad: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Make ``x`` smoothly periodic: remove the line through its end samples,
    reflect the rest oddly at both ends and taper the reflections to zero.

    Returns the extended detrended signal and the line's offset and slope
    (per sample), which the caller transforms analytically.
    """
    n = x.shape[0]
    offset = x[0]
    slope = (x[-1] - x[0]) / (n - 1)
    k = np.arange(n).reshape((-1,) + (1,) * (x.ndim - 1))
    d = x - (offset + slope * k)  # zero at both ends
    taper = (0.5 - 0.5 * np.cos(np.pi * np.arange(pad) / pad)).reshape((-1,) + (1,) * (x.ndim - 1))
    left = -d[pad:0:-1] * taper
    right = -d[-2 : -pad - 2 : -1] * taper[::-1]
    return np.concatenate([left, d, right], axis=0), offset, slope


def _extend_into(x: np.ndarray, pad: int, buf: np.ndarray) -> tuple[float, float]:
    """:func:`_extend` of the 1-D ``x`` written into the zeroed ``buf`` (the FFT's zero padding follows it).

    The same operations on the same numbers as :func:`_extend` (the same
    values to the bit), without its temporaries and the concatenation;
    returns the line's offset and slope.
    """
    n = x.shape[0]
    offset = x[0]
    slope = (x[-1] - x[0]) / (n - 1)
    line = slope * np.arange(n)
    line += offset
    d = buf[pad : pad + n]
    np.subtract(x, line, out=d)  # zero at both ends
    del line
    taper = _taper(pad)
    np.multiply(d[pad:0:-1], taper, out=buf[:pad])  # -(a t) == (-a) t to the bit
    np.negative(buf[:pad], out=buf[:pad])
    right = buf[pad + n : 2 * pad + n]
    np.multiply(d[-2 : -pad - 2 : -1], taper[::-1], out=right)
    np.negative(right, out=right)
    return offset, slope


#: Bytes of filter responses kept for re-use (:func:`_response`): a few records' worth, not a long record's many.
RESPONSE_CACHE_BYTES = 32 * 2**20
_RESPONSES: OrderedDict[tuple, np.ndarray] = OrderedDict()
_RESPONSES_LOCK = threading.Lock()


def _response(
    size: int, fs: float, cutoff: float | None, order: int, derivative: int, hold: bool, complement: bool
) -> np.ndarray:
    """The shared zero-phase response at the ``rfft`` frequencies of ``size`` samples (see module docstring).

    Read-only, and computed once per set of arguments: the bias correction's simulated records filter
    hundreds of columns of one length at two cut-offs, and the response (a complex power of every frequency)
    cost as much as a transform. The most recently used responses are kept up to
    :data:`RESPONSE_CACHE_BYTES`.
    """
    key = (
        int(size),
        float(fs),
        None if cutoff is None else float(cutoff),
        int(order),
        int(derivative),
        hold,
        complement,
    )
    with _RESPONSES_LOCK:
        cached = _RESPONSES.get(key)
        if cached is not None:
            _RESPONSES.move_to_end(key)
            return cached
    response = _compute_response(*key)
    response.setflags(write=False)
    with _RESPONSES_LOCK:
        _RESPONSES[key] = response
        total = sum(r.nbytes for r in _RESPONSES.values())
        while total > RESPONSE_CACHE_BYTES and len(_RESPONSES) > 1:
            total -= _RESPONSES.popitem(last=False)[1].nbytes
        if total > RESPONSE_CACHE_BYTES:  # one response larger than the whole budget: not kept
            _RESPONSES.clear()
    return response


@functools.lru_cache(maxsize=16)
def _taper(pad: int) -> np.ndarray:
    """The raised-cosine taper of the reflections, ``pad`` samples (read-only, computed once per length)."""
    taper = 0.5 - 0.5 * np.cos(np.pi * np.arange(pad) / pad)
    taper.setflags(write=False)
    return taper


def _compute_response(
    size: int, fs: float, cutoff: float | None, order: int, derivative: int, hold: bool, complement: bool
) -> np.ndarray:
    """:func:`_response`, computed.

    The low-pass and the first two derivatives' ``(i w)^k`` are formed in real arithmetic: the same numbers
    to the bit as the complex products of the definition (each of them has a zero part, so no rounding
    differs; ``tests/signal/test_derivatives.py`` checks it), without complex powers and temporaries.
    """
    # rfftfreq's numbers (its integer ramp times 1 / (size d)), without the integer array
    freqs = np.arange(size // 2 + 1, dtype=float)
    freqs *= 1.0 / (size * (1.0 / fs))
    real = None if cutoff is None else 1.0 / (1.0 + (freqs / cutoff) ** (2 * order))
    if real is not None and complement:
        real = 1.0 - real
    response = np.zeros(freqs.size, dtype=complex)
    if derivative in (1, 2):
        # i w for k = 1, 0 - w w for k = 2 (the complex square's real part, +0 at f = 0); times the low-pass
        part = freqs * (2.0 * np.pi)
        if derivative == 2:
            np.multiply(part, part, out=part)
            np.subtract(0.0, part, out=part)
        if real is not None:
            np.multiply(real, part, out=part)
        if derivative == 1:
            response.imag = part
        else:
            response.real = part
    else:
        response.real = 1.0 if real is None else real
        if derivative > 0:
            response *= (2j * np.pi * freqs) ** derivative
        elif derivative < 0:  # integration (the complementary filter): zero at f = 0
            response[0] = 0.0
            response[1:] *= (2j * np.pi * freqs[1:]) ** derivative
    if hold:
        response *= np.sinc(freqs / fs) * np.exp(-1j * np.pi * freqs / fs)
    return response


def _apply(
    x: np.ndarray,
    fs: float,
    cutoff: float | None,
    *,
    order: int = FILTER_ORDER,
    derivative: int = 0,
    hold: bool = False,
    complement: bool = False,
) -> np.ndarray:
    """Apply the shared zero-phase response along axis 0 (see module docstring).

    ``complement`` applies ``1 - L(f)`` instead of the low-pass ``L(f)``;
    ``derivative`` may then be negative (integration, zero at ``f = 0``).
    """
    x = np.asarray(x, dtype=float)
    if cutoff is not None:
        check_cutoff(cutoff, fs)
    if x.ndim == 2:
        # one column at a time: the padded spectra of a whole regressor matrix would set the peak memory
        # of a long record (10^6 samples x 6 terms: ~0.3 GB of temporaries); the result is the same
        out = np.empty_like(x)
        _filter_columns(x, out, range(x.shape[1]), fs, cutoff, order, derivative, hold, complement)
        return out
    if x.ndim != 1:
        return _apply_nd(x, fs, cutoff, order, derivative, hold, complement)
    out = np.empty_like(x)
    _filter_columns(x[:, None], out[:, None], (0,), fs, cutoff, order, derivative, hold, complement)
    return out


#: Bytes of zero-padded input transformed at once by :func:`_filter_columns` (several columns of a short
#: record in one batched FFT; a long record's columns one at a time, which bounds the peak memory).
FILTER_BLOCK_BYTES = 4 * 2**20


def _filter_columns(
    x: np.ndarray,
    out: np.ndarray,
    columns: Iterable[int],
    fs: float,
    cutoff: float | None,
    order: int,
    derivative: int,
    hold: bool,
    complement: bool,
) -> None:
    """``out[:, j] =`` the shared response applied to ``x[:, j]`` for each ``j`` in ``columns`` (``out`` may be ``x``).

    The response is computed once for all the columns, and each column is
    extended straight into the FFT's zero-padded input (:func:`_extend_into`).
    Columns are transformed in blocks of up to :data:`FILTER_BLOCK_BYTES`
    of input, one row each, with one batched forward and inverse FFT per
    block (pocketfft applies the same one-dimensional plan to every row):
    the same numbers as filtering each column on its own, to the bit
    (``tests/signal/test_derivatives.py`` checks it), in about two thirds of the time
    for a record of 10^4-10^5 samples.
    """
    from scipy import fft as sp_fft

    columns = list(columns)
    if not columns:
        return
    n = x.shape[0]
    pad = _pad_length(n, fs, cutoff)
    size = sp_fft.next_fast_len(n + 2 * pad, real=True)
    response = _response(size, fs, cutoff, order, derivative, hold, complement)
    block = int(max(1, min(len(columns), FILTER_BLOCK_BYTES // (8 * size))))
    k = None
    for first in range(0, len(columns), block):
        js = columns[first : first + block]
        buf = np.zeros((len(js), size))
        lines = [_extend_into(x[:, j], pad, buf[i]) for i, j in enumerate(js)]
        spectrum = sp_fft.rfft(buf, axis=-1)
        del buf
        spectrum *= response
        filtered = sp_fft.irfft(spectrum, size, axis=-1)
        del spectrum
        for i, (j, (offset, slope)) in enumerate(zip(js, lines, strict=True)):
            col = filtered[i, pad : pad + n]
            # the removed line passes the low-pass unchanged (1 - L removes it entirely); a hold delays it by half
            # a sample
            if not complement and derivative in (0, 1):
                if derivative == 0:
                    if k is None:
                        k = np.arange(n) - (0.5 if hold else 0.0)
                    col += offset + slope * k
                else:
                    col += slope * fs
            out[:, j] = col


def _apply_nd(
    x: np.ndarray,
    fs: float,
    cutoff: float | None,
    order: int,
    derivative: int,
    hold: bool,
    complement: bool,
) -> np.ndarray:
    """:func:`_apply` along axis 0 of an array of three or more dimensions (all at once)."""
    from scipy import fft as sp_fft

    n = x.shape[0]
    pad = _pad_length(n, fs, cutoff)
    ext, offset, slope = _extend(x, pad)
    size = sp_fft.next_fast_len(ext.shape[0], real=True)
    spectrum = sp_fft.rfft(ext, size, axis=0)
    response = _response(size, fs, cutoff, order, derivative, hold, complement)
    shape = (-1,) + (1,) * (x.ndim - 1)
    out = sp_fft.irfft(spectrum * response.reshape(shape), size, axis=0)[pad : pad + n]
    if complement:  # 1 - L removes the line (and its integrals) entirely
        return out
    # the removed line passes the low-pass unchanged; a hold delays it by half a sample
    k = np.arange(n).reshape(shape) - (0.5 if hold else 0.0)
    if derivative == 0:
        out += offset + slope * k
    elif derivative == 1:
        out += slope * fs
    return out


def lowpass_columns(values: np.ndarray, fs: float, cutoff: float, columns: Iterable[int]) -> np.ndarray:
    """:func:`lowpass` of the given columns of the 2-D ``values``, in place (the other columns untouched).

    The same numbers as ``values[:, j] = lowpass(values[:, j], fs, cutoff)``
    for each ``j``, with the filter's response computed once for all of
    them. Returns ``values``.
    """
    check_cutoff(cutoff, fs)
    _filter_columns(values, values, columns, fs, float(cutoff), FILTER_ORDER, 0, False, False)
    return values


def lowpass_and_derivatives(x: np.ndarray, fs: float, cutoff: float, orders: Iterable[int]) -> list[np.ndarray]:
    """:func:`lowpass` (order 0) and :func:`differentiate` (orders 1, 2) of the 1-D ``x`` at one cut-off, one FFT.

    The signal is extended and transformed once and each response applied to
    that spectrum: the same numbers, to the bit, as ``lowpass(x, fs, cutoff)``
    and ``differentiate(x, fs, order=k, cutoff=cutoff)[0]``, for one forward
    transform instead of one per order.
    """
    from scipy import fft as sp_fft

    orders = [int(k) for k in orders]
    if any(k not in (0, 1, 2) for k in orders):
        raise InputError(f"orders must be 0 (the low-pass), 1 or 2, got {orders}")
    x = np.asarray(x, dtype=float)
    if x.ndim != 1 or x.size < 6:
        raise InputError("lowpass_and_derivatives needs a 1-D signal of at least 6 samples")
    cutoff = float(cutoff)
    check_cutoff(cutoff, fs)
    n = x.shape[0]
    pad = _pad_length(n, fs, cutoff)
    size = sp_fft.next_fast_len(n + 2 * pad, real=True)
    buf = np.zeros(size)
    offset, slope = _extend_into(x, pad, buf)
    spectrum = sp_fft.rfft(buf)
    del buf
    out = []
    for k in orders:
        # what _filter_columns does after the forward transform, order by order
        col = sp_fft.irfft(spectrum * _response(size, fs, cutoff, FILTER_ORDER, k, False, False), size)[pad : pad + n]
        if k == 0:
            col += offset + slope * (np.arange(n) - 0.0)
        elif k == 1:
            col += slope * fs
        out.append(col.copy())
    return out


def lowpass(x: np.ndarray, fs: float, cutoff: float, order: int = FILTER_ORDER) -> np.ndarray:
    """Zero-phase low-pass of ``x`` along its first axis.

    Parameters
    ----------
    x
        Signal(s), shape ``(N,)`` or ``(N, k)``.
    fs
        Sampling frequency in Hz.
    cutoff
        Cut-off frequency in Hz, ``0 < cutoff < fs / 2``.
    order
        Butterworth order; the magnitude applied is that of the filter run
        forwards and backwards.
    """
    return _apply(x, fs, float(cutoff), order=order)


def differentiate(
    x: np.ndarray,
    fs: float,
    *,
    order: int = 1,
    cutoff: float | None = None,
    filter_order: int = FILTER_ORDER,
) -> tuple[np.ndarray, DerivativeFilter]:
    """Estimate the first or second time derivative of a sampled signal.

    Parameters
    ----------
    x
        Uniformly sampled signal, shape ``(N,)``, ``N >= 6``.
    fs
        Sampling frequency in Hz.
    order
        1 for the first derivative (velocity from displacement), 2 for the
        second (acceleration from displacement).
    cutoff
        Low-pass cut-off in Hz. ``None`` chooses :func:`suggest_cutoff`.
    filter_order
        Butterworth order of the low-pass.

    Returns
    -------
    derivative : numpy.ndarray
        The estimate, same shape as ``x``.
    used : DerivativeFilter
        The filter that was applied (record it with the result).
    """
    if order not in (1, 2):
        raise InputError(f"derivative order must be 1 or 2, got {order}")
    x = np.asarray(x, dtype=float)
    if x.ndim != 1 or x.size < 6:
        raise InputError("differentiate needs a 1-D signal of at least 6 samples")
    if cutoff is None:
        cutoff = suggest_cutoff(x, fs)
    used = DerivativeFilter(cutoff=float(cutoff), order=filter_order)
    return _apply(x, fs, used.cutoff, order=filter_order, derivative=order), used


def complementary(
    z: np.ndarray | None,
    a: np.ndarray,
    fs: float,
    crossover: float,
    *,
    derivative: int = 0,
    order: int = FILTER_ORDER,
) -> np.ndarray:
    """Displacement or velocity from a displacement (low band) and an acceleration (high band).

    In the frequency domain, with ``L`` the shared zero-phase low-pass at the
    crossover and ``w = 2 pi f``::

        derivative 0:  Z_hat = L Z + (1 - L) A / (i w)^2
        derivative 1:  V_hat = L (i w) Z + (1 - L) A / (i w)

    ``L + (1 - L) = 1``: noise-free, consistent channels are reproduced at
    every frequency. Use it when the displacement is noisy at high
    frequencies (its noise is amplified by ``w`` in a derivative) and the
    acceleration at low frequencies (offsets and drift are amplified by
    ``1 / w^2`` in its integrals); the best crossover is where the two noise
    densities, in the same units, are equal.

    Parameters
    ----------
    z
        Displacement samples, shape ``(N,)``; ``None`` gives the acceleration
        path alone.
    a
        Acceleration samples, shape ``(N,)``, at the same instants.
    fs
        Sampling frequency in Hz.
    crossover
        Crossover frequency in Hz, ``0 < crossover < fs / 2``.
    derivative
        0 for the displacement, 1 for the velocity.
    order
        Butterworth order of ``L``.

    Returns
    -------
    numpy.ndarray
        The estimate, shape ``(N,)``.
    """
    if derivative not in (0, 1):
        raise InputError(f"complementary gives the displacement (0) or the velocity (1), not derivative {derivative}")
    check_cutoff(float(crossover), fs, name="crossover")
    out = _apply(a, fs, float(crossover), order=order, derivative=derivative - 2, complement=True)
    if z is not None:
        out = out + _apply(z, fs, float(crossover), order=order, derivative=derivative)
    return out


def zoh_equivalent(x: np.ndarray, fs: float, cutoff: float | None = None, order: int = FILTER_ORDER) -> np.ndarray:
    """In-band samples of a zero-order-held (staircase) signal, optionally low-passed.

    A force held constant over each sample interval (a DAC output, or the
    paper's simulation) is, in continuous time, a staircase whose spectrum is
    ``X(w) sinc(w dt / 2) exp(-i w dt / 2)``: it acts on the structure half a
    sample later than its sample times, and slightly attenuated. Quantities
    derived from the motion (a displacement differentiated through the
    low-pass) see that staircase, so a force compared with them must be
    passed through the same response.

    Parameters
    ----------
    x
        The held samples, shape ``(N,)`` or ``(N, k)``.
    fs
        Sampling frequency in Hz.
    cutoff
        Also apply the shared low-pass at this cut-off (Hz).
    order
        Butterworth order of that low-pass.
    """
    return _apply(x, fs, cutoff, order=order, hold=True)


def integrate(x: np.ndarray, fs: float, *, highpass: float | None = None) -> tuple[np.ndarray, float]:
    """Integrate a sampled signal once, removing drift.

    Parameters
    ----------
    x
        Uniformly sampled signal (e.g. acceleration), shape ``(N,)``.
    fs
        Sampling frequency in Hz.
    highpass
        Corner of the zero-phase Butterworth high-pass (order 2) that removes
        the integration constant and drift, in Hz. Default ``10 / duration``.

    Returns
    -------
    integral : numpy.ndarray
        The zero-mean, drift-free integral.
    highpass : float
        The high-pass corner that was used, in Hz.
    """
    x = np.asarray(x, dtype=float)
    duration = x.size / fs
    if highpass is None:
        highpass = 10.0 / duration
    check_cutoff(highpass, fs, name="highpass")
    y = np.concatenate(([0.0], np.cumsum(0.5 * (x[1:] + x[:-1])) / fs))
    from scipy import signal

    sos = signal.butter(2, highpass, btype="high", fs=fs, output="sos")
    return signal.sosfiltfilt(sos, y - y.mean()), float(highpass)
