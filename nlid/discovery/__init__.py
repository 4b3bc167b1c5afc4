"""Close the loop: find the residual, trace it to a missing effect, add it, report the error.

:func:`discover` identifies a declared model, tests candidate effects
(:mod:`nlid.discovery.library`) against its residual, accepts one only when it
passes a stated rule (:mod:`nlid.discovery.evidence`), re-identifies and
repeats. :func:`write_report` writes the Markdown/HTML report with the
residual figures (:mod:`nlid.discovery.plots`). The command line is
``nlid discover``; the documentation is ``docs/discover.md``.
"""

from .evidence import AcceptanceRule, Evidence, Scores
from .library import LIBRARY, Candidate, Shape, library_names, resolve_candidates
from .loop import DiscoveryResult, ResidualView, Stage, Step, choose_method, discover
from .report import summary_table, write_report

__all__ = [
    "discover",
    "write_report",
    "summary_table",
    "choose_method",
    "DiscoveryResult",
    "Stage",
    "Step",
    "ResidualView",
    "AcceptanceRule",
    "Evidence",
    "Scores",
    "Candidate",
    "Shape",
    "LIBRARY",
    "library_names",
    "resolve_candidates",
]
