"""A peer row: pysindy SINDy, run as a competent user of pysindy would fit a forced oscillator.

What the peer does (and nothing of nlid's identification):

* the state is ``x = (z, v)`` with ``v`` differentiated from ``z`` by one of pysindy's
  differentiation methods (:data:`DIFFERENTIATION`: ``FiniteDifference``, its default;
  ``SmoothedFiniteDifference``, Savitzky-Golay smoothing first; ``SpectralDerivative``, exact
  within the band of a band-limited record), which SINDy also uses for ``x'``;
* continuous-time SINDy with control, ``ps.SINDy(feature_library=..., optimizer=ps.STLSQ(threshold,
  normalize_columns=True), differentiation_method=...).fit(x, t=dt, u=f)``, on a polynomial library
  of ``(z, v)`` up to the declared degree (with a constant), the force ``u`` linearly, and
  ``sign(v)`` (friction) when the benchmark asks for it. The columns are normalised (pysindy's
  advice when library terms differ in scale, as ``z^3`` and ``u`` do on a record in volts): with
  raw columns, STLSQ's ridge term (``alpha = 0.05``) shrinks the coefficient of a column whose norm
  is tiny (``z^3`` of a 50 mV signal) and the model is wrong for that reason alone;
* the differentiation method and the STLSQ threshold are chosen from the declared grid by the
  free-run error on the last part of the *estimation* record (fitted on the rest), as pysindy's
  tutorial on evaluating a model advises ("there's no substitute for simulation"; a derivative
  score favours methods that oversmooth); the threshold grid is relative to the largest normalised
  coefficient (:class:`~nlid.benchmarking.declarations.PeerSettings`); then the model is refitted on
  the whole estimation record with them; the test sets take no part;
* the free run integrates the fitted equations ``x' = Xi theta(z, v, u)`` from the rule's initial
  state (first sample: ``z[0]`` and the differentiated ``v[0]``; an initialisation window: the
  state fitted by least squares to the window; periodic: preceding periods of the record's own
  force simulated until the state at a period start settles).

Why the row once read 54 mV on the Silverbox arrow head: the grid held only finite differences
(their gain at 200 Hz, a third of the 610 Hz sampling rate, is 0.43: the derivatives of the
multisine are wrong by half) and the columns were not normalised (the ridge term removed most of
the cubic spring). ``benchmarks/peer_side_by_side.py`` runs pysindy as its documentation advises,
with nothing of this module, and compares.

pysindy's own ``SINDy.simulate`` (``solve_ivp``/LSODA at tolerances of 1e-12, the force
interpolated by a cubic ``interp1d``) takes minutes on a few hundred samples; the peer
integrates the same equations by fixed-step RK4 (:data:`SUBSTEPS` per sample, compiled with
numba), the force between the samples interpolated as every free run nlid scores is
(:func:`nlid.simulation.fine_force`: exact within the force's band, where a cubic spline is off by
9e-3 of the amplitude at a fifth of the sampling frequency), so that the rows are scored with one
instrument.
``tests/bench/test_peer.py`` checks that the peer's run equals pysindy's on a smooth force;
every fit checks that the peer's features equal pysindy's library.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numba
import numpy as np

from ..data.record import Record
from ..errors import DataError, InputError
from .declarations import PeerSettings

__all__ = [
    "SindyPeer",
    "PeerModel",
    "PeerScore",
    "fit_peer",
    "selection_rule",
    "SUBSTEPS",
    "DIVERGED",
    "DIFFERENTIATION",
]

#: RK4 sub-steps per sample of the peer's free run.
SUBSTEPS = 4
#: A free run whose state exceeds this many times the record's range is stopped as diverged.
DIVERGED = 1e3
#: Most preceding periods simulated for a periodic steady state, and the settling tolerance (relative).
MAX_PERIODS, PERIODIC_TOL = 100, 1e-6


@numba.njit(cache=True)
def _features(z, v, u, powers, friction, out):  # pragma: no cover - compiled
    n = powers.shape[0]
    for i in range(n):
        out[i] = z ** powers[i, 0] * v ** powers[i, 1]
    out[n] = u
    if friction:
        out[n + 1] = 1.0 if v > 0 else (-1.0 if v < 0 else 0.0)


@numba.njit(cache=True)
def _rhs(z, v, u, coef, powers, friction, buf):  # pragma: no cover - compiled
    _features(z, v, u, powers, friction, buf)
    dz = 0.0
    dv = 0.0
    for i in range(buf.size):
        dz += coef[0, i] * buf[i]
        dv += coef[1, i] * buf[i]
    return dz, dv


@numba.njit(cache=True)
def _simulate(coef, powers, friction, uf, dt, z0, v0, substeps, limit):  # pragma: no cover - compiled
    """z at every sample; ``uf`` is the force at every half sub-step (``2 substeps n + 1`` values)."""
    n = (uf.size - 1) // (2 * substeps)
    out = np.empty(n)
    buf = np.empty(coef.shape[1])
    z, v = z0, v0
    h = dt / substeps
    for k in range(n):
        out[k] = z
        for s in range(substeps):
            j = 2 * (k * substeps + s)
            ua, ub, uc = uf[j], uf[j + 1], uf[j + 2]
            k1z, k1v = _rhs(z, v, ua, coef, powers, friction, buf)
            k2z, k2v = _rhs(z + 0.5 * h * k1z, v + 0.5 * h * k1v, ub, coef, powers, friction, buf)
            k3z, k3v = _rhs(z + 0.5 * h * k2z, v + 0.5 * h * k2v, ub, coef, powers, friction, buf)
            k4z, k4v = _rhs(z + h * k3z, v + h * k3v, uc, coef, powers, friction, buf)
            z = z + h / 6.0 * (k1z + 2 * k2z + 2 * k3z + k4z)
            v = v + h / 6.0 * (k1v + 2 * k2v + 2 * k3v + k4v)
        if not (abs(z) < limit) or not np.isfinite(v):
            out[k + 1 :] = np.nan
            return out, z, v, False
    return out, z, v, True


def _force_grid(f: np.ndarray, f_next: float, substeps: int) -> np.ndarray:
    """The force at every half sub-step (``2 substeps n + 1`` values): nlid's band-limited interpolation.

    The one every free run is scored with (:func:`nlid.simulation.fine_force`, ``stages=True``); ``f_next`` is
    the force after the last sample.
    """
    from ..simulation import fine_force

    ext = np.append(np.asarray(f, dtype=float), f_next)
    return fine_force(ext, "sampled", substeps, stages=True)[: 2 * substeps * (ext.size - 1) + 1]


@dataclass(frozen=True)
class PeerScore:
    """The peer's free-run scores on one record under one rule (RMSE in the unit of ``z``)."""

    rmse: float
    nrmse_percent: float
    fit_percent: float
    scored_samples: int
    rule: str
    note: str = ""


@dataclass
class PeerModel:
    """A fitted pysindy model and what is needed to run it freely.

    Attributes
    ----------
    coefficients
        ``Xi`` (2 x features): the rows of ``z'`` and ``v'``.
    names
        The feature names as pysindy prints them.
    powers
        Powers of ``(z, v)`` of the polynomial features.
    friction
        Whether ``sign(v)`` is a feature.
    threshold, differentiation
        The STLSQ threshold pysindy was given (on the normalised columns) and the pysindy
        differentiation method used.
    equations
        The model as pysindy prints it.
    scale
        The largest coefficient of the fit on the normalised columns (the unit of the relative thresholds).
    """

    coefficients: np.ndarray
    names: list[str]
    powers: np.ndarray
    friction: bool
    threshold: float
    differentiation: str = "FiniteDifference"
    equations: list[str] = field(default_factory=list)
    seconds: float = 0.0
    selection: dict[str, Any] = field(default_factory=dict)
    scale: float = float("nan")

    @property
    def parameters(self) -> int:
        """Non-zero coefficients."""
        return int(np.count_nonzero(self.coefficients))

    def simulate(self, f: np.ndarray, fs: float, x0: tuple[float, float], *, limit: float, f_next: float | None = None):
        """The free run's ``z`` over ``f`` from ``x0``; the force after the last sample is ``f_next`` (else held)."""
        f = np.asarray(f, dtype=float)
        uf = _force_grid(f, float(f[-1] if f_next is None else f_next), SUBSTEPS)
        return _simulate(
            self.coefficients,
            self.powers,
            self.friction,
            uf,
            1.0 / fs,
            float(x0[0]),
            float(x0[1]),
            SUBSTEPS,
            float(limit),
        )

    def free_run(self, record: Record, rule: str) -> PeerScore:
        """Scores on ``record`` under ``rule`` (``first-sample``, ``window:N``, ``periodic[:N]``)."""
        z = record.z
        span = float(np.ptp(z)) or 1.0
        limit = DIVERGED * (span + float(np.max(np.abs(z))))
        v = _differentiate(z, record.fs, self.differentiation)
        skip = 0
        x0 = (float(z[0]), float(v[0]))
        f_next = None
        if rule == "first-sample":
            text = "from the record's first sample"
        elif rule.startswith("window:"):
            skip = int(rule.split(":", 1)[1])
            if skip >= record.n - 1:
                raise InputError(f"rule {rule}: the record has only {record.n} samples")
            x0 = self._fit_state(record, skip, x0, limit)
            text = f"initialisation window of {skip} samples (state fitted to them; not scored)"
        elif rule.startswith("periodic"):
            period = int(rule.split(":", 1)[1]) if ":" in rule else record.n
            if record.n % period:
                raise InputError(f"rule {rule}: the record's {record.n} samples are not whole periods")
            x0, periods, settled = self._settle(record, period, x0, limit)
            f_next = float(record.f[0])
            text = (
                f"periodic steady state (period {period} samples, declared; {periods} preceding periods simulated"
                + ("" if settled else ", not settled")
                + ")"
            )
        else:
            raise InputError(f"unknown rule {rule!r}")
        zs, _, _, ok = self.simulate(record.f, record.fs, x0, limit=limit, f_next=f_next)
        if not ok:
            return PeerScore(np.nan, np.nan, np.nan, record.n - skip, text, "free run diverged")
        e = zs[skip:] - z[skip:]
        zz = z[skip:]
        rmse = float(np.sqrt(np.mean(e**2)))
        fit = 100.0 * (1.0 - float(np.linalg.norm(e)) / float(np.linalg.norm(zz - zz.mean())))
        return PeerScore(rmse, 100.0 * rmse / float(np.std(zz)), fit, record.n - skip, text)

    def _fit_state(self, record: Record, n: int, x0: tuple[float, float], limit: float) -> tuple[float, float]:
        from scipy.optimize import least_squares

        z = record.z[:n]
        f = record.f[: n + 1]
        zscale = float(np.std(record.z)) or 1.0
        vscale = zscale * 2 * np.pi * record.fs / 20

        def resid(p):
            zs, _, _, ok = self.simulate(f[:n], record.fs, (p[0] * zscale, p[1] * vscale), limit=limit, f_next=f[n])
            return (zs - z) / zscale if ok else np.full(n, 1e6)

        sol = least_squares(resid, [x0[0] / zscale, x0[1] / vscale], method="lm" if n >= 2 else "trf")
        return float(sol.x[0] * zscale), float(sol.x[1] * vscale)

    def _settle(self, record: Record, period: int, x0: tuple[float, float], limit: float):
        f = record.f[:period]
        zscale = float(np.std(record.z)) or 1.0
        vscale = float(np.std(_differentiate(record.z, record.fs, self.differentiation))) or 1.0
        state = x0
        for k in range(1, MAX_PERIODS + 1):
            _, z1, v1, ok = self.simulate(f, record.fs, state, limit=limit, f_next=float(f[0]))
            if not ok:
                return state, k, False
            moved = max(abs(z1 - state[0]) / zscale, abs(v1 - state[1]) / vscale)
            state = (z1, v1)
            if moved < PERIODIC_TOL:
                return state, k, True
        return state, MAX_PERIODS, False


#: The differentiation methods the peer may use (pysindy classes by name).
DIFFERENTIATION = ("FiniteDifference", "SmoothedFiniteDifference", "SpectralDerivative")


def _differentiator(name: str) -> Any:
    import pysindy as ps

    if name not in DIFFERENTIATION:
        raise InputError(f"pysindy peer: unknown differentiation {name!r}; use {', '.join(DIFFERENTIATION)}")
    return getattr(ps, name)()


def _differentiate(z: np.ndarray, fs: float, method: str = "FiniteDifference") -> np.ndarray:
    return np.asarray(_differentiator(method)(np.asarray(z, dtype=float), 1.0 / fs), dtype=float).ravel()


def _sign(x):
    return np.sign(x)


def _sign_name(x):
    return f"sign({x})"


def _library(settings: PeerSettings):
    import pysindy as ps

    libraries = [
        ps.PolynomialLibrary(degree=settings.degree, include_bias=True),
        ps.PolynomialLibrary(degree=1, include_bias=False),
    ]
    inputs = [[0, 1], [2]]
    if settings.friction:
        libraries.append(ps.CustomLibrary(library_functions=[_sign], function_names=[_sign_name]))
        inputs.append([1])
    return ps.GeneralizedLibrary(libraries, inputs_per_library=inputs)


def _sindy(settings: PeerSettings, threshold: float, method: str) -> Any:
    import pysindy as ps

    return ps.SINDy(
        feature_library=_library(settings),
        optimizer=ps.STLSQ(threshold=threshold, normalize_columns=True),
        differentiation_method=_differentiator(method),
    )


def _fit(record: Record, settings: PeerSettings, threshold: float, method: str) -> PeerModel:
    """pysindy fitted on ``record`` with an absolute STLSQ threshold (on the normalised columns)."""
    import warnings

    z = record.z
    v = _differentiate(z, record.fs, method)
    model = _sindy(settings, threshold, method)
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Sparsity parameter is too big", category=UserWarning)
        model.fit(np.column_stack([z, v]), t=1.0 / record.fs, u=record.f, feature_names=["z", "v", "u"])
    coef = np.asarray(model.coefficients(), dtype=float)
    lib = model.feature_library
    poly = lib.libraries[0] if hasattr(lib, "libraries") else lib.libraries_[0]
    powers = np.asarray(_powers(poly), dtype=np.int64)
    peer = PeerModel(
        coef,
        list(model.get_feature_names()),
        powers,
        settings.friction,
        threshold,
        method,
        [str(e) for e in model.equations()],
    )
    _check_features(peer, model, z[:50], v[:50], record.f[:50])
    theta = np.asarray(getattr(model.optimizer, "Theta_", None) if hasattr(model.optimizer, "Theta_") else [])
    if theta.ndim == 2 and theta.shape[1] == coef.shape[1]:
        peer.scale = float(np.max(np.abs(coef) * np.linalg.norm(theta, axis=0)))
    return peer


def _scale(record: Record, settings: PeerSettings, method: str) -> tuple[PeerModel, float]:
    """The unthresholded fit and its largest normalised coefficient (what the relative thresholds multiply)."""
    peer = _fit(record, settings, 0.0, method)
    return peer, peer.scale


def selection_rule(rules: Sequence[str]) -> str:
    """The rule the hyper-parameters are chosen under on the held-out end of the estimation part.

    The benchmark's own initialisation window when a test set declares one (``window:N``),
    else from the first sample (a periodic rule needs whole periods, which a hold-out is not).
    """
    for rule in rules:
        if rule.startswith("window:"):
            return rule
    return "first-sample"


def _powers(poly: Any) -> np.ndarray:
    for lib in (poly,):
        powers = getattr(lib, "powers_", None)
        if powers is not None:
            return np.asarray(powers)
    raise DataError("pysindy's polynomial library has no powers_ (an unsupported pysindy version)")


def _check_features(peer: PeerModel, model: Any, z: np.ndarray, v: np.ndarray, u: np.ndarray) -> None:
    """The peer's features equal pysindy's on a few samples (so the free run is pysindy's model)."""
    theirs = np.asarray(model.feature_library.transform(np.column_stack([z, v, u])))
    ours = np.empty_like(theirs)
    buf = np.empty(peer.coefficients.shape[1])
    for i in range(z.size):
        _features(z[i], v[i], u[i], peer.powers, peer.friction, buf)
        ours[i] = buf
    if ours.shape != theirs.shape or not np.allclose(ours, theirs, rtol=1e-10, atol=1e-300):
        raise DataError("the pysindy peer's features differ from pysindy's library (an unsupported pysindy version)")


def fit_peer(record: Record, settings: PeerSettings, *, holdout: float = 0.25, rule: str = "first-sample") -> PeerModel:
    """The peer fitted on the estimation record, its hyper-parameters chosen on the record's last part.

    Parameters
    ----------
    record
        The estimation record (nothing else is seen).
    settings
        Library degree, friction, the grid of relative thresholds.
    holdout
        Fraction of ``record`` (its end) on which the differentiation method and the threshold
        are chosen by the free-run error; the final model is fitted on all of ``record``.
    rule
        The transient rule of that free run (:func:`selection_rule`).
    """
    start = time.perf_counter()
    fit_part, held = record.split(holdout)
    errors: dict[str, float] = {}
    best, best_err = (DIFFERENTIATION[0], settings.thresholds[0]), np.inf
    for method in DIFFERENTIATION:
        unthresholded, scale = _scale(fit_part, settings, method)
        for relative in settings.thresholds:
            trial = unthresholded if relative == 0 else _fit(fit_part, settings, relative * scale, method)
            err = trial.free_run(held, rule).rmse if trial.parameters else np.nan
            errors[f"{method}, threshold {relative:g}"] = err
            if np.isfinite(err) and err < best_err:
                best, best_err = (method, relative), err
    method, relative = best
    peer, scale = _scale(record, settings, method)
    if relative:
        peer = _fit(record, settings, relative * scale, method)
    peer.seconds = time.perf_counter() - start
    peer.selection = {
        "differentiation": method,
        "threshold": relative,
        "threshold_absolute": relative * scale,
        "holdout_rmse": errors,
        "holdout_fraction": holdout,
        "holdout_rule": rule,
    }
    return peer


class SindyPeer:
    """The pysindy peer as a pipeline (``fit(record) -> PeerModel``)."""

    label = "pysindy SINDy (peer)"

    def __init__(self, settings: PeerSettings, holdout: float = 0.25, rule: str = "first-sample") -> None:
        self.settings, self.holdout, self.rule = settings, holdout, rule

    def fit(self, record: Record) -> PeerModel:
        """The peer fitted on the estimation record (:func:`fit_peer`)."""
        return fit_peer(record, self.settings, holdout=self.holdout, rule=self.rule)
