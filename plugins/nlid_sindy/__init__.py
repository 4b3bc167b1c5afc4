"""nlid plugin: sparse identification with pysindy (``sindy``).

Registered under the entry-point group ``nlid.identifiers`` in nlid's
``pyproject.toml``, exactly as a third-party package would register its own. pysindy is imported when the plugin
identifies, not when its entry point is loaded.
"""

from typing import Any

from nlid.plugin import hookimpl

from .identifier import SparseIdentification

__all__ = ["SparseIdentification", "TermLibrary", "auto_candidates", "nlid_identifiers"]


def __getattr__(name: str) -> Any:
    """``TermLibrary`` and ``auto_candidates`` on first use: their module imports pysindy (~1-5 s)."""
    if name in ("TermLibrary", "auto_candidates"):
        from . import library

        return getattr(library, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


@hookimpl
def nlid_identifiers() -> list[type]:
    """The identifiers this plugin provides."""
    return [SparseIdentification]
