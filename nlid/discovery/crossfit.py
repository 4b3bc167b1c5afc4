"""Judging a candidate by the test it will face: the cross-fitted held-out prediction.

The equation error (Eq. 25-26) is what a least-squares identifier minimises, and a candidate
term that lowers it on held-out data can still make the model *predict* worse: a benchmark
scores the free run of the model driven by the measured force, where a small error in the
damping or an extrapolating polynomial accumulates. Measured on EMPS, a velocity term
``|v|`` that lowered the held-out equation error raised the free-run error on the
benchmark's test from 8.3 to 12.6 mm. So a candidate that passes the equation-error rule
(:mod:`nlid.discovery.evidence`) must also improve the **cross-fitted held-out
prediction**:

1. The record the search was given (the whole estimation part) is cut into ``folds``
   contiguous blocks. Each block is predicted by the model fitted on the longer contiguous
   side of the rest (for two folds: the first half predicts the second and the second the
   first), so every block is held out once and every fit is on contiguous data, which every
   identifier accepts.
2. On each held-out block the model runs free from the block's start under the record's
   transient rule (a state-initialisation window, periodic steady state, or the first
   sample; :mod:`nlid.scoring.rules`). When the current model's free run is chaotic on a
   block (the chaos check of :func:`nlid.scoring.free_run_error`), a free run means nothing
   and the ``k``-step-ahead prediction (:func:`nlid.scoring.predict`) is scored instead,
   ``k`` two periods of the model's fastest linearised mode.
3. The candidate passes when it lowers the error on **every** block (one block's luck does not
   decide) and the pooled RMS error (over all scored samples) by at least ``min_gain``.

The fits are those the search will deliver: the search's identifier, or the refining
identifier (``oe``) when the search refines its final model
(``Discovery(refine=True)``): a term that an equation-error fit cannot use well but an
output-error fit can is judged by what the output-error fit does with it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..data.record import Record
from ..errors import InputError, NlidError
from ..scoring import FromFirstSample, InitWindow, TransientRule, default_rule

__all__ = [
    "PredictionRule",
    "Folds",
    "FoldPrediction",
    "make_folds",
    "predict_folds",
    "compare_predictions",
    "veto_only",
    "DEFAULT_FOLDS",
    "MIN_PREDICTION_GAIN",
    "SCREEN_EXPLAINED",
    "MIN_FOLD_SAMPLES",
]

#: Contiguous blocks of the cross-fitted prediction.
DEFAULT_FOLDS = 2
#: Smallest relative drop of the pooled RMS prediction error that accepts a candidate (1 %).
MIN_PREDICTION_GAIN = 0.01
#: Share of the held-out residual variance (equation error) that screens a candidate for the prediction check.
SCREEN_EXPLAINED = 0.02
#: Fewest samples of a held-out block (else the cross-fitted prediction is not computed and says why).
MIN_FOLD_SAMPLES = 256
#: The initialisation window of a block that starts in motion: periods of the equation band's cut-off, and the
#: fewest samples (the nonlinear-benchmarks package's EMPS window).
WINDOW_PERIODS, MIN_WINDOW = 2.0, 20
#: Interleaved sets of k-step runs simulated per block (each costs one simulation of the block; ``k`` of them
#: would predict every sample): four give the error on 4/k of the samples, spread evenly.
PARTITIONS = 4
#: Periods of the fastest linearised mode predicted ahead when the free run is chaotic, and the bounds of k.
CHAOTIC_PERIODS, CHAOTIC_MIN_STEPS, CHAOTIC_MAX_STEPS = 2.0, 5, 100

Fitter = Callable[[Record, Any, "float | None", Any], Any]


@dataclass(frozen=True)
class PredictionRule:
    """When a candidate improves the prediction (see the module docstring).

    Parameters
    ----------
    folds
        Contiguous blocks the record is cut into (at least 2).
    min_gain
        Smallest relative drop of the pooled RMS prediction error, ``0 <= min_gain < 1``.
    enabled
        ``False`` judges candidates by the equation error alone (the rule before prediction was judged).
    screen
        The share of the held-out residual variance a candidate must explain to be judged by its prediction
        (the equation-error rule's ``min_explained`` when the search is given no rule): the equation error
        screens and ranks, the prediction decides.
    """

    folds: int = DEFAULT_FOLDS
    min_gain: float = MIN_PREDICTION_GAIN
    enabled: bool = True
    screen: float = SCREEN_EXPLAINED

    def __post_init__(self) -> None:
        if isinstance(self.folds, bool) or not isinstance(self.folds, (int, np.integer)) or self.folds < 2:
            raise InputError(f"folds must be a whole number >= 2, got {self.folds!r}")
        object.__setattr__(self, "folds", int(self.folds))
        if not (isinstance(self.min_gain, (int, float)) and 0.0 <= float(self.min_gain) < 1.0):
            raise InputError(f"min_gain must lie in [0, 1), got {self.min_gain!r}")
        object.__setattr__(self, "min_gain", float(self.min_gain))
        if not (isinstance(self.screen, (int, float)) and 0.0 < float(self.screen) < 1.0):
            raise InputError(f"screen must lie between 0 and 1, got {self.screen!r}")
        object.__setattr__(self, "screen", float(self.screen))

    def describe(self) -> str:
        """The rule in one sentence (reports and JSON)."""
        if not self.enabled:
            return "candidates are judged by the equation error only (the prediction check is off)"
        return (
            f"a candidate must also lower the cross-fitted held-out prediction error: the record is cut into "
            f"{self.folds} contiguous blocks, each predicted (free run under the record's transient rule; k-step "
            "prediction where the free run is chaotic) by the model fitted on the rest; the error must drop on "
            f"every block and the pooled RMS error by at least {100 * self.min_gain:g} %"
        )

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly form, with the sentence."""
        return {
            "folds": self.folds,
            "min_gain": self.min_gain,
            "enabled": self.enabled,
            "screen": self.screen,
            "text": self.describe(),
        }


@dataclass(frozen=True)
class Folds:
    """The cross-fitting blocks of a record: each test block with the contiguous record its model is fitted on.

    Attributes
    ----------
    train, test
        One training record and one held-out block per fold.
    rule
        The transient rule of the held-out free runs (``None``: each block's own).
    note
        Why there are no folds (empty when there are).
    """

    train: tuple[Record, ...] = ()
    test: tuple[Record, ...] = ()
    rule: TransientRule | None = None
    note: str = ""

    @property
    def usable(self) -> bool:
        """True when there is at least one fold."""
        return bool(self.test)


def make_folds(record: Record, folds: int, rule: TransientRule | None) -> Folds:
    """Cut ``record`` into ``folds`` contiguous blocks; each is predicted from the longer contiguous side of the rest.

    A periodic record (``meta["periodic"]``) is cut at whole periods when it holds at least ``folds`` of them,
    so each block is scored in periodic steady state.
    """
    n = record.n
    period = record.meta.get("periodic")
    if isinstance(period, (int, np.integer)) and not isinstance(period, bool) and n // int(period) >= folds:
        per = n // int(period)
        edges = [int(period) * round(per * k / folds) for k in range(folds + 1)]
        edges[-1] = n
    else:
        edges = [round(n * k / folds) for k in range(folds + 1)]
    if min(np.diff(edges)) < MIN_FOLD_SAMPLES:
        return Folds(
            note=f"not judged by prediction: the record ({n} samples) is too short for {folds} blocks of at least "
            f"{MIN_FOLD_SAMPLES} samples"
        )
    train, test = [], []
    for k in range(folds):
        lo, hi = edges[k], edges[k + 1]
        before, after = lo, n - hi
        train.append(record[:lo] if before > after else record[hi:])
        test.append(record[lo:hi])
    return Folds(tuple(train), tuple(test), rule)


@dataclass(frozen=True)
class FoldPrediction:
    """A model's cross-fitted held-out prediction.

    Attributes
    ----------
    rmse
        RMS error of each held-out block (unit of ``z``; ``inf`` where the run diverged or the fit failed).
    samples
        Scored samples of each block.
    kind
        ``"free run"`` or ``"k-step, k = ..."``.
    notes
        What went wrong on a block, if anything.
    """

    rmse: tuple[float, ...]
    samples: tuple[int, ...]
    kind: str
    notes: tuple[str, ...] = field(default=())

    @property
    def pooled(self) -> float:
        """RMS error over every scored sample of every block (``inf`` if any block failed)."""
        if not self.rmse or any(not math.isfinite(r) for r in self.rmse):
            return math.inf
        total = sum(n for n in self.samples)
        return math.sqrt(sum(r * r * n for r, n in zip(self.rmse, self.samples, strict=True)) / max(total, 1))

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly form."""
        return {
            "rmse": [r if math.isfinite(r) else None for r in self.rmse],
            "pooled": self.pooled if math.isfinite(self.pooled) else None,
            "samples": list(self.samples),
            "kind": self.kind,
            "notes": list(self.notes),
        }


def _horizon(fit: Any, fs: float) -> int:
    """``k`` of the chaotic fallback: :data:`CHAOTIC_PERIODS` periods of the fastest linearised mode."""
    fn = [m.fn_hz for m in getattr(fit, "modal", ()) if np.isfinite(m.fn_hz) and m.fn_hz > 0]
    k = CHAOTIC_PERIODS * fs / max(fn) if fn else CHAOTIC_MAX_STEPS
    return int(min(max(round(k), CHAOTIC_MIN_STEPS), CHAOTIC_MAX_STEPS))


def predict_folds(
    fitter: Fitter, model: Any, mass: float | None, path: Any, folds: Folds, *, steps: int | None = None
) -> FoldPrediction:
    """Fit ``model`` on each fold's training record with ``fitter`` and score its prediction of the held-out block.

    Parameters
    ----------
    fitter
        ``fitter(record, model, mass, input_path) -> IdentifiedModel``.
    model, mass, path
        The model, the mass it is given (``None``: estimated) and its input path.
    folds
        From :func:`make_folds`.
    steps
        Score the ``steps``-step-ahead prediction instead of the free run (the chaotic fallback: the caller
        passes the current model's ``k`` so that two models are compared on the same measure).
    """
    rmse, samples, notes = [], [], []
    kind = "free run" if steps is None else f"k-step, k = {steps}"
    for train, test in zip(folds.train, folds.test, strict=True):
        try:
            fit = fitter(train, model, mass, path)
            rule = folds.rule if folds.rule is not None else default_rule(test)
            if steps is not None:
                found = fit.predict(test, steps, rule=rule, partitions=PARTITIONS)
                rmse.append(float(found.rmse) if np.isfinite(found.rmse) else math.inf)
                samples.append(int(found.scored_samples))
                continue
            scores = fit.score(test, free_run=True, rule=rule)
        except InputError:
            raise
        except NlidError as exc:
            rmse.append(math.inf)
            samples.append(test.n)
            notes.append(str(exc))
            continue
        if not math.isfinite(scores.freerun_rmse):
            rmse.append(math.inf)
            samples.append(test.n)
            notes.append(scores.freerun_note)
            continue
        rmse.append(float(scores.freerun_rmse))
        samples.append(int(scores.freerun_scored_samples or test.n))
    return FoldPrediction(tuple(rmse), tuple(samples), kind, tuple(notes))


def chaotic(prediction: FoldPrediction) -> bool:
    """True when a free-run prediction failed because the model is chaotic on a block."""
    return prediction.kind == "free run" and any("chaotic" in n for n in prediction.notes)


def compare_predictions(before: FoldPrediction, after: FoldPrediction, rule: PredictionRule) -> tuple[bool, str]:
    """Whether ``after`` improves on ``before`` by the rule, and why, in words.

    A free run must improve on every block and in the pooled error by ``min_gain``. A ``k``-step prediction (a
    chaotic record) can only veto: it passes unless a block is worse by more than ``min_gain``, because its
    error is dominated by the measured initial states and the chaos and barely sees a small law (measured:
    a Stribeck friction on the double well, 21 % of the held-out equation residual, changes the 100-step error
    by 0.2 %); the caller then asks the equation-error rule's full share (:func:`veto_only`).
    """
    pooled_b, pooled_a = before.pooled, after.pooled
    if not math.isfinite(pooled_a):
        why = "; ".join(dict.fromkeys(after.notes)) or "a run diverged"
        return False, f"its cross-fitted prediction fails ({why})"
    if not math.isfinite(pooled_b):
        return True, f"cross-fitted {after.kind} error {pooled_a:.4g} where the current model's fails"
    gain = 1.0 - pooled_a / pooled_b if pooled_b > 0 else 0.0
    figures = f"cross-fitted {after.kind} error {pooled_b:.4g} -> {pooled_a:.4g} ({-100 * gain:+.3g} %)"
    if veto_only(after):
        worse = [
            k + 1 for k, (b, a) in enumerate(zip(before.rmse, after.rmse, strict=True)) if a > (1.0 + rule.min_gain) * b
        ]
        if worse:
            blocks = ", ".join(str(k) for k in worse)
            return False, f"{figures}: worse by more than {100 * rule.min_gain:g} % on held-out block(s) {blocks}"
        return True, f"{figures}: no block worse by more than {100 * rule.min_gain:g} % (a chaotic record)"
    worse = [k + 1 for k, (b, a) in enumerate(zip(before.rmse, after.rmse, strict=True)) if not a < b]
    if worse:
        blocks = ", ".join(str(k) for k in worse)
        return False, f"{figures}: worse on held-out block(s) {blocks} of {len(before.rmse)}"
    if gain < rule.min_gain:
        return False, f"{figures}: less than the {100 * rule.min_gain:g} % the rule asks"
    return True, figures


def veto_only(prediction: FoldPrediction) -> bool:
    """True for a ``k``-step prediction: on a chaotic record the prediction can veto a candidate, not accept it."""
    return prediction.kind.startswith("k-step")


def fold_rule(record: Record, rule: TransientRule | None, cutoff: float) -> TransientRule | None:
    """The transient rule of the held-out blocks: the given one, else the record's (a window if it moves at the start).

    A periodic record keeps its periodic steady state. Otherwise a block cut from the middle of a record does not
    start at rest, so the first-sample rule (the default of a record that is not periodic) is replaced by an
    initialisation window of :data:`WINDOW_PERIODS` periods of the equation band's cut-off ``cutoff`` (Hz), at
    least :data:`MIN_WINDOW` samples: the state is fitted to it, as the benchmarks' windows do.
    """
    if rule is not None:
        return rule
    found = default_rule(record)
    if isinstance(found, FromFirstSample):
        return InitWindow(int(max(MIN_WINDOW, math.ceil(WINDOW_PERIODS * record.fs / cutoff))))
    return found


def steps_for(fits: Sequence[Any], fs: float) -> int:
    """``k`` of the chaotic fallback for the first of ``fits`` that has modes."""
    for fit in fits:
        if getattr(fit, "modal", ()):
            return _horizon(fit, fs)
    return CHAOTIC_MAX_STEPS
