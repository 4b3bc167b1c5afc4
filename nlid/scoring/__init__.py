"""How well an identified model meets a record: the one place every score is computed.

Every layer of nlid (the pipeline, ``nlid identify``, studies, discovery,
posteriors, the output-error identifier, benchmarks) scores a model on data
through the functions here, so that the same model on the same record gets the
same number whichever command asks.

Scores (:class:`Scores`, from :func:`score`):

``eps_percent``
    The percentage RMS residual of the restoring-force surface (Eq. 26):
    ``100 RMS(R_e - R_hat) / RMS(R_e)`` with ``R_e = f - m a`` (Eq. 25),
    formed in the band of the shared differentiating filter when a channel
    the model needs is estimated (:func:`nlid.estimation.balance.regression_data`).
``force_residual_percent``
    The same residual relative to the force, ``100 RMS(f - m a - R_hat) /
    RMS(f)``: the "relative force residual" of inverse-dynamics benchmarks
    such as EMPS.
``freerun_rmse``, ``freerun_nrmse_percent``, ``freerun_fit_percent``, ``freerun_note``
    The free-run simulation error of the displacement: the model driven by the
    record's force (a zero-order-held force held, a sampled one interpolated
    between the samples), started and scored under a *transient rule*
    (:mod:`nlid.scoring.rules`, ``freerun_rule`` says which and what it found;
    ``freerun_scored_samples`` how many samples are scored). Over the scored
    samples: ``RMS(z_sim - z)`` in the unit of ``z`` (the RMSE benchmark tables
    quote), that relative to ``std(z)`` (NRMSE), and the fit of MATLAB's
    ``compare``, ``100 (1 - |z - z_sim| / |z - mean(z)|)`` (100 % a perfect
    match; ``100 - freerun_nrmse_percent`` up to rounding). The default rule is
    the one a benchmark paper would use for the record
    (:func:`default_rule`): a declared benchmark's own, periodic steady state
    for a periodic record (declared, a force that repeats with a response that
    does, or one period of a multisine: :mod:`nlid.scoring.periods`), else
    from the record's first sample (``z[0]`` and
    the velocity at ``t = 0``, measured or differentiated through the shared
    filter at its suggested cut-off: a property of the record alone, so the
    number does not depend on who asks). It is not reported for a model that
    is too sensitive to its initial state for one free run to mean anything
    (chaotic): two runs started :data:`SENSITIVITY_DELTA` ``std(z)`` apart
    that differ by more than :data:`SENSITIVITY_LIMIT` ``std(z)`` (RMS over the
    second half of the scored samples). ``freerun_note`` says why a figure is
    missing.
``predict_rmse``, ``predict_fit_percent``, ``predict_horizon``
    With ``score(..., horizon=k)``: the ``k``-step-ahead prediction error
    (:func:`predict`), finite for chaotic records too.

The package holds one job per module: :mod:`~nlid.scoring.scores` (the
scores), :mod:`~nlid.scoring.rules` (the transient rules),
:mod:`~nlid.scoring.periods` (the period of a record),
:mod:`~nlid.scoring.prediction` (``k``-step-ahead prediction),
:mod:`~nlid.scoring.surface` (slices of the restoring surface) and
:mod:`~nlid.scoring.twin` (the chaos check's pair of free runs, the second
stopped where it joins the first).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..base.lazy import lazy_face

if TYPE_CHECKING:  # loaded on first use by __getattr__ below: importing one submodule loads no other
    from .coverage import RANGE_TOLERANCE, RangeExcess, beyond_range, range_excess, value_range
    from .periods import detect_period, multisine_lines, record_period
    from .prediction import Prediction, predict
    from .rules import FromFirstSample, InitWindow, PeriodicSteadyState, TransientRule, default_rule, rule_from_spec
    from .scores import (
        HORIZON_STARTS,
        SENSITIVITY_DELTA,
        SENSITIVITY_LIMIT,
        FreeRun,
        FreeRunResponse,
        ModelFit,
        Residual,
        Scores,
        epsilon,
        force_residual_percent,
        free_run_error,
        free_run_response,
        initial_state,
        predictability_horizon,
        residual,
        score,
    )
    from .surface import DampingSlice, damping_slice

#: Public name -> module that defines it (imported on first access).
_LAZY: dict[str, str] = {
    "RANGE_TOLERANCE": "nlid.scoring.coverage",
    "RangeExcess": "nlid.scoring.coverage",
    "beyond_range": "nlid.scoring.coverage",
    "range_excess": "nlid.scoring.coverage",
    "value_range": "nlid.scoring.coverage",
    "Prediction": "nlid.scoring.prediction",
    "predict": "nlid.scoring.prediction",
    "FromFirstSample": "nlid.scoring.rules",
    "InitWindow": "nlid.scoring.rules",
    "PeriodicSteadyState": "nlid.scoring.rules",
    "TransientRule": "nlid.scoring.rules",
    "default_rule": "nlid.scoring.rules",
    "detect_period": "nlid.scoring.periods",
    "multisine_lines": "nlid.scoring.periods",
    "record_period": "nlid.scoring.periods",
    "rule_from_spec": "nlid.scoring.rules",
    "HORIZON_STARTS": "nlid.scoring.scores",
    "SENSITIVITY_DELTA": "nlid.scoring.scores",
    "SENSITIVITY_LIMIT": "nlid.scoring.scores",
    "FreeRun": "nlid.scoring.scores",
    "FreeRunResponse": "nlid.scoring.scores",
    "ModelFit": "nlid.scoring.scores",
    "Residual": "nlid.scoring.scores",
    "Scores": "nlid.scoring.scores",
    "epsilon": "nlid.scoring.scores",
    "force_residual_percent": "nlid.scoring.scores",
    "free_run_error": "nlid.scoring.scores",
    "free_run_response": "nlid.scoring.scores",
    "initial_state": "nlid.scoring.scores",
    "predictability_horizon": "nlid.scoring.scores",
    "residual": "nlid.scoring.scores",
    "score": "nlid.scoring.scores",
    "DampingSlice": "nlid.scoring.surface",
    "damping_slice": "nlid.scoring.surface",
}

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
    "DampingSlice",
    "damping_slice",
    "SENSITIVITY_DELTA",
    "SENSITIVITY_LIMIT",
    "FromFirstSample",
    "InitWindow",
    "PeriodicSteadyState",
    "TransientRule",
    "detect_period",
    "multisine_lines",
    "record_period",
    "default_rule",
    "rule_from_spec",
    "Prediction",
    "predict",
    "RANGE_TOLERANCE",
    "RangeExcess",
    "beyond_range",
    "range_excess",
    "value_range",
]


__getattr__, __dir__ = lazy_face(__name__, _LAZY, __all__)
