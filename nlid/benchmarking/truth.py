"""The true system's row: a simulated benchmark's declared system, scored like any fitted model.

A benchmark whose data were simulated (Bouc-Wen) declares the system that generated them
(``[truth]`` in its file: :class:`~nlid.benchmarking.declarations.Truth`). Scored on a test set
under the test set's rule by the one scorer every row goes through
(:func:`nlid.benchmarking.jobs.score_model`), it is the figure a perfect model reaches with
nlid's scorer: the floor of that table, and a check of the instrument itself (a scorer that
gives the truth more than a fitted model is coarser than the models it ranks). It is the
``truth`` pipeline (:mod:`nlid.benchmarking.pipelines`): one row per test set, whatever else runs.
"""

from __future__ import annotations

from ..identified.reference import Reference
from .declarations import Protocol
from .fitted import Fitted
from .prior import Prior

__all__ = ["true_fitted", "TRUTH_KIND", "TRUTH_PIPELINE"]

#: The ``kind`` of the true system's rows (beside ``"nlid"``, ``"peer"``, ``"published"``, ``"reference"``).
TRUTH_KIND = "truth"
#: The pipeline name of the true system's rows.
TRUTH_PIPELINE = "true system"


def true_fitted(protocol: Protocol) -> list[Fitted]:
    """The declared true system of a benchmark as a fitted model (none when the benchmark declares none).

    Nothing is fitted: ``parameters`` is 0 and ``choices`` is empty (no decision is made on any data).
    It knew everything: the mass, the terms and their shapes (:class:`~nlid.benchmarking.prior.Prior`).
    """
    if protocol.truth is None:
        return []
    model = Reference.from_mapping(protocol.truth.as_mapping()).true_model(f"benchmark {protocol.name}'s [truth]")
    method = f"the system that generated the data ({protocol.truth.source})"
    prior = Prior("given", "true model", "given", protocol.truth.source)
    return [Fitted(TRUTH_PIPELINE, TRUTH_KIND, method, model, 0, 0.0, prior=prior)]
