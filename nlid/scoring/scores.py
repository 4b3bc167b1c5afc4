"""The scores of a model on a record: epsilon, the force residual, the free-run and k-step errors (see the package)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import Any, Protocol

import numpy as np

from ..data.record import Record
from ..errors import DataError, InputError, NlidError
from ..estimation.balance import RegressionData, regression_data
from ..estimation.inputpath import acting_record
from ..model.physics import Coefficients, dict_or_vector
from ..model.terms import Model
from ..signal import derivatives
from .rules import FromFirstSample, TransientRule, error_metrics, resolve_rule
from .rules import start as rule_start

__all__ = [
    "ModelFit",
    "Scores",
    "Residual",
    "FreeRun",
    "score",
    "residual",
    "free_run_error",
    "free_run_response",
    "FreeRunResponse",
    "predictability_horizon",
    "HORIZON_STARTS",
    "initial_state",
    "epsilon",
    "force_residual_percent",
    "SENSITIVITY_DELTA",
    "SENSITIVITY_LIMIT",
]

#: Initial-state offset of the sensitivity (chaos) test, as a fraction of std(z).
SENSITIVITY_DELTA = 1e-6
#: Largest RMS difference (relative to std(z)) of the two sensitivity runs over the second half.
SENSITIVITY_LIMIT = 1e-3
#: Starting points of the pairs of runs :func:`predictability_horizon` measures (spread over the first half).
HORIZON_STARTS = 8

NAN = float("nan")


class ModelFit(Protocol):
    """What the scores read of a fitted model: its model, its coefficients in model order and its mass.

    :class:`nlid.identified.model.IdentifiedModel` is one; the scores need nothing else of it (so this module,
    which the identified model uses, does not import it).
    """

    @property
    def model(self) -> Model:
        """The terms of ``R`` (with their ``px(z)`` roots)."""

    @property
    def theta(self) -> np.ndarray:
        """The coefficients in model order."""

    @property
    def mass(self) -> float | None:
        """The mass in kg (``None``: not known; the scores that need it say so)."""


def epsilon(measured: np.ndarray, identified: np.ndarray) -> float:
    """Percentage RMS residual ``100 RMS(R - R_e) / RMS(R_e)`` (Eq. 26)."""
    measured = np.asarray(measured, dtype=float)
    rms = np.sqrt(np.mean(measured**2))
    if rms == 0:
        raise DataError("the measured restoring force is identically zero")
    return float(100.0 * np.sqrt(np.mean((np.asarray(identified) - measured) ** 2)) / rms)


def force_residual_percent(data: RegressionData, coefficients: np.ndarray, mass: float) -> float:
    """Residual relative to the force: ``100 RMS(f - m a - G theta) / RMS(f)``.

    This is the "relative force residual" of inverse-dynamics benchmarks such
    as EMPS (IDIM-LS), where the mass is estimated with the other
    coefficients and the force is the regressed variable. It has the same
    numerator as epsilon (Eq. 26) but divides by the force, not by the
    restoring force.
    """
    resid = data.f - mass * data.a - data.G @ np.asarray(coefficients, dtype=float)
    return float(100.0 * np.sqrt(np.mean(resid**2)) / np.sqrt(np.mean(data.f**2)))


@dataclass(frozen=True)
class FreeRun:
    """The free-run simulation error of a model on a record, or why there is none.

    Attributes
    ----------
    rmse
        ``RMS(z_sim - z)`` over the scored samples, in the unit of ``z`` (NaN when not computed).
    nrmse_percent
        ``100 rmse / std(z)`` (``z`` over the scored samples).
    fit_percent
        ``100 (1 - |z - z_sim| / |z - mean(z)|)`` over the scored samples: MATLAB ``compare``'s fit (NaN when
        not computed).
    note
        Empty when computed, else why not (chaotic, diverged, no mass...).
    rule
        The transient rule as applied (:mod:`nlid.scoring.rules`): ``"from the record's first sample"``, the
        window, or the period and the number of preceding periods simulated; empty when no run was made.
    scored_samples
        Number of samples the figures are computed over (0 when not computed).
    """

    rmse: float = NAN
    nrmse_percent: float = NAN
    note: str = ""
    fit_percent: float = NAN
    rule: str = ""
    scored_samples: int = 0

    @property
    def computed(self) -> bool:
        """True when the error was computed."""
        return not self.note


@dataclass(frozen=True)
class FreeRunResponse:
    """The free run itself, as :func:`free_run_error` scores it (:func:`free_run_response`; for figures).

    Attributes
    ----------
    z
        The measured displacement (the whole record).
    z_sim
        The simulated displacement at every sample of the record (the initialisation window included), or
        ``None`` when the run diverged or was not made.
    first
        The first scored sample (``InitWindow``: the window's length; 0 otherwise).
    error
        The figures and the rule as applied (:class:`FreeRun`).
    """

    z: np.ndarray
    z_sim: np.ndarray | None
    first: int
    error: FreeRun


@dataclass(frozen=True)
class Scores:
    """The scores of one model on one record (see the module docstring).

    Attributes
    ----------
    eps_percent
        Eq. 26 (NaN without a mass).
    force_residual_percent
        The residual relative to ``RMS(f)``.
    freerun_rmse, freerun_nrmse_percent, freerun_note, freerun_fit_percent
        The free-run error (:class:`FreeRun`).
    band_hz
        The equation band (Hz), ``None`` when nothing was filtered.
    samples
        Samples of the settled force balance the residuals were computed on.
    freerun_rule, freerun_scored_samples
        The transient rule the free run was scored under, as applied, and the number of samples scored
        (:attr:`FreeRun.rule`, :attr:`FreeRun.scored_samples`).
    predict_rmse, predict_fit_percent, predict_horizon
        The ``k``-step-ahead prediction error (:func:`nlid.scoring.predict`; ``score(..., horizon=k)``): RMS in
        the unit of ``z``, MATLAB ``compare``'s fit, and ``k`` (``None`` when not computed).
    """

    eps_percent: float
    force_residual_percent: float
    freerun_rmse: float = NAN
    freerun_nrmse_percent: float = NAN
    freerun_note: str = "not computed"
    band_hz: float | None = None
    samples: int = 0
    freerun_fit_percent: float = NAN
    freerun_rule: str = ""
    freerun_scored_samples: int = 0
    predict_rmse: float = NAN
    predict_fit_percent: float = NAN
    predict_horizon: int | None = None

    def to_dict(self) -> dict[str, Any]:
        """Plain dictionary (NaN kept; :func:`nlid.base.jsonable.to_jsonable` maps it to null)."""
        return asdict(self)


@dataclass(frozen=True)
class Residual:
    """The residual of the restoring-force surface on a record, in the equation band.

    Attributes
    ----------
    z, v
        Displacement and velocity the regressors were evaluated on (``v`` is
        always present: it is estimated when the model has no velocity term,
        so that residuals of every model can be drawn against ``v``).
    r
        ``R_e - R_hat = f - m a - G theta`` (N).
    restoring
        ``R_e = f - m a`` (N).
    fitted
        ``R_hat = G theta`` in the band (N).
    fs
        Sampling frequency (Hz).
    band_hz
        The equation band, ``None`` when nothing was filtered.
    f, a
        The force and the acceleration of the balance (N, m/s^2).
    """

    z: np.ndarray
    v: np.ndarray
    r: np.ndarray
    restoring: np.ndarray
    fitted: np.ndarray
    fs: float
    band_hz: float | None
    f: np.ndarray
    a: np.ndarray


def _require_mass(fit: ModelFit, what: str) -> float:
    if fit.mass is None:
        raise InputError(f"{what} needs the mass: the model has none (give mass= when identifying)")
    return float(fit.mass)


def residual(fit: ModelFit, record: Record, *, cutoff: float | None = None) -> Residual:
    """The residual ``f - m a - R_hat(z, v)`` of an identified model on a record.

    Parameters
    ----------
    fit
        The identified model.
    record
        The data (missing ``v``, ``a`` are estimated through the shared filter).
    cutoff
        Equation band in Hz (default: the filter's suggestion for ``record``).
    """
    mass = _require_mass(fit, "the residual")
    record = acting_record(fit, record)
    model = fit.model
    augmented = model if "v" in model else model.with_terms(add=["v"])
    data = regression_data(record, augmented, cutoff=cutoff)
    columns = [augmented.index(n) for n in model.names]
    fitted = data.G[:, columns] @ fit.theta
    restoring = data.restoring_force(mass)
    return Residual(
        data.z,
        data.v,
        restoring - fitted,
        restoring,
        fitted,
        record.fs,
        data.filtered_at,
        data.f,
        data.a,  # type: ignore[arg-type]
    )


def initial_state(record: Record) -> tuple[float, float]:
    """The state a free run on ``record`` starts from: ``z[0]`` and the velocity at ``t = 0``.

    The velocity is the measured one when the record has it, else the
    derivative of ``z`` through the shared zero-phase filter at its
    suggested cut-off (:func:`nlid.signal.derivatives.differentiate`).
    """
    if record.is_measured("v"):
        return float(record.z[0]), float(record.v[0])  # type: ignore[index]
    v, _ = derivatives.differentiate(record.z, record.fs, order=1)
    return float(record.z[0]), float(v[0])


def free_run_error(
    fit: ModelFit, record: Record, rule: TransientRule | str | Mapping[str, Any] | None = None
) -> FreeRun:
    """Free-run simulation error of the displacement under a transient rule, with the chaos check.

    Parameters
    ----------
    fit
        The identified model (without a mass there is no free run: the note says so).
    record
        The force that drives the run and the displacement it is scored against.
    rule
        The transient rule (:mod:`nlid.scoring.rules`; a rule or its spelling, ``"window:50"``); default
        :func:`~nlid.scoring.default_rule` of the record.

    Returns
    -------
    FreeRun
        The figures over the scored samples, the rule as applied, or the note saying why there are none
        (chaotic: two runs started :data:`SENSITIVITY_DELTA` ``std(z)`` apart differ by more than
        :data:`SENSITIVITY_LIMIT` ``std(z)`` over the second half of the scored samples).

    Raises
    ------
    InputError
        A rule that does not fit the record (a window longer than it, a period it cannot show).
    """
    return free_run_response(fit, record, rule).error


def free_run_response(
    fit: ModelFit, record: Record, rule: TransientRule | str | Mapping[str, Any] | None = None
) -> FreeRunResponse:
    """The free run :func:`free_run_error` scores, with the simulated displacement (same arguments)."""
    rule = resolve_rule(rule, record)
    record = acting_record(fit, record)
    z = np.asarray(record.z)
    if fit.mass is None:
        return FreeRunResponse(z, None, 0, FreeRun(note="skipped: the mass is unknown"))
    if isinstance(rule, FromFirstSample):
        return _free_run_first_sample(fit, record, rule.describe())
    from ..simulation import FREE_RUN_OVERSAMPLE, simulate_segments

    q = FREE_RUN_OVERSAMPLE
    try:
        begin = rule_start(fit, record, rule, q)
        shifted = begin.state.copy()
        scale = float(np.std(z[begin.first :]))
        shifted[0] += SENSITIVITY_DELTA * scale
        runs = [
            simulate_segments(
                fit.model,
                fit.theta,
                float(fit.mass),
                record.f,
                record.fs,
                [0],
                x[None, :],
                oversample=q,
                fine=begin.fine,
                sensitivities=False,
            ).z
            for x in (begin.state, shifted)
        ]
    except InputError:
        raise
    except NlidError as exc:
        return FreeRunResponse(z, None, 0, FreeRun(note=f"free run diverged: {exc}", rule=rule.describe()))
    k = begin.first
    error = _judged(z[k:], runs[0][k:], runs[1][k:], scale, begin.description)
    return FreeRunResponse(z, runs[0], k, error)


def _judged(z: np.ndarray, z1: np.ndarray, z2: np.ndarray, scale: float, rule: str) -> FreeRun:
    """The figures of a free run ``z1`` against ``z``, unless ``z2`` (started nearby) says the model is chaotic."""
    half = z.size // 2
    spread = float(np.sqrt(np.mean((z1[half:] - z2[half:]) ** 2))) / scale
    if spread > SENSITIVITY_LIMIT:
        return FreeRun(
            note=f"skipped: chaotic - two free runs started {SENSITIVITY_DELTA:g} std(z) apart differ by "
            f"{100 * spread:.3g} % of std(z) over the second half",
            rule=rule,
        )
    rmse, nrmse, fit = error_metrics(z, z1)
    return FreeRun(rmse, nrmse, "", fit, rule, int(z.size))


def _free_run_first_sample(fit: ModelFit, record: Record, rule: str) -> FreeRunResponse:
    """The free run from the record's first sample (:func:`nlid.simulation.free_run`, nlid's path before the rules).

    The chaos check's second run stops where it joins the first (:func:`nlid.scoring.twin.free_run_pair`: the
    displacements of the two whole runs, to the bit).
    """
    from .twin import free_run_pair

    z = np.asarray(record.z)
    scale = float(np.std(z))
    x0 = initial_state(record)
    try:
        z1, z2 = free_run_pair(
            fit.model,
            fit.theta,
            float(fit.mass),
            record.f,
            record.fs,
            force_hold=record.force_hold,
            x0=x0,
            x1=(x0[0] + SENSITIVITY_DELTA * scale, x0[1]),
        )
    except NlidError as exc:
        return FreeRunResponse(z, None, 0, FreeRun(note=f"free run diverged: {exc}", rule=rule))
    return FreeRunResponse(z, z1, 0, _judged(z, z1, z2, scale, rule))


def predictability_horizon(
    model: Model,
    coefficients: Coefficients,
    mass: float,
    record: Record,
    *,
    oversample: int | None = None,
    starts: int = HORIZON_STARTS,
    quantile: float = 0.5,
) -> float | None:
    """How long a model's free run on a record stays predictable: the chaos check of :func:`free_run_error` as a time.

    From :data:`HORIZON_STARTS` states spread over the first half of the free run (started from
    :func:`initial_state`), a run and a copy displaced by :data:`SENSITIVITY_DELTA` ``std(z)`` are
    integrated over half the record; each pair's time is the first at which the two displacements differ by
    more than :data:`SENSITIVITY_LIMIT` ``std(z)`` (a growth by ``SENSITIVITY_LIMIT / SENSITIVITY_DELTA``,
    the factor the chaos check allows). The horizon is the median of these times (by default; a lower
    ``quantile`` calls a record unpredictable when fewer of its starts separate).

    Parameters
    ----------
    model, coefficients, mass
        The model, its coefficients and the mass (kg).
    record
        The force that drives it and the displacement whose ``std`` sets the scale.
    oversample
        Sub-steps per sample (default :data:`nlid.simulation.FREE_RUN_OVERSAMPLE`).
    starts
        Number of starting points.
    quantile
        Quantile of the pairs' times taken as the horizon (0.5: the median; the lower value of two).

    Returns
    -------
    float or None
        The horizon in seconds; ``None`` when that quantile of the pairs stays within the limit over half
        the record (the free run is predictable over the record, as :func:`free_run_error` requires).

    Raises
    ------
    nlid.simulation.SimulationError
        If the free run diverges.
    """
    from ..simulation import FREE_RUN_OVERSAMPLE, fine_force, simulate_segments

    q = FREE_RUN_OVERSAMPLE if oversample is None else int(oversample)
    theta = dict_or_vector(model, coefficients)
    scale = float(np.std(record.z))
    n = record.n
    half = n // 2
    if half < 2 or starts < 1:
        raise InputError(f"the record is too short ({n} samples) to measure a predictability horizon")
    if not 0.0 <= quantile <= 1.0:
        raise InputError(f"quantile must lie in [0, 1], got {quantile}")
    fine = fine_force(record.f, record.force_hold, q)
    points = np.unique(np.linspace(0, half, starts, endpoint=False).astype(int))
    memory = sum(t.is_memory for t in model.terms)
    state = np.zeros((1, 2 + memory))
    state[0, :2] = initial_state(record)
    # the reference run moved on from start to start (one run through the first half), then the displaced runs
    # over half the record and the reference on from the first start over every window, at once: the segments
    # of one call (run in parallel) over the windows of the force joined end to end. The reference's windows
    # are the pieces of its one run (a run continued from its end state is the same run, to the bit), not a
    # run each: 1 + len(points) / 2 record lengths instead of len(points)
    states = np.empty((points.size, 2 + memory))
    here = 0
    for i, start in enumerate(points):
        if start > here:  # move the reference run on to this start
            run = simulate_segments(
                model,
                theta,
                mass,
                record.f[here:start],
                record.fs,
                [0],
                state,
                oversample=q,
                sensitivities=False,
                fine=fine[here * q : start * q],
            )
            state = run.end_state.copy()
            here = start
        states[i] = state[0]
    reach = int(points[-1]) + half  # the reference from points[0] = 0 through the last window
    displaced = states.copy()
    displaced[:, 0] += SENSITIVITY_DELTA * scale
    samples = np.concatenate([np.arange(reach), (points[:, None] + np.arange(half)[None, :]).ravel()])
    z = simulate_segments(
        model,
        theta,
        mass,
        record.f[samples],
        record.fs,
        np.append(0, reach + np.arange(points.size) * half),
        np.vstack([states[:1], displaced]),
        oversample=q,
        sensitivities=False,
        fine=fine[(samples[:, None] * q + np.arange(q)[None, :]).ravel()],
    ).z
    reference, others = z[:reach], z[reach:].reshape(points.size, half)
    times = []
    for start, second in zip(points, others, strict=True):
        first = reference[start : start + half]
        apart = np.flatnonzero(np.abs(first - second) > SENSITIVITY_LIMIT * scale)
        times.append(apart[0] / record.fs if apart.size else np.inf)
    horizon = float(np.median(times)) if quantile == 0.5 else float(np.quantile(times, quantile, method="lower"))
    return horizon if np.isfinite(horizon) else None


def score(
    fit: ModelFit,
    record: Record,
    *,
    cutoff: float | None = None,
    free_run: bool = True,
    rule: TransientRule | str | Mapping[str, Any] | None = None,
    horizon: int | None = None,
    data: RegressionData | None = None,
) -> Scores:
    """Every score of an identified model on a record (see :mod:`nlid.scoring`).

    Parameters
    ----------
    fit
        The identified model.
    record
        Estimation or held-out data.
    cutoff
        Equation band in Hz for estimated channels (default: the filter's
        suggestion for ``record``).
    free_run
        Also compute the free-run error (two simulations of the record).
    rule
        The transient rule of the free run and of the prediction (a rule or its spelling such as
        ``"window:50"``; default :func:`~nlid.scoring.default_rule` of the record).
    horizon
        Also compute the ``horizon``-step-ahead prediction error (:func:`~nlid.scoring.predict`): the
        ``predict_*`` fields (NaN, with the horizon, when the prediction diverged).
    data
        A force balance of ``fit.model`` on ``record`` already formed (saves
        the filtering).

    Returns
    -------
    Scores
    """
    if not isinstance(record, Record) or record.indexed:  # nlid.load reads files, DataFrames and mappings
        what = "a structure's record (channels z1..zn)" if isinstance(record, Record) else type(record).__name__
        raise InputError(f"record must be a one-DOF nlid Record (see nlid.load), got {what}")
    if fit.mass is None:
        note = "skipped: the mass is unknown" if free_run else "not computed"
        return Scores(NAN, NAN, freerun_note=note)
    mass = float(fit.mass)
    record = acting_record(fit, record)
    data = data if data is not None else regression_data(record, fit.model, cutoff=cutoff)
    if data.G.shape[1] != len(fit.model):
        raise InputError(f"the force balance has {data.G.shape[1]} regressors but the model has {len(fit.model)} terms")
    theta = fit.theta
    eps = epsilon(data.restoring_force(mass), data.G @ theta)
    force = force_residual_percent(data, theta, mass)
    if free_run or horizon is not None:
        rule = resolve_rule(rule, record)
    run = free_run_error(fit, record, rule) if free_run else FreeRun(note="not computed")
    ahead: tuple[float, float, int | None] = (NAN, NAN, None)
    if horizon is not None:
        from .prediction import predict

        try:
            found = predict(fit, record, horizon, rule=rule)
            ahead = (found.rmse, found.fit_percent, found.horizon)
        except InputError:
            raise
        except NlidError:
            ahead = (NAN, NAN, int(horizon))
    return Scores(
        eps,
        force,
        run.rmse,
        run.nrmse_percent,
        run.note,
        data.filtered_at,
        int(data.f.size),
        run.fit_percent,
        run.rule,
        run.scored_samples,
        *ahead,
    )
