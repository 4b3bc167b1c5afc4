"""The study row's column families (declared in :mod:`nlid.columns`, re-exported here as the study's vocabulary).

The declarations live in the core module :mod:`nlid.columns` because two
producers of the row sit below the study package and must not import it:
:meth:`nlid.reference.Comparison.to_row` (coefficient, mass, equilibrium
and modal columns) and :func:`nlid.bayes.study_metrics` (the posterior's
``ci_*`` columns). Producers build keys through a declaration
(``COEF_ERROR.key(term)``), consumers read through it
(``COEF_ERROR.labels(frame.columns)``); nothing else spells a column key.
"""

from __future__ import annotations

from ..columns import *  # noqa: F403 - this module is the study's name for the declarations
from ..columns import __all__  # noqa: F401
