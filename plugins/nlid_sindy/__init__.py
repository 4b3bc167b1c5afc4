"""nlid plugin: sparse identification with pysindy (``sindy``).

Registered under the entry-point group ``nlid.identifiers`` in nlid's
``pyproject.toml``, exactly as a third-party package would register its own.
"""

from nlid.plugin import hookimpl

from .identifier import SparseIdentification
from .library import TermLibrary, auto_candidates

__all__ = ["SparseIdentification", "TermLibrary", "auto_candidates", "nlid_identifiers"]


@hookimpl
def nlid_identifiers() -> list[type]:
    """The identifiers this plugin provides."""
    return [SparseIdentification]
