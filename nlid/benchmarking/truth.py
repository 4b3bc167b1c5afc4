"""The "true model" row: a benchmark's own model, scored by the same scorer as every other row.

Where a benchmark's truth is known (a simulated benchmark such as Bouc-Wen; its file's ``[truth]``),
the leaderboard shows the true model under the scorer it uses for every row. That row measures the
scorer as much as the models: a true model that scores worse than a fitted one says the scorer (the
force's interpolation between samples, the transient rule) is coarser than the models it ranks.

:func:`true_model` is the one place that turns a ``[truth]`` into a model the scorer runs. It builds
an :class:`~nlid.identified.IdentifiedModel` from the declared coefficients and mass; a finer
"true model under this scorer" (the scorer's own force interpolation, its integrator) replaces this
function and every leaderboard follows.
"""

from __future__ import annotations

from typing import Any

from .declarations import Protocol

__all__ = ["true_model"]


def true_model(protocol: Protocol) -> Any:
    """The benchmark's own model as an :class:`~nlid.identified.IdentifiedModel`, or ``None`` when unknown."""
    truth = protocol.truth
    if truth is None:
        return None
    from ..identified import IdentifiedModel
    from ..terms import Model

    coefficients = dict(truth.coefficients)
    model = Model.from_spec(list(coefficients), defaults=False)
    return IdentifiedModel(model, coefficients, truth.mass, "truth")
