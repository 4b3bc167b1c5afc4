"""The old home of the discovery loop, kept so that ``nlid.discovery.loop`` imports keep working.

The loop now lives in :mod:`nlid.discovery.search` (:class:`~nlid.discovery.search.Discovery`,
:func:`~nlid.discovery.search.discover`), its fits in :mod:`nlid.discovery.trials`, the result classes in
:mod:`nlid.discovery.result` and the choice of the identifier in :mod:`nlid.methods` (by the identifiers'
own attributes). ``PREFERRED_METHODS`` is now read from the installed identifiers' ``preference``.
"""

from __future__ import annotations

from ..methods import choose_method
from .inputs import BUILTIN_CANDIDATES, DEFAULT_HOLDOUT
from .result import VALIDATION_WORSE, DiscoveryResult, ResidualView, Stage, Step
from .search import DEFAULT_MAX_STEPS, discover
from .trials import DICTIONARY_MAX_TERMS, SHAPE_REFINE_FITS, residual_view

__all__ = [
    "PREFERRED_METHODS",  # noqa: F822 (computed from the installed identifiers by __getattr__)
    "DEFAULT_HOLDOUT",
    "DEFAULT_MAX_STEPS",
    "Stage",
    "ResidualView",
    "Step",
    "DiscoveryResult",
    "choose_method",
    "residual_view",
    "discover",
    "VALIDATION_WORSE",
    "BUILTIN_CANDIDATES",
    "DICTIONARY_MAX_TERMS",
    "SHAPE_REFINE_FITS",
]


def __getattr__(name: str):
    if name == "PREFERRED_METHODS":  # the installed identifiers that state a preference, most preferred first
        from ..methods import ranked
        from ..registry import default_registry

        identifiers = default_registry().identifiers
        return tuple(n for n in ranked(identifiers) if getattr(identifiers[n], "preference", None) is not None)
    raise AttributeError(f"module 'nlid.discovery.loop' has no attribute {name!r}")
