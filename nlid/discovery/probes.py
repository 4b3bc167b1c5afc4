"""Remaining-structure probes: is the residual still predictable, and from what?

A model is complete when what it leaves in the force balance is noise. Each
probe asks how much of the *held-out* residual variance a flexible function
of one kind of information can predict, fitted on the estimation record
(and the reverse, cross-fitted: the fraction reported is the mean of
"fit on estimation, score on held-out" and "fit on held-out, score on
estimation"), so that noise cannot look like structure: a probe fitted to
noise predicts nothing out of sample (its fraction is then near or below 0).

==================  =====================================================================
probe               what it is given (besides a constant)
==================  =====================================================================
``z``               Legendre polynomials of the displacement, degree 1-8
``v``               Legendre polynomials of the velocity, degree 1-7, and ``sign(v)``
``z,v``             products of Legendre polynomials of z (0-4) and of v (1-4, ``sign(v)``)
``acceleration``    every function of (z, v) of the ``z``, ``v`` and ``z,v`` probes plus the
                    acceleration of the balance: a mass error leaves ``dm * a``; its fraction
                    is what the acceleration adds
``force-rate``      the same with the force's time derivative: a time skew ``dt`` between
                    the force and the motion leaves ``dt * f'``
``memory``          every function above of (z, v) plus the recent history of the motion: play
                    (backlash) operators of z of four widths (rate-independent
                    hysteresis: pre-sliding friction, Bouc-Wen) and z, v lagged by 1,
                    2, 4 and 8 periods of the equation band (an unmodelled mode, a
                    viscoelastic force); its fraction is what the history adds to the
                    static functions of (z, v)
``time``            every static function of (z, v) plus Legendre polynomials of time, degree
                    1-:data:`TIME_DEGREE`, across each record: a drift (a sensor's offset
                    creeping, a temperature) or a parameter that changes during the record.
                    A function of time fitted on one record cannot predict another, so this
                    probe is cross-fitted *within* each record, over :data:`TIME_BLOCKS`
                    interleaved blocks (fit on the even blocks, score on the odd ones, and the
                    reverse); its fraction is what time adds to the static functions under the
                    same split, averaged over both records
==================  =====================================================================

A probe finds structure when its fraction reaches :data:`MIN_STRUCTURE`
(5 % of the residual variance). The threshold was set from complete models at
1, 2 and 5 % noise (``tests/discovery/test_probes.py``; figures in
docs/discover.md): there the largest fraction over the probes stays below it.
The *dominant* probe is the one with the largest fraction (``memory`` counted
by its increment), except that a simpler probe explaining within
:data:`SIMPLER_WITHIN` of a richer one is named instead (``z`` or ``v`` rather
than ``z,v``; ``acceleration`` or ``force-rate``, one function each, rather
than a flexible function of the motion).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.polynomial import legendre

from ..scoring import Residual

__all__ = [
    "MIN_STRUCTURE",
    "PROBES",
    "TIME_DEGREE",
    "TIME_BLOCKS",
    "RESONANCE_GAIN",
    "RESONANCE_COHERENCE",
    "resonance",
    "ProbeResult",
    "Remaining",
    "probe_residual",
    "describe_remaining",
    "time_gain",
]

#: Smallest cross-fitted held-out fraction of the residual variance that counts as structure.
MIN_STRUCTURE = 0.05
#: Probe names, in report order.
PROBES = ("z", "v", "z,v", "acceleration", "force-rate", "memory", "time")
#: Widths of the play operators, as multiples of std(z).
PLAY_WIDTHS = (0.05, 0.15, 0.4, 1.0)
#: Lags of z and v, in periods of the equation band.
LAG_PERIODS = (1, 2, 4, 8)
#: Ridge penalty of the probes' fits, relative to the mean eigenvalue of the standardised Gram matrix
#: (0.01: measured to keep a 5-s held-out record's fit of the (z, v) products from extrapolating, while
#: the fractions of real structure change by under 0.01).
RIDGE = 0.01
#: Probes counted by what they add to every static function of (z, v) under the records' cross-fit (``time``
#: is too, under its own split within each record: :func:`time_gain`).
INCREMENTAL = ("acceleration", "force-rate", "memory")
#: Highest degree of the ``time`` probe's polynomials (3: a ramp, a bow and an S across the record; a drift slow
#: against the record's length).
TIME_DEGREE = 3
#: Interleaved blocks of each record over which the ``time`` probe is cross-fitted (8: a gap of 1/8 of the record
#: between the blocks a cubic in time is fitted on, which it bridges without extrapolating).
TIME_BLOCKS = 8


@dataclass(frozen=True)
class ProbeResult:
    """What one probe found.

    Attributes
    ----------
    name
        The probe (:data:`PROBES`).
    explained
        Cross-fitted fraction of the residual variance it predicts (for
        ``memory``: the increment over ``z,v``).
    explained_holdout, explained_estimation
        The two directions: fitted on the other record, scored on this one.
    columns
        Number of functions it was given.
    structured
        ``explained >= threshold``.
    """

    name: str
    explained: float
    explained_holdout: float
    explained_estimation: float
    columns: int
    structured: bool

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly dictionary."""
        return {
            "explained": self.explained,
            "explained_holdout": self.explained_holdout,
            "explained_estimation": self.explained_estimation,
            "columns": self.columns,
            "structured": self.structured,
        }


@dataclass(frozen=True)
class Remaining:
    """The verdict of the probes on one model.

    Attributes
    ----------
    structured
        True when some probe finds structure.
    explained_holdout
        The largest cross-fitted fraction over the probes (``memory`` as its
        total, ``z,v`` plus history).
    dominant
        The probe with the largest fraction (``None`` when nothing is found).
    probes
        Every probe's result.
    threshold
        :data:`MIN_STRUCTURE` used.
    residual_of_force
        RMS of the held-out residual relative to the RMS force (the scale of
        what remains).
    resonance_hz
        When memory is what remains: the frequency of a resonance through which the residual follows the
        motion (:func:`resonance`), a mode the model lacks; ``None`` when there is none.
    """

    structured: bool
    explained_holdout: float
    dominant: str | None
    probes: dict[str, ProbeResult] = field(default_factory=dict)
    threshold: float = MIN_STRUCTURE
    residual_of_force: float = float("nan")
    resonance_hz: float | None = None

    def to_dict(self) -> dict[str, Any]:
        """The ``remaining`` object of ``nlid discover --json``."""
        return {
            "structured": self.structured,
            "explained_holdout": self.explained_holdout,
            "dominant": self.dominant,
            "threshold": self.threshold,
            "residual_of_force": self.residual_of_force,
            "resonance_hz": self.resonance_hz,
            "text": describe_remaining(self),
            "probes": {k: v.to_dict() for k, v in self.probes.items()},
        }


def _legendre(x: np.ndarray, degrees: range) -> np.ndarray:
    cols = []
    for d in degrees:
        c = np.zeros(d + 1)
        c[d] = 1.0
        cols.append(legendre.legval(x, c))
    return np.column_stack(cols) if cols else np.empty((x.size, 0))


def _play(z: np.ndarray, width: float) -> np.ndarray:
    """The play (backlash) operator of width ``width`` minus its input: a hysteretic feature in ``[-w, w]``."""
    from ..model.terms.memory_kernels import play_loop

    z = np.ascontiguousarray(z, dtype=float)
    out = np.empty_like(z)
    play_loop(z, float(width), out)
    return out


class _Scaler:
    """Maps z and v onto the range of the record a probe is fitted on (applied to both records)."""

    def __init__(self, est: Residual, shortest: int):
        self.shortest = shortest  # the shorter record's length: both records get the same lagged features
        self.z_mid = 0.5 * (float(est.z.max()) + float(est.z.min()))
        self.z_half = max(0.5 * float(np.ptp(est.z)), 1e-300)
        self.v_half = max(float(np.max(np.abs(est.v))), 1e-300)
        self.z_std = max(float(np.std(est.z)), 1e-300)
        self.fs = est.fs
        self.band = est.band_hz or 0.1 * est.fs

    def xz(self, res: Residual) -> np.ndarray:
        return np.clip((res.z - self.z_mid) / self.z_half, -1.0, 1.0)

    def xv(self, res: Residual) -> np.ndarray:
        return np.clip(res.v / self.v_half, -1.0, 1.0)

    def parts(self, res: Residual) -> dict[str, Any]:
        """The blocks the probes' design matrices are made of (each probe's matrix: :func:`_design`)."""
        xz, xv = self.xz(res), self.xv(res)
        sv = np.sign(res.v)
        z_basis = _legendre(xz, range(1, 9))
        v_basis = np.column_stack([_legendre(xv, range(1, 8)), sv])
        zp = _legendre(xz, range(0, 5))
        vp = np.column_stack([_legendre(xv, range(1, 5)), sv])
        zv = np.column_stack(
            [zp[:, i] * vp[:, j] for i in range(zp.shape[1]) for j in range(vp.shape[1])] + [zp[:, 1:]]
        )
        history = [_play(res.z, w * self.z_std) / self.z_std for w in PLAY_WIDTHS]
        for periods in LAG_PERIODS:
            lag = int(round(periods * self.fs / self.band))
            if 0 < lag < self.shortest // 4:
                for x in (xz, xv):
                    shifted = np.empty_like(x)
                    shifted[lag:] = x[:-lag]
                    shifted[:lag] = x[0]
                    history.append(shifted)
        return {"z": z_basis, "v": v_basis, "z,v": zv, "a": res.a, "f": res.f, "fs": res.fs, "history": history}


def _design(parts: dict[str, Any], name: str) -> np.ndarray:
    """The design matrix of probe ``name`` (or ``"static"``) from :meth:`_Scaler.parts`.

    Built when needed and dropped after use: holding every probe's matrix for both records at once
    made the probes the memory peak of ``nlid discover`` (several kB per sample).
    """
    if name in ("z", "v", "z,v"):
        return parts[name]
    static = np.column_stack([parts["z"], parts["v"], parts["z,v"]])
    if name == "static":
        return static
    if name == "acceleration":
        return np.column_stack([static, parts["a"]])
    if name == "force-rate":
        return np.column_stack([static, np.gradient(parts["f"]) * parts["fs"]])
    if name == "memory":
        return np.column_stack([static, *parts["history"]]) if parts["history"] else static
    raise KeyError(name)


def _explained(x_fit: np.ndarray, r_fit: np.ndarray, x_test: np.ndarray, r_test: np.ndarray, skip: int) -> float:
    """Fraction of ``r_test``'s variance predicted by least squares on ``(x_fit, r_fit)`` (constant included)."""
    a = np.column_stack([np.ones(r_fit.size - skip), x_fit[skip:]])
    b = np.column_stack([np.ones(r_test.size - skip), x_test[skip:]])
    scale = np.sqrt(np.mean(a**2, axis=0))
    scale[scale == 0] = 1.0
    a /= scale
    b /= scale
    # ridge regression on standardised columns: the held-out record may be short, and a flexible
    # basis fitted to few samples must not extrapolate wildly within the other record's range
    gram = a.T @ a
    gram[np.diag_indices_from(gram)] += RIDGE * np.trace(gram) / gram.shape[0]
    coef = np.linalg.solve(gram, a.T @ r_fit[skip:])
    pred = b @ coef
    target = r_test[skip:]
    total = float(np.sum((target - target.mean()) ** 2))
    if total <= 0:
        return 0.0
    return float(1.0 - np.sum((target - pred) ** 2) / total)


def probe_residual(estimation: Residual, holdout: Residual, threshold: float = MIN_STRUCTURE) -> Remaining:
    """Run every probe on a model's residual on the estimation and held-out records (module docstring).

    Parameters
    ----------
    estimation, holdout
        :func:`nlid.scoring.residual` of the same model on both records (same band).
    threshold
        Fraction that counts as structure.
    """
    # each direction scales (and clips) both records to the range of the record it fits on, so that no
    # polynomial is asked to extrapolate beyond the data it was fitted to
    shortest = min(estimation.z.size, holdout.z.size)
    fit_est, fit_ho = _Scaler(estimation, shortest), _Scaler(holdout, shortest)
    pe_e, ph_e = fit_est.parts(estimation), fit_est.parts(holdout)
    ph_h, pe_h = fit_ho.parts(holdout), fit_ho.parts(estimation)
    # the history features need a warm-up: leave out the longest lag at the start of each record
    skip = int(round(max(LAG_PERIODS) * fit_est.fs / fit_est.band))
    skip = min(skip, estimation.z.size // 4, holdout.z.size // 4)
    results: dict[str, ProbeResult] = {}
    raw: dict[str, tuple[float, float]] = {}
    columns: dict[str, int] = {}
    for name in (*PROBES, "static"):
        if name == "time":  # cross-fitted within each record (module docstring)
            raw[name] = (_time_gain(ph_h, holdout.r), _time_gain(pe_e, estimation.r))
            continue
        x_fit = _design(pe_e, name)
        columns[name] = x_fit.shape[1]
        ho = _explained(x_fit, estimation.r, _design(ph_e, name), holdout.r, skip)
        del x_fit
        es = _explained(_design(ph_h, name), holdout.r, _design(pe_h, name), estimation.r, skip)
        raw[name] = (ho, es)
    columns["time"] = columns["static"] + TIME_DEGREE
    # what the acceleration, the force rate and the history add to every static function of (z, v);
    # a static fit that predicts nothing counts as 0 (time's gain is already an increment, under its own split)
    base_ho, base_es = (max(x, 0.0) for x in raw["static"])
    for name in PROBES:
        ho, es = raw[name]
        if name in INCREMENTAL:
            ho, es = ho - base_ho, es - base_es
        value = 0.5 * (ho + es)
        results[name] = ProbeResult(name, value, ho, es, columns[name], value >= threshold)
    total = {n: results[n].explained for n in PROBES}
    total.update({n: 0.5 * sum(raw[n]) for n in INCREMENTAL})
    structured = any(r.structured for r in results.values())
    scale = float(np.sqrt(np.mean(holdout.r**2)) / max(np.sqrt(np.mean(holdout.f**2)), 1e-300))
    dominant = _dominant(results) if structured else None
    mode = resonance(estimation, fit_est.band) if dominant == "memory" else None
    return Remaining(structured, max(total.values()), dominant, results, threshold, scale, mode)


#: A resonance of the residual's response to the motion is named when its gain stands this many times above
#: the median gain in the band, where the residual is this coherent with the motion. Measured on a Duffing
#: oscillator (1 kg, 50.3 Hz) with a hidden appendage of 5-10 % of its mass tuned to 0.6, 1 and 1.6 times its
#: frequency (``tests/discovery/test_probes.py``): gains of 9.6-12.5 times the median at coherences of
#: 0.75-0.93, named at 29.3, 48.8-52.7 (the tuned appendage splits the mode) and 82.0 Hz against 30.2, 50.3
#: and 80.5 Hz; a Bouc-Wen, Dahl or Coulomb law missing from the double well: 1.4-2.6 times at most; a
#: complete model: noise, coherence below 0.25.
RESONANCE_GAIN, RESONANCE_COHERENCE = 5.0, 0.5


def resonance(res: Residual, band: float) -> float | None:
    """The frequency (Hz) where the residual follows the motion through a resonance, or ``None``.

    The residual's response to the displacement, ``H(f) = S_zr / S_zz`` (Welch, segments of a sixteenth of
    the record), is searched below ``band`` for its largest gain weighted by the coherence; it is a
    resonance when that gain is :data:`RESONANCE_GAIN` times the band's median, the coherence there is
    at least :data:`RESONANCE_COHERENCE`, and the gain falls to half of it on both sides within the band
    (Silverbox's final model: a gain that rises to the band's edge, 198.5 of 200.3 Hz, is not one): a mode
    of the structure that the model does not hold (an appendage, a second degree of freedom coupled to this
    one).
    """
    from scipy import signal

    n = 2 ** int(np.log2(max(res.z.size / 16, 16)))
    f, szz = signal.welch(res.z, res.fs, nperseg=n)
    _, szr = signal.csd(res.z, res.r, res.fs, nperseg=n)
    _, srr = signal.welch(res.r, res.fs, nperseg=n)
    inside = (f > 0) & (f <= band) & (szz > 0) & (srr > 0)
    if np.count_nonzero(inside) < 8:
        return None
    gain = np.abs(szr[inside]) / szz[inside]
    coherence = np.abs(szr[inside]) ** 2 / (szz[inside] * srr[inside])
    k = int(np.argmax(gain * coherence))
    if gain[k] < RESONANCE_GAIN * float(np.median(gain)) or coherence[k] < RESONANCE_COHERENCE:
        return None
    if not (np.any(gain[:k] < 0.5 * gain[k]) and np.any(gain[k + 1 :] < 0.5 * gain[k])):
        return None  # a gain that rises to the band's edge (a mass error's w^2) is no resonance
    return float(f[inside][k])


def _time_gain(parts: dict[str, Any], r: np.ndarray) -> float:
    """What polynomials of time add to the static functions of (z, v) in predicting ``r`` (one record)."""
    return time_gain(r, _design(parts, "static"))


def time_gain(r: np.ndarray, static: np.ndarray | None = None) -> float:
    """What polynomials of time (degree 1-:data:`TIME_DEGREE` across the record) add to ``static`` (columns; none:
    a constant only) in predicting ``r``, cross-fitted within the record.

    The record is cut into :data:`TIME_BLOCKS` blocks; both designs are fitted on the even blocks and scored on
    the odd ones, and the reverse; the gain is the mean difference of the fractions predicted.
    """
    static = np.empty((r.size, 0)) if static is None else static
    time = _legendre(np.linspace(-1.0, 1.0, r.size), range(1, TIME_DEGREE + 1))
    both = np.column_stack([static, time])
    even = (np.arange(r.size) * TIME_BLOCKS // r.size) % 2 == 0
    gain = 0.0
    for fit, test in ((even, ~even), (~even, even)):
        gain += _explained(both[fit], r[fit], both[test], r[test], 0)
        if static.shape[1]:
            gain -= _explained(static[fit], r[fit], static[test], r[test], 0)
    return 0.5 * gain


#: A simpler probe is named dominant when it explains within this much of a richer one.
SIMPLER_WITHIN = 0.05


def _dominant(results: dict[str, ProbeResult]) -> str:
    """The probe that best names what remains, preferring the simpler of two that explain about as much."""
    e = {n: r.explained for n, r in results.items()}
    best = max(PROBES, key=lambda n: e[n])
    if best == "z,v" and max(e["z"], e["v"]) >= e["z,v"] - SIMPLER_WITHIN:
        best = "z" if e["z"] >= e["v"] else "v"
    single = max(("acceleration", "force-rate"), key=lambda n: e[n])
    if best != single and results[single].structured and e[single] >= e[best] - SIMPLER_WITHIN:
        best = single  # one function explains about as much as a flexible family: name it
    return best


_WHERE = {
    "z": "a function of the displacement: a stiffness law outside the model (a gap or stop, a higher power)",
    "v": "a function of the velocity: a friction or damping law outside the model",
    "z,v": "a function of position and velocity together: position-dependent friction or damping",
    "acceleration": "the acceleration: a wrong mass, or an inertial effect the model lacks",
    "force-rate": "the force's rate of change: the force and the motion are skewed in time",
    "memory": "the motion's history beyond the instantaneous (z, v): an effect with memory "
    "(hysteresis, pre-sliding friction, an unmodelled mode)",
    "time": "time itself, beyond any function of (z, v): a drift (a sensor's offset creeping, a temperature) or a "
    "parameter that changes during the record",
}
_TRY = {
    "z": "try stiffness candidates (gap, stop, z^5) or a candidate of your own",
    "v": "try friction candidates (stribeck, dictionary) or your own",
    "z,v": "try position-dependent friction (sign(v)*|px(z)|) or products in the dictionary",
    "acceleration": "let the method estimate the mass (omit it) or check the value given",
    "force-rate": "check the channels' synchronisation (anti-aliasing filters, sample-and-hold) and align them",
    "memory": "try hysteretic terms (bouc_wen(a, b), dahl(rho)) or a model with more states",
    "time": "check the sensors for drift (detrend or high-pass a drifting displacement before identifying) and "
    "identify on parts short enough to be stationary",
}


def describe_remaining(remaining: Remaining) -> str:
    """One or two sentences: clean, or how much remains, predictable from what, and what to try."""
    if not remaining.structured or remaining.dominant is None:
        best = max(remaining.probes.values(), key=lambda p: p.explained, default=None)
        tail = "" if best is None else f" (largest: {best.name}, {100 * max(best.explained, 0.0):.2g} %)"
        return (
            f"clean: no probe predicts {100 * remaining.threshold:g} % or more of the held-out residual variance{tail}"
        )
    d = remaining.dominant
    share = remaining.probes[d].explained
    scale = ""
    if np.isfinite(remaining.residual_of_force):
        scale = f" (about {100 * np.sqrt(share) * remaining.residual_of_force:.2g} % of the force's RMS)"
    where = _WHERE[d]
    if d == "memory" and remaining.resonance_hz is not None:
        where += (
            f"; the residual follows the motion through a resonance near {remaining.resonance_hz:.3g} Hz, as a mode "
            "the model lacks would"
        )
    return f"{100 * share:.2g} % of the held-out residual variance{scale} remains predictable from {where}; {_TRY[d]}"
