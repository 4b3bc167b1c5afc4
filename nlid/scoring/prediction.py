"""``k``-step-ahead prediction: every sample predicted from the measured state ``k`` samples before it.

A free run of a chaotic model (the paper-experimental double well) forgets its
initial state within seconds, so its free-run error means nothing (the chaos
check of :func:`nlid.scoring.free_run_error` withholds it). MATLAB's ``compare``
reports a finite-horizon prediction for such systems instead; so does
:func:`predict`: sample ``i`` is simulated over ``k`` samples with the record's
force, from the state at ``i - k`` taken from the data:

* ``z`` measured, ``v`` measured or differentiated through the shared filter
  (:func:`nlid.scoring.rules.data_velocity`);
* each memory state (Bouc-Wen's, Dahl's) integrated along the measured ``z``
  from 0 at the record's start (:func:`nlid.model.terms.memory.path`, as the force
  balance does); for a periodic record, from its preceding period (the record's
  first period) so that the start does not matter.

Every start is one segment of :func:`nlid.simulation.simulate_segments`; the
``k`` interleaved partitions of the record (segments starting at ``r, r + k,
r + 2k...``) give every sample its own ``k``-step run in ``k`` parallel calls,
with no Python loop over the samples.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..data.record import Record
from ..errors import InputError
from ..estimation.inputpath import acting_record
from .rules import (
    InitWindow,
    PeriodicSteadyState,
    TransientRule,
    data_velocity,
    error_metrics,
    periodic_fine_force,
    resolve_rule,
)

__all__ = ["Prediction", "predict"]


@dataclass(frozen=True)
class Prediction:
    """The ``k``-step-ahead prediction of a record's displacement (:func:`predict`).

    Attributes
    ----------
    z
        The predicted displacement at every sample, NaN where none is made (the first ``k`` samples).
    rmse
        ``RMS(z_pred - z)`` over the scored samples, in the unit of ``z``.
    nrmse_percent
        ``100 rmse / std(z)`` over the scored samples.
    fit_percent
        MATLAB ``compare``'s fit ``100 (1 - |z - z_pred| / |z - mean(z)|)`` over the scored samples.
    horizon
        ``k`` (samples).
    rule
        The transient rule's description (its window is not scored).
    scored_samples
        Number of samples scored: from ``max(k, window)`` on.
    """

    z: np.ndarray
    rmse: float
    nrmse_percent: float
    fit_percent: float
    horizon: int
    rule: str
    scored_samples: int


def _memory_states(fit: Any, record: Record, period: int | None) -> np.ndarray:
    """Each memory state along the measured ``z``, shape ``(n, M)`` (from 0, or from the preceding period)."""
    from ..model.terms.memory import path

    terms = [t for t in fit.model.terms if t.is_memory]
    z = record.z
    lead = 0
    if period is not None and period <= z.size:
        z = np.concatenate([record.z[:period], record.z])
        lead = period
    out = np.empty((record.n, len(terms)))
    for r, term in enumerate(terms):
        out[:, r] = path(term.memory[0], term.memory[1], z)[lead:]
    return out


def predict(
    fit: Any,
    record: Record,
    horizon: int,
    *,
    rule: TransientRule | str | Mapping[str, Any] | None = None,
    partitions: int | None = None,
) -> Prediction:
    """The ``horizon``-step-ahead prediction of a model on a record (module docstring).

    Parameters
    ----------
    fit
        The identified model (:class:`nlid.IdentifiedModel`; it needs its mass).
    record
        The force that drives the runs and the data the states are taken from.
    horizon
        ``k``: samples simulated from each measured state (``1 <= k < n``).
    rule
        The transient rule (:mod:`nlid.scoring.rules`; default: the record's): an
        :class:`~nlid.scoring.InitWindow` keeps its window unscored; a periodic record's memory states
        start from its preceding period.
    partitions
        How many of the ``horizon`` interleaved sets of runs are simulated (evenly spread): ``None`` (all:
        every sample is predicted, ``horizon`` simulations of the record's length) or fewer, for a cheaper
        estimate of the same error on ``partitions / horizon`` of the samples (the others are NaN in ``z``).

    Returns
    -------
    Prediction

    Raises
    ------
    InputError
        No mass, or a horizon that is not a whole number of samples from 1 to ``n - 1``.
    nlid.simulation.SimulationError
        A ``k``-step run diverged.
    """
    from ..simulation import FREE_RUN_OVERSAMPLE, fine_force, simulate_segments

    if fit.mass is None:
        raise InputError("a prediction needs the mass: the model has none (give mass= when identifying)")
    n = record.n
    k = horizon
    if isinstance(k, (int, np.integer)) and not isinstance(k, bool):
        k = int(k)
    if not isinstance(k, int) or isinstance(k, bool) or not 1 <= k < n:
        raise InputError(f"horizon= must be a whole number of samples from 1 to {n - 1}, got {horizon!r}")
    rule = resolve_rule(rule, record)
    record = acting_record(fit, record)
    first = max(k, rule.samples if isinstance(rule, InitWindow) else 0)
    if first >= n - 1:
        raise InputError(f"nothing is left to score: the first {first} samples of {n} are not scored")
    period = None
    if isinstance(rule, PeriodicSteadyState):
        from .periods import detect_period

        period = rule.period if rule.period is not None else detect_period(record.f)
    states = np.column_stack([record.z, data_velocity(record), _memory_states(fit, record, period)])
    q = FREE_RUN_OVERSAMPLE
    if period is None:
        fine = fine_force(record.f, record.force_hold, q)
    else:
        fine = periodic_fine_force(record.f, period, record.force_hold, q)
    predicted = np.full(n, np.nan)
    if partitions is not None and (isinstance(partitions, bool) or not isinstance(partitions, int) or partitions < 1):
        raise InputError(f"partitions= must be a whole number >= 1, got {partitions!r}")
    offsets = range(k) if partitions is None or partitions >= k else np.unique(np.linspace(0, k, partitions, False))
    for offset in (int(o) for o in offsets):  # partition r: segments start at r, r + k, ... (lead-in [0, r) unused)
        starts = np.arange(offset, n, k)
        if offset:
            starts = np.concatenate([[0], starts])
        run = simulate_segments(
            fit.model,
            fit.theta,
            float(fit.mass),
            record.f,
            record.fs,
            starts,
            states[starts],
            oversample=q,
            fine=fine,
            sensitivities=False,
        )
        full = (run.lengths == k) & (starts + k < n)
        predicted[starts[full] + k] = run.end_state[full, 0]
    z = record.z[first:]
    done = np.isfinite(predicted[first:])
    if not done.all():  # some partitions only: the error over the predicted samples
        z = z[done]
        rmse, nrmse, fit_pct = error_metrics(z, predicted[first:][done])
        return Prediction(predicted, rmse, nrmse, fit_pct, k, rule.describe(), int(z.size))
    rmse, nrmse, fit_pct = error_metrics(z, predicted[first:])
    description = rule.describe()
    return Prediction(predicted, rmse, nrmse, fit_pct, k, description, int(z.size))
