"""One fitted model of a bench pipeline, and the choices it made (all on the estimation part)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from .prior import Prior

__all__ = ["Fitted"]


@dataclass
class Fitted:
    """One fitted model of a pipeline, and the choices it made (all on the estimation part).

    Attributes
    ----------
    pipeline
        The pipeline's name.
    kind
        ``"nlid"``, ``"peer"`` or ``"truth"``.
    method
        What fitted it, in words (``"rfs"``, ``"discover (rfs), refit on the estimation part"``...).
    model
        The :class:`~nlid.identified.model.IdentifiedModel` or the :class:`~nlid.benchmarking.peer.PeerModel`.
    parameters
        Fitted parameters: coefficients, the mass when estimated, shape parameters chosen from data.
    seconds
        Wall time of the pipeline (its share, when two pipelines share a discovery).
    choices
        Every decision (terms, steps, coefficients, hyper-parameters): what must not depend on the test sets.
    details
        For the report (discovery steps and their hold-out scores, equations).
    prior
        What the pipeline was given (:class:`~nlid.benchmarking.prior.Prior`).
    """

    pipeline: str
    kind: str
    method: str
    model: Any
    parameters: int
    seconds: float
    choices: dict[str, Any] = field(default_factory=dict)
    details: dict[str, Any] = field(default_factory=dict)
    prior: Prior = field(default_factory=Prior)
