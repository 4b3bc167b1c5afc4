"""The old home of :mod:`nlid.frozen` (kept so that old imports and pickles of ``FrozenDict`` still resolve)."""

from __future__ import annotations

from .frozen import FrozenDict, freeze

__all__ = ["FrozenDict", "freeze"]
