"""Measurement-noise levels of the channels the regressors are built from.

The bias correction (:mod:`nlid.bayes.bias`) simulates the identified model
and adds white noise to the channels the regressors are evaluated on: the
displacement ``z`` always, the velocity ``v`` when it is measured and the
model uses it. Its answer is only as good as those noise levels: a level
twice too high over-corrects by about four times the true bias. Each level is
either given (``noise={"z": ..., "v": ...}``, SI units of the channel) or
established from the record, each channel by the method that holds for it:

``z``: the noise floor
    :func:`nlid.signal.derivatives.noise_sd`: the median power spectral density
    between 0.35 and 0.45 fs, where a displacement's motion has died away
    (it falls like ``f^-4`` above the resonances when the force is white,
    faster when it is band-limited). Measured on both presets at 1-5 % noise
    the floor reads 0.99 of the true level.

``v``: the consistency of ``v`` with ``dz/dt``, never its own floor
    A velocity's motion falls only like ``f^-2`` above the resonances, so its
    "floor" can be mostly motion: on ``paper-numerical`` (white force) it
    reads 9, 4.7 and 2.1 times the true noise at 1, 2 and 5 %, and the
    correction built on it moved ``v`` and ``v*|v|`` by 7-14 standard
    deviations away from the truth (issue 15). Instead,
    ``r = L v - L D z`` (``D`` the exact spectral derivative, ``L`` the
    shared zero-phase low-pass at 0.45 fs applied to both, so the motion
    cancels at every frequency) holds noise only, with the one-sided density

        ``S_r(f) = |L(f)|^2 (N_v + (2 pi f)^2 N_z)``,   ``N_c = 2 sigma_c^2 / fs``.

    ``N_v`` and ``N_z`` are fitted to the Welch periodogram of ``r``
    (Hann window, whose side lobes keep the steep ``f^2`` part from leaking
    into the low bins; ``K`` non-overlapping segments, so each bin is an
    ``S chi^2_{2K} / 2K`` variable) by iteratively reweighted
    least squares, the weights ``1 / S^2`` of the fitted model (the Whittle
    likelihood's scoring step; unbiased whatever the distribution's skew).
    ``N_v`` is read from the low frequencies, where the velocity's own noise
    dominates, ``N_z`` from the high ones.

    The level is *established* only when

    * the periodogram follows that model: in each of ``BANDS`` log-spaced
      bands the mean of ``P / S`` lies within ``max(BAND_TOLERANCE,
      4 / sqrt(K n_b))`` of 1 (a velocity sensor whose response or timing
      differs from the displacement sensor's leaves motion in ``r`` and fails
      this);
    * ``N_v`` is determined: its standard error (from the fit's information,
      inflated by the reduced chi-square when above 1) is at most
      ``MAX_RELATIVE_SE`` of it;
    * the ``z`` level the fit implies agrees with the one the ``z`` floor
      gives (within ``max(Z_TOLERANCE, 4`` standard errors)): a floor holding
      motion, or non-white noise on ``z``, fails this.

    Otherwise :class:`UnknownNoiseError` says what was found and asks for
    the level (``noise={"v": ...}``): a correction on a guessed level would
    give confident, wrong intervals.

The noise on a measured acceleration needs no level: it enters ``y = f - m a``
linearly and independently of the regressors.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass

import numpy as np
from scipy import signal

from ..base.validate import NOISE_SD_CHANNELS, NOISE_UNITS, check_noise_sd
from ..data.record import Record
from ..errors import DataError, InputError
from ..model.terms import Model
from ..signal import derivatives

__all__ = [
    "NoiseLevel",
    "UnknownNoiseError",
    "channel_noise",
    "velocity_noise",
    "VelocityNoiseFit",
    "MAX_RELATIVE_SE",
]

#: Channels whose noise the bias correction simulates, and their units (SI; declared with their rule).
NOISY_CHANNELS = NOISE_SD_CHANNELS
UNITS = NOISE_UNITS
#: Cut-off of the low-pass shared by ``v`` and ``dz/dt``, as a fraction of fs.
CONSISTENCY_CUTOFF = 0.45
#: Highest frequency of the fit, as a fraction of fs.
FIT_MAX_FRACTION = 0.4
#: Welch segments of the residual: at least this many (non-overlapping).
SEGMENTS = 16
#: Log-spaced bands of the goodness-of-fit check.
BANDS = 8
#: Largest accepted deviation of a band's mean ``P / S`` from 1 (beyond 4 of its standard errors).
BAND_TOLERANCE = 0.25
#: Largest accepted relative standard error of the fitted velocity noise variance ``N_v``.
MAX_RELATIVE_SE = 0.5
#: Largest accepted relative difference of the displacement noise variances of the floor and of the fit.
Z_TOLERANCE = 0.3
#: Samples dropped at each end of the residual (filter transients).
EDGE = 64


class UnknownNoiseError(DataError):
    """The noise level of a channel cannot be established from the record: it must be given.

    Parameters
    ----------
    reason
        What was found (without the remedy).
    channels
        The channels whose levels must be given.
    """

    def __init__(self, reason: str, channels: tuple[str, ...]):
        self.reason = reason
        self.channels = tuple(channels)
        wanted = ", ".join(f"{c!r}: sd in {UNITS[c]}" for c in self.channels)
        super().__init__(
            f"{reason}; give the level (noise={{{wanted}}}) from the sensor's specification or a record at rest"
        )

    def __reduce__(self):  # keeps the structured fields across processes (pickle)
        return (type(self), (self.reason, self.channels))


@dataclass(frozen=True)
class NoiseLevel:
    """Noise standard deviation of one channel and where it comes from.

    Attributes
    ----------
    channel
        ``"z"`` or ``"v"``.
    sd
        Standard deviation of the white measurement noise, SI unit of the channel.
    source
        ``"given"``, ``"noise floor"`` or ``"v - dz/dt"``.
    relative_se
        Relative standard error of the variance ``sd^2`` (``None`` when given).
    """

    channel: str
    sd: float
    source: str
    relative_se: float | None = None

    def to_dict(self) -> dict[str, object]:
        """Plain dictionary (JSON)."""
        return asdict(self)

    def describe(self, unit: str | None = None) -> str:
        """E.g. ``"v = 0.014 m/s (v - dz/dt, sd +/- 3 %)"`` (the sd's relative error is half the variance's).

        ``unit``: the channel's unit when the record is not in SI (``"V"`` for a displacement in volts).
        """
        extra = "" if self.relative_se is None else f", sd +/- {50 * self.relative_se:.0f} %"
        unit = UNITS.get(self.channel, "") if unit is None else unit
        return f"{self.channel} = {self.sd:.3g} {unit} ({self.source}{extra})"


@dataclass(frozen=True)
class VelocityNoiseFit:
    """The fit of ``S_r(f) = |L|^2 (N_v + w^2 N_z)`` to the periodogram of ``L v - L D z``.

    Attributes
    ----------
    v_sd, z_sd
        ``sqrt(N fs / 2)`` of the fitted densities (m/s and m).
    v_relative_se, z_relative_se
        Relative standard errors of ``N_v`` and ``N_z``.
    band_ratios
        ``(f_low, f_high, mean P/S, allowed deviation)`` of each band.
    segments
        Number of Welch segments ``K``.
    chi2
        Reduced chi-square of the fit (1 for the model's scatter).
    """

    v_sd: float
    z_sd: float
    v_relative_se: float
    z_relative_se: float
    band_ratios: tuple[tuple[float, float, float, float], ...]
    segments: int
    chi2: float

    def worst_band(self) -> tuple[float, float, float, float] | None:
        """The band whose mean ``P / S`` deviates most beyond its allowance, or ``None`` if none does."""
        bad = [b for b in self.band_ratios if abs(b[2] - 1.0) > b[3]]
        return max(bad, key=lambda b: abs(b[2] - 1.0) / b[3]) if bad else None


def velocity_noise(z: np.ndarray, v: np.ndarray, fs: float) -> VelocityNoiseFit:
    """Fit the noise levels of a measured velocity and displacement from their consistency.

    See the module docstring: the motion cancels in ``L v - L D z``, whose
    density is ``|L|^2 (N_v + (2 pi f)^2 N_z)``.

    Parameters
    ----------
    z, v
        Displacement (m) and velocity (m/s) of the same motion, shape ``(N,)``.
    fs
        Sampling frequency in Hz.

    Raises
    ------
    DataError
        If the record is too short for the fit.
    """
    z = np.asarray(z, dtype=float)
    v = np.asarray(v, dtype=float)
    n = z.size
    nper = (n - 2 * EDGE) // SEGMENTS
    if nper < 64:
        raise DataError(f"too few samples ({n}) to establish the velocity's noise level from v - dz/dt")
    fc = CONSISTENCY_CUTOFF * fs
    dz, _ = derivatives.differentiate(z, fs, order=1, cutoff=fc)
    r = (derivatives.lowpass(v, fs, fc) - dz)[EDGE : n - EDGE]
    window = signal.get_window("hann", nper)
    freqs, P = signal.welch(r, fs=fs, window=window, nperseg=nper, noverlap=0, detrend="constant")
    segments = r.size // nper
    # periodogram values of neighbouring bins are correlated through the window: the fit's information
    # is divided by 1 + 2 sum_m rho_m, rho_m the correlation at a lag of m bins (white noise)
    w2 = window**2
    lags = np.abs(np.fft.rfft(w2))[1:8] / w2.sum()
    design = 1.0 + 2.0 * float(np.sum(lags**2))
    keep = (freqs > 0) & (freqs <= FIT_MAX_FRACTION * fs)
    f, P = freqs[keep], P[keep]
    gain = 1.0 / (1.0 + (f / fc) ** (2 * derivatives.FILTER_ORDER))
    X = (gain**2)[:, None] * np.column_stack([np.ones_like(f), (2 * np.pi * f) ** 2])
    # scale the columns so the normal equations are well conditioned; keep each level above a
    # negligible floor so the weights 1 / S^2 stay finite
    col = np.sqrt(np.mean(X**2, axis=0))
    Xs = X / col
    floor = 1e-9 * np.mean(P) / np.mean(Xs, axis=0)
    beta = np.maximum(np.linalg.lstsq(Xs, P, rcond=None)[0], floor)
    S = Xs @ beta
    for _ in range(50):
        Wx = Xs / S[:, None] ** 2
        beta_new = np.maximum(np.linalg.solve(Wx.T @ Xs, Wx.T @ P), floor)
        S_new = Xs @ beta_new
        done = np.max(np.abs(S_new / S - 1.0)) < 1e-10
        beta, S = beta_new, S_new
        if done:
            break
    info = segments * (Xs / S[:, None]).T @ (Xs / S[:, None]) / design
    resid = P / S - 1.0
    chi2 = float(segments * np.sum(resid**2) / max(1, f.size - 2))
    cov = np.linalg.inv(info) * max(1.0, chi2)
    rel_se = np.sqrt(np.diag(cov)) / beta
    N = beta / col
    edges = np.geomspace(f[0], f[-1] * (1 + 1e-12), BANDS + 1)
    bands = []
    for lo, hi in zip(edges[:-1], edges[1:], strict=True):
        sel = (f >= lo) & (f < hi)
        if sel.sum() == 0:
            continue
        ratio = float(np.mean(P[sel] / S[sel]))
        allowed = max(BAND_TOLERANCE, 4.0 * np.sqrt(design / (segments * sel.sum())))
        bands.append((float(lo), float(hi), ratio, float(allowed)))
    return VelocityNoiseFit(
        v_sd=float(np.sqrt(N[0] * fs / 2.0)),
        z_sd=float(np.sqrt(N[1] * fs / 2.0)),
        v_relative_se=float(rel_se[0]),
        z_relative_se=float(rel_se[1]),
        band_ratios=tuple(bands),
        segments=int(segments),
        chi2=chi2,
    )


def _given(noise: Mapping[str, float] | None, record: Record) -> dict[str, float]:
    """The given levels, checked (each against the standard deviation of its channel in ``record``)."""
    known = noise if isinstance(noise, Mapping) else {}
    scales = {
        c: float(np.std(getattr(record, c))) for c in NOISY_CHANNELS if c in known and getattr(record, c) is not None
    }
    return check_noise_sd(noise, scales=scales)


def channel_noise(record: Record, model: Model, noise: Mapping[str, float] | None = None) -> dict[str, NoiseLevel]:
    """Noise level of each channel the regressors are built from.

    ``z`` always; ``v`` when it is measured and the model uses it. Levels in
    ``noise`` win; the others are established from the record as the module
    docstring says.

    Parameters
    ----------
    record, model
        The data and the model.
    noise
        Known standard deviations, e.g. ``{"z": 4e-4, "v": 0.014}`` (m, m/s).

    Raises
    ------
    UnknownNoiseError
        When a level cannot be established from the record (the message
        says why and names ``noise=``).
    InputError
        A bad level in ``noise``.
    """
    given = _given(noise, record)
    if "v" in given and not record.is_measured("v"):
        raise InputError(
            "noise={'v': ...} is given but the record has no measured velocity (it is estimated from z, "
            "whose noise level is all the correction needs): drop it"
        )
    channels = ["z"] + (["v"] if model.uses_velocity and record.is_measured("v") else [])
    out: dict[str, NoiseLevel] = {}
    if "z" in given:
        out["z"] = NoiseLevel("z", given["z"], "given")
    elif not record.is_measured("z"):
        raise UnknownNoiseError(
            f"the displacement is not measured ({record.source_of('z')}): its noise is not white and its level "
            "cannot be read from the record",
            ("z",),
        )
    else:
        out["z"] = NoiseLevel("z", derivatives.noise_sd(record.z, record.fs), "noise floor")
    if "v" not in channels:
        return out
    if "v" in given:
        out["v"] = NoiseLevel("v", given["v"], "given")
        return out
    if not record.is_measured("z"):
        raise UnknownNoiseError(
            "the velocity's noise level is established from its consistency with a measured displacement, "
            "which this record lacks",
            ("v",),
        )
    fit = velocity_noise(record.z, record.v, record.fs)
    bad = fit.worst_band()
    if bad is not None:
        raise UnknownNoiseError(
            f"the velocity's noise level cannot be established: v - dz/dt is not white noise on v plus "
            f"differentiated white noise on z (between {bad[0]:.3g} and {bad[1]:.3g} Hz it holds {bad[2]:.2f} "
            "times the fitted density; the sensors' responses or timing may differ)",
            ("v",),
        )
    if fit.v_relative_se > MAX_RELATIVE_SE:
        raise UnknownNoiseError(
            f"the velocity's noise level cannot be established: v - dz/dt gives {fit.v_sd:.3g} m/s with a "
            f"relative standard error of {100 * fit.v_relative_se:.0f} % on its variance (at most "
            f"{100 * MAX_RELATIVE_SE:.0f} % accepted)",
            ("v",),
        )
    if out["z"].source == "noise floor":
        z_var, fit_var = out["z"].sd ** 2, fit.z_sd**2
        allowed = max(Z_TOLERANCE, 4.0 * fit.z_relative_se)
        if abs(fit_var / z_var - 1.0) > allowed:
            raise UnknownNoiseError(
                f"the noise levels cannot be established: the displacement's noise floor says {out['z'].sd:.3g} m "
                f"but v - dz/dt says {fit.z_sd:.3g} m (the floor may hold motion, or the noise is not white)",
                ("z", "v"),
            )
    out["v"] = NoiseLevel("v", fit.v_sd, "v - dz/dt", fit.v_relative_se)
    return out
