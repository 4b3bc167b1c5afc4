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
from .evidence import AcceptanceRule, Evidence, rank

__all__ = ["Judge", "MAX_JUDGED", "JUDGE_TOL", "judging_options"]

#: Candidates judged by their cross-fitted prediction in one round (in the order of the equation-error rule); a
#: round whose first ones all fail the prediction check stops the search.
MAX_JUDGED = 3

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
        """Rank the candidates and accept the best whose cross-fitted prediction is better too.

        Candidates the equation-error rule accepts are judged in its order, :data:`MAX_JUDGED` at most; one
        that does not improve the prediction is rejected (and said), and the next one gets its turn.
        Returns the ranking, the accepted candidate (``None``: none) and the current stage with its
        prediction measured.
        """
        ranking, accepted = rank(tested)
        if accepted is None or not self.rule.enabled or not self.folds.usable:
            return ranking, accepted, current
        for _ in range(MAX_JUDGED):
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
                return ranking, accepted, current
            say(f"{accepted.effect} lowers the equation error but not the prediction: {why}")
            accepted.status, accepted.reason = "rejected", f"{accepted.rule_reason}; but {why}"
            ranking, accepted = rank(tested)
            if accepted is None:
                return ranking, None, current
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
