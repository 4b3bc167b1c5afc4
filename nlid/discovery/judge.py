"""The prediction check of a round: the candidates the equation error accepts, judged by what they predict.

:class:`Judge` holds what a search fixed for its prediction check (the rule, the cross-fitting blocks of the
record and the fitter: the search's identifier, or the refiner when the search refines its final model) and
ranks a round's candidates (:func:`nlid.discovery.evidence.rank`), then accepts the first one, in the equation
error's order, whose cross-fitted held-out prediction is better too (:mod:`nlid.discovery.crossfit`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from ..data.record import Record
from ..identification.pipeline import identify
from ..model.terms import Model
from .crossfit import (
    FoldPrediction,
    Folds,
    PredictionRule,
    chaotic,
    compare_predictions,
    fold_rule,
    make_folds,
    predict_folds,
    steps_for,
    veto_only,
)
from .evidence import AcceptanceRule, Evidence, eligible, rank

__all__ = ["Judge", "MAX_JUDGED", "RIVAL_SHARE", "JUDGE_TOL", "judging_options"]

#: Candidates judged by their cross-fitted prediction in one round (in the order of the equation-error rule); a
#: round whose first ones all fail the prediction check stops the search.
MAX_JUDGED = 3

#: Once a candidate improves the prediction, the next ones are judged against it only while they explain at least
#: this share of its part of the held-out equation residual (Silverbox after ``1, z, z^3, v``: ``z^2`` 8.5 %,
#: ``v*|v|`` 6.5 %, both judged, ``v*|v|`` predicts better; Bouc-Wen: the hysteresis 98 %, the mass and ``z^3``
#: under 1 %, not judged: two output-error fits per block saved, 40 s of its 90).
RIVAL_SHARE = 0.5

#: Relative tolerance (option ``tol``) of the refiner's fits that judge candidates, when it declares one (``oe``:
#: 1e-8 by default). A judging fit only has to rank two models' held-out predictions against a 1 % gain
#: (:data:`nlid.discovery.crossfit.MIN_PREDICTION_GAIN`); the model the search delivers is refitted at the
#: refiner's default. Measured on the three benchmarks' discover-refine (docs/performance.md, round four, fourth
#: session): the same decisions; the judged predictions within 1e-7 of the default's (2.2e-3 on EMPS, whose
#: sign(v) fits have flat optima); 323 -> 201 evaluations of the judging fits on EMPS, 65 -> 60 on Silverbox.
JUDGE_TOL = 1e-5

#: A stage of the search (:class:`nlid.discovery.result.Stage`), read by its attributes.
StageLike = Any


def judging_options(identifier: type, method: str) -> dict[str, Any]:
    """A judging refiner's options: started from ``method``, at :data:`JUDGE_TOL` when it has ``tol``."""
    options: dict[str, Any] = {"init": method}
    if any(option.name == "tol" for option in getattr(identifier, "options", ())):
        options["tol"] = JUDGE_TOL
    return options


@dataclass(frozen=True)
class Judge:
    """A search's prediction check: the rule, the blocks and the fitter (see the module docstring).

    Build it with :meth:`for_search`.
    """

    rule: PredictionRule
    folds: Folds
    fitter: Any = None
    fs: float = 1.0

    @classmethod
    def for_search(
        cls,
        rule: PredictionRule,
        record: Record,
        identifier: Any,
        cutoff: float,
        freerun_rule: Any = None,
    ) -> Judge:
        """The check of a search on ``record`` (the whole record given to it), fitting with ``identifier``."""
        if not rule.enabled:
            return cls(rule, Folds(note="the prediction check is off"), None, record.fs)
        folds = make_folds(record, rule.folds, fold_rule(record, freerun_rule, cutoff))

        def fit(part: Record, model: Model, mass: float | None, path: Any) -> Any:
            return identify(part, model, identifier, mass=mass, cutoff=cutoff, input_path=path)

        return cls(rule, folds, fit, record.fs)

    def to_dict(self) -> dict[str, Any]:
        """The rule and the blocks' rule, for the result's ``info``."""
        return {
            **self.rule.to_dict(),
            "folds_note": self.folds.note,
            "fold_rule": None if self.folds.rule is None else self.folds.rule.describe(),
        }

    def predict(self, stage: StageLike, steps: int | None = None) -> FoldPrediction:
        """A stage's model fitted on each block's training record and scored on the block."""
        return predict_folds(self.fitter, stage.model, stage.given_mass, stage.path, self.folds, steps=steps)

    def judged(
        self,
        current: StageLike,
        tested: list[Evidence],
        fits: dict[str, StageLike],
        say: Callable[[str], None],
    ) -> tuple[list[Evidence], Evidence | None, StageLike]:
        """Rank the candidates and accept, of those whose cross-fitted prediction is better too, the best predicting.

        Candidates the equation-error rule accepts are judged in its order, :data:`MAX_JUDGED` at most; one
        that does not improve the prediction is rejected (and said). Of those that improve it, the one with the
        lowest pooled free-run error is accepted: the equation error screens and ranks, the prediction decides
        between the candidates too. Once one improves it, the next are judged only while they explain at least
        :data:`RIVAL_SHARE` of its share of the held-out residual; a ``k``-step prediction (a chaotic record)
        only vetoes, so there the first that passes is accepted. Returns the ranking, the accepted candidate
        (``None``: none) and the current stage with its prediction measured.
        """
        ranking, accepted = rank(tested)
        if accepted is None or not self.rule.enabled or not self.folds.usable:
            return ranking, accepted, current
        judged: list[Evidence] = []
        improving: list[tuple[Evidence, FoldPrediction, str]] = []
        while accepted is not None and len(judged) < MAX_JUDGED:
            if improving and float(accepted.explained_holdout or 0.0) < RIVAL_SHARE * float(
                improving[0][0].explained_holdout or 0.0
            ):
                break  # explains far less than a candidate that improves the prediction: not judged against it
            judged.append(accepted)
            current, after, ok, why = self._judge_one(current, accepted, fits, say)
            if ok:
                improving.append((accepted, after, why))
                if veto_only(after):  # a k-step prediction cannot choose between candidates
                    break
            ranking, accepted = _rank_without(tested, [e for e, _, _ in improving])
        if not improving:
            # the next eligible ones were not judged: they are not accepted unjudged
            for ev in tested:
                if ev.status == "accepted" or (ev.status == "rejected" and ev.passes and all(ev.passes.values())):
                    ev.passes["prediction"] = False
                    ev.status = "rejected"
                    ev.reason = (
                        f"{ev.rule_reason}; not judged by prediction: the {MAX_JUDGED} candidates before it did not "
                        "improve it"
                    )
            ranking, _ = rank(tested)
            return ranking, None, current
        kind = improving[0][1].kind
        best, best_after, best_why = min((x for x in improving if x[1].kind == kind), key=lambda x: x[1].pooled)
        for ev, after, why in improving:
            if ev is not best:
                ev.passes["best_prediction"] = False
                ev.status = "rejected"
                ev.reason = (
                    f"{ev.rule_reason}; {why}, but {best.effect!r} predicts better ({best_after.pooled:.4g} against "
                    f"{after.pooled:.4g})"
                )
        for ev in tested:  # eligible but not judged: the judged ones decide
            if all(ev is not j for j in judged) and eligible(ev):
                ev.passes["prediction"] = False
                ev.status = "rejected"
                ev.reason = (
                    f"{ev.rule_reason}; not judged by prediction: {best.effect!r}, judged before it, improves the "
                    f"prediction (at most {MAX_JUDGED} are judged, those explaining {100 * RIVAL_SHARE:g} % of its "
                    "share or more)"
                )
        ranking, accepted = rank(tested)
        assert accepted is best
        accepted.reason = f"{accepted.rule_reason}; {best_why}"
        return ranking, accepted, current

    def _judge_one(
        self, current: StageLike, accepted: Evidence, fits: dict[str, StageLike], say: Callable[[str], None]
    ) -> tuple[StageLike, FoldPrediction, bool, str]:
        """One candidate's cross-fitted prediction against the current model's: ``(current, after, ok, why)``.

        ``current`` comes back with its prediction measured; a candidate that passes gets its prediction in
        ``fits`` and the figures in its reason, one that fails is rejected (and said).
        """
        if current.prediction is None:
            before = self.predict(current)
            if chaotic(before):  # a chaotic free run means nothing: k steps ahead instead
                before = self.predict(current, steps_for([current.identified], self.fs))
            current = dataclasses.replace(current, prediction=before)
        before = current.prediction
        steps = int(before.kind.rsplit("=", 1)[1]) if before.kind.startswith("k-step") else None
        say(f"judging {accepted.effect} by its cross-fitted prediction ({before.kind})")
        after = self.predict(fits[accepted.effect], steps)
        if chaotic(after):  # the candidate's free run is chaotic: both are compared k steps ahead
            steps = steps_for([current.identified, fits[accepted.effect].identified], self.fs)
            before = self.predict(current, steps)
            after = self.predict(fits[accepted.effect], steps)
        ok, why = compare_predictions(before, after, self.rule)
        floor = AcceptanceRule().min_explained
        if ok and veto_only(after) and float(accepted.explained_holdout or 0.0) < floor:
            # a chaotic record: the k-step prediction cannot decide, so the equation error decides at its full share
            ok = False
            share = 100 * float(accepted.explained_holdout or 0.0)
            why += (
                f"; on a chaotic record the equation error decides, and it explains {share:.3g} % < "
                f"{100 * floor:g} % of the held-out residual"
            )
        accepted.prediction_before, accepted.prediction_after = before.to_dict(), after.to_dict()
        accepted.passes["prediction"] = ok
        if ok:
            fits[accepted.effect] = dataclasses.replace(fits[accepted.effect], prediction=after)
            accepted.reason = f"{accepted.rule_reason}; {why}"
        else:
            say(f"{accepted.effect} lowers the equation error but not the prediction: {why}")
            accepted.status, accepted.reason = "rejected", f"{accepted.rule_reason}; but {why}"
        return current, after, ok, why


def _rank_without(tested: list[Evidence], held: list[Evidence]) -> tuple[list[Evidence], Evidence | None]:
    """:func:`rank` with the candidates ``held`` (already judged and improving) left out of the choice."""
    for ev in held:
        ev.passes["judged"] = False
    try:
        return rank(tested)
    finally:
        for ev in held:
            del ev.passes["judged"]
