"""Moved to :mod:`nlid.runtime.preload`; this name keeps working (importing it imports that module)."""

from .runtime.preload import warm_up

__all__ = ["warm_up"]
