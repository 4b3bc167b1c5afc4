"""Moved to :mod:`nlid.runtime.forkserver`; this name keeps working (importing it imports that module)."""

from .runtime.forkserver import THREAD_ENV

__all__ = ["THREAD_ENV"]
