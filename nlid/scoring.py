"""How well an identified model meets a record: the one place every score is computed.

Every layer of nlid (the pipeline, ``nlid identify``, studies, discovery,
posteriors, the output-error identifier) scores a model on data through the
functions here, so that the same model on the same record gets the same
number whichever command asks.

Scores (:class:`Scores`, from :func:`score`):

``eps_percent``
    The percentage RMS residual of the restoring-force surface (Eq. 26):
    ``100 RMS(R_e - R_hat) / RMS(R_e)`` with ``R_e = f - m a`` (Eq. 25),
    formed in the band of the shared differentiating filter when a channel
    the model needs is estimated (:func:`nlid.balance.regression_data`).
``force_residual_percent``
    The same residual relative to the force, ``100 RMS(f - m a - R_hat) /
    RMS(f)``: the "relative force residual" of inverse-dynamics benchmarks
    such as EMPS.
``freerun_rmse``, ``freerun_nrmse_percent``, ``freerun_fit_percent``, ``freerun_note``
    The free-run simulation error of the displacement: the model driven by
    the record's force from the record's first state
    (:func:`nlid.simulation.free_run`, which holds a zero-order-held force
    and interpolates a sampled one), ``RMS(z_sim - z)`` in the unit of ``z``
    and relative to ``std(z)``; and the fit of MATLAB's ``compare``,
    ``100 (1 - |z - z_sim| / |z - mean(z)|)`` (100 % a perfect match, the
    norms over the record; ``100 - freerun_nrmse_percent`` up to rounding,
    in the convention benchmark tables quote). The initial velocity is the measured one when
    the record has it, else the derivative of ``z`` through the shared filter
    at its suggested cut-off (a property of the record alone, so the number
    does not depend on who asks). It is not reported for a model that is too
    sensitive to its initial state for one free run to mean anything
    (chaotic): two runs started :data:`SENSITIVITY_DELTA` ``std(z)`` apart
    that differ by more than :data:`SENSITIVITY_LIMIT` ``std(z)`` (RMS over
    the second half). ``freerun_note`` says why a figure is missing.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any, Protocol

import numpy as np

from . import derivatives
from .balance import RegressionData, regression_data
from .errors import DataError, InputError, NlidError
from .physics import Coefficients, damping, dict_or_vector
from .record import Record
from .terms import Model

__all__ = [
    "ModelFit",
    "Scores",
    "Residual",
    "FreeRun",
    "score",
    "residual",
    "free_run_error",
    "predictability_horizon",
    "HORIZON_STARTS",
    "initial_state",
    "epsilon",
    "force_residual_percent",
    "DampingSlice",
    "damping_slice",
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

    :class:`nlid.identified.IdentifiedModel` is one; the scores need nothing else of it (so this module,
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
        ``RMS(z_sim - z)`` in the unit of ``z`` (NaN when not computed).
    nrmse_percent
        ``100 rmse / std(z)``.
    fit_percent
        ``100 (1 - |z - z_sim| / |z - mean(z)|)``: MATLAB ``compare``'s fit (NaN when not computed).
    note
        Empty when computed, else why not (chaotic, diverged, no mass...).
    """

    rmse: float = NAN
    nrmse_percent: float = NAN
    note: str = ""
    fit_percent: float = NAN

    @property
    def computed(self) -> bool:
        """True when the error was computed."""
        return not self.note


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
    """

    eps_percent: float
    force_residual_percent: float
    freerun_rmse: float = NAN
    freerun_nrmse_percent: float = NAN
    freerun_note: str = "not computed"
    band_hz: float | None = None
    samples: int = 0
    freerun_fit_percent: float = NAN

    def to_dict(self) -> dict[str, Any]:
        """Plain dictionary (NaN kept; :func:`nlid.interface.to_jsonable` maps it to null)."""
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
    suggested cut-off (:func:`nlid.derivatives.differentiate`).
    """
    if record.is_measured("v"):
        return float(record.z[0]), float(record.v[0])  # type: ignore[index]
    v, _ = derivatives.differentiate(record.z, record.fs, order=1)
    return float(record.z[0]), float(v[0])


def free_run_error(fit: ModelFit, record: Record) -> FreeRun:
    """Free-run simulation error of the displacement, with the chaos check (module docstring)."""
    from .simulation import free_run

    if fit.mass is None:
        return FreeRun(note="skipped: the mass is unknown")
    z = record.z
    scale = float(np.std(z))
    x0 = initial_state(record)
    args = (fit.model, fit.theta, float(fit.mass), record.f, record.fs)
    try:
        z1, _, _ = free_run(*args, force_hold=record.force_hold, x0=x0)
        z2, _, _ = free_run(*args, force_hold=record.force_hold, x0=(x0[0] + SENSITIVITY_DELTA * scale, x0[1]))
    except NlidError as exc:
        return FreeRun(note=f"free run diverged: {exc}")
    half = z.size // 2
    spread = float(np.sqrt(np.mean((z1[half:] - z2[half:]) ** 2))) / scale
    if spread > SENSITIVITY_LIMIT:
        return FreeRun(
            note=f"skipped: chaotic - two free runs started {SENSITIVITY_DELTA:g} std(z) apart differ by "
            f"{100 * spread:.3g} % of std(z) over the second half"
        )
    rmse = float(np.sqrt(np.mean((z1 - z) ** 2)))
    fit = 100.0 * (1.0 - float(np.linalg.norm(z - z1)) / float(np.linalg.norm(z - np.mean(z))))
    return FreeRun(rmse, 100.0 * rmse / scale, "", fit)


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
    from .simulation import FREE_RUN_OVERSAMPLE, fine_force, simulate_segments

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
    here = 0
    times = []
    for start in points:
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
        pair = np.vstack([state, state])
        pair[1, 0] += SENSITIVITY_DELTA * scale
        stop = start + half
        runs = [
            simulate_segments(
                model,
                theta,
                mass,
                record.f[start:stop],
                record.fs,
                [0],
                pair[i : i + 1],
                oversample=q,
                sensitivities=False,
                fine=fine[start * q : stop * q],
            ).z
            for i in range(2)
        ]
        apart = np.flatnonzero(np.abs(runs[0] - runs[1]) > SENSITIVITY_LIMIT * scale)
        times.append(apart[0] / record.fs if apart.size else np.inf)
    horizon = float(np.median(times)) if quantile == 0.5 else float(np.quantile(times, quantile, method="lower"))
    return horizon if np.isfinite(horizon) else None


def score(
    fit: ModelFit,
    record: Record,
    *,
    cutoff: float | None = None,
    free_run: bool = True,
    data: RegressionData | None = None,
) -> Scores:
    """Every score of an identified model on a record (see the module docstring).

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
    data
        A force balance of ``fit.model`` on ``record`` already formed (saves
        the filtering).

    Returns
    -------
    Scores
    """
    if not isinstance(record, Record):  # nlid.load reads files, DataFrames and mappings into a Record
        raise InputError(f"record must be an nlid Record (see nlid.load), got {type(record).__name__}")
    if fit.mass is None:
        note = "skipped: the mass is unknown" if free_run else "not computed"
        return Scores(NAN, NAN, freerun_note=note)
    mass = float(fit.mass)
    data = data if data is not None else regression_data(record, fit.model, cutoff=cutoff)
    if data.G.shape[1] != len(fit.model):
        raise InputError(f"the force balance has {data.G.shape[1]} regressors but the model has {len(fit.model)} terms")
    theta = fit.theta
    eps = epsilon(data.restoring_force(mass), data.G @ theta)
    force = force_residual_percent(data, theta, mass)
    run = free_run_error(fit, record) if free_run else FreeRun(note="not computed")
    return Scores(
        eps,
        force,
        run.rmse,
        run.nrmse_percent,
        run.note,
        data.filtered_at,
        int(data.f.size),
        freerun_fit_percent=run.fit_percent,
    )


# --------------------------------------------------------------------------- slices of the surface
@dataclass(frozen=True)
class DampingSlice:
    """The damping force near one position (paper Fig. 21 b-d).

    Attributes
    ----------
    z0, half_width
        The slice ``|z - z0| <= half_width`` (m).
    v
        Velocities of the samples in the slice (m/s).
    measured
        Their measured damping force ``R_e - K(z)`` (N): the restoring force
        minus the identified elastic part at each sample's own position,
        formed in the force balance's band (the stiffness columns of ``G``)
        so that a filtered balance does not leak the out-of-band part of
        ``K(z)`` into the damping force.
    v_grid, model
        The identified ``D(z0, v)`` on a velocity grid spanning the slice.
    """

    z0: float
    half_width: float
    v: np.ndarray
    measured: np.ndarray
    v_grid: np.ndarray
    model: np.ndarray


def damping_slice(
    data: RegressionData,
    model: Model,
    coefficients: Coefficients,
    mass: float,
    z0: float,
    half_width: float | None = None,
    grid: int = 200,
) -> DampingSlice:
    """Slice the restoring surface at ``z0`` to compare ``D`` with the data (Fig. 21 b-d).

    Parameters
    ----------
    data
        From :func:`nlid.balance.regression_data` (needs velocity: the model
        must have velocity terms).
    model, coefficients, mass
        The identified model.
    z0
        Position of the slice (m).
    half_width
        Half width of the slice; default 5 % of the displacement range.
    grid
        Number of velocity points of the model curve.
    """
    if data.v is None:
        raise InputError("a damping slice needs velocity: the model has no velocity-dependent term")
    theta = dict_or_vector(model, coefficients)
    if data.G.shape[1] != len(model):
        raise InputError(f"the force balance has {data.G.shape[1]} regressors but the model has {len(model)} terms")
    if half_width is None:
        half_width = 0.05 * float(np.ptp(data.z))
    near = np.abs(data.z - z0) <= half_width
    if near.sum() < 3:
        raise InputError(f"fewer than 3 samples within {half_width:.3g} m of z0 = {z0:.4g} m")
    v = data.v[near]
    stiff = [i for i, t in enumerate(model.terms) if t.family == "stiffness"]
    # K in the balance's band: the stiffness regressors of G (equal to K(z) when nothing is filtered)
    measured = data.restoring_force(mass)[near] - data.G[near][:, stiff] @ theta[stiff]
    v_grid = np.linspace(v.min(), v.max(), grid)
    curve = damping(model, theta, np.full(grid, float(z0)), v_grid)
    return DampingSlice(float(z0), float(half_width), v, measured, v_grid, curve)
