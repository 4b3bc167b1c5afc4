"""Close the loop: find the residual, trace it to a missing effect, add it, report the error.

:func:`discover` identifies a declared model, tests candidate effects
(:mod:`nlid.discovery.library`) against its residual, accepts one only when it
passes a stated rule (:mod:`nlid.discovery.evidence`), re-identifies and
repeats; a candidate must also improve the cross-fitted held-out prediction
(:mod:`nlid.discovery.crossfit`), and effects in the input path (a delay, a lag, the force's hold;
:mod:`nlid.estimation.inputpath`) are candidates like the terms. :func:`write_report` writes the Markdown/HTML report
with the
residual figures (:mod:`nlid.discovery.plots`). The command line is
``nlid discover``; the documentation is ``docs/discover.md``.

:func:`discover` is a thin wrapper of :class:`Discovery` (:mod:`nlid.discovery.search`), whose
:meth:`~Discovery.steps` yields the search's state after each round, with a :class:`CandidateLibrary`
(the effects it may add) and a :class:`Split` (estimation / hold-out / validation). The result classes
are in :mod:`nlid.discovery.result`, the fits in :mod:`nlid.discovery.trials`.
"""

from .crossfit import FoldPrediction, PredictionRule
from .evidence import AcceptanceRule, Evidence, Scores
from .inputs import CandidateLibrary, Split
from .library import LIBRARY, Candidate, Shape, library_names, resolve_candidates
from .paths import INPUT_PATH, InputPathCandidate
from .report import discovery_summary, summary_table, write_report
from .result import DiscoveryResult, ResidualView, Stage, Step
from .search import Discovery, discover
from .state import SearchState

__all__ = [
    "discover",
    "Discovery",
    "SearchState",
    "CandidateLibrary",
    "Split",
    "discovery_summary",
    "write_report",
    "summary_table",
    "DiscoveryResult",
    "Stage",
    "Step",
    "ResidualView",
    "AcceptanceRule",
    "PredictionRule",
    "FoldPrediction",
    "Evidence",
    "Scores",
    "Candidate",
    "Shape",
    "InputPathCandidate",
    "INPUT_PATH",
    "LIBRARY",
    "library_names",
    "resolve_candidates",
]
