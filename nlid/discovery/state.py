"""The state of a search: what it fixed before its first round, and where it stands after each.

:class:`SearchSetup` is shared by every state of one search; :class:`SearchState` is what
:meth:`nlid.discovery.search.Discovery.steps` yields after each round (nothing is changed in place).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from ..model.terms import Model
from .evidence import Evidence
from .inputs import CandidateLibrary
from .judge import Judge
from .result import ResidualView, Stage, Step
from .trials import Context

__all__ = ["SearchSetup", "SearchState"]


@dataclass(frozen=True)
class SearchSetup:
    """What a search fixed before its first round, shared by its states.

    The records, identifier and band (:class:`~nlid.discovery.trials.Context`), the method and why, the
    declared model, the candidates, the estimation record's range of ``z`` and the start time.
    """

    context: Context
    method: str
    method_notes: tuple[str, ...]
    declared: Model
    held_text: str
    source: str
    holdout_source: str
    units: dict[str, str]
    library: CandidateLibrary
    use_mass: bool
    z_range: tuple[float, float]
    started: float
    judge: Judge


@dataclass(frozen=True)
class SearchState:
    """Where a search stands after a round; each round yields a new one (nothing is changed in place).

    Attributes
    ----------
    run
        What the search fixed before its first round (:class:`SearchSetup`).
    stages
        The declared model's stage, then one per accepted step (each carries its own mass,
        :attr:`~nlid.discovery.result.Stage.given_mass`).
    steps
        The accepted effects.
    views
        The residual view of each stage (estimation record).
    ranking
        The candidates of the round that accepted nothing, with their evidence (empty otherwise).
    stop_reason
        Why the search stopped; empty while it goes on.
    """

    run: SearchSetup = dataclasses.field(repr=False)
    stages: tuple[Stage, ...]
    steps: tuple[Step, ...] = ()
    views: tuple[ResidualView, ...] = ()
    ranking: tuple[Evidence, ...] = ()
    stop_reason: str = ""

    @property
    def stage(self) -> Stage:
        """The current model."""
        return self.stages[-1]

    @property
    def step(self) -> Step | None:
        """The last accepted effect (``None`` before the first)."""
        return self.steps[-1] if self.steps else None

    @property
    def done(self) -> bool:
        """Whether the search stopped by itself."""
        return bool(self.stop_reason)

    @property
    def added(self) -> frozenset[str]:
        """Effects this search added (not tested again; the dictionary may propose terms again)."""
        return frozenset(s.effect for s in self.steps if s.effect != "dictionary")
