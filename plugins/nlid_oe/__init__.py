"""nlid plugin: output-error identification (``oe``), fitting the free-run simulation itself.

Registered under the entry-point group ``nlid.identifiers`` in nlid's ``pyproject.toml``, exactly as a
third-party package would register its own.
"""

from nlid.plugin import hookimpl

from .identifier import OutputError

__all__ = ["OutputError", "nlid_identifiers"]


@hookimpl
def nlid_identifiers() -> list[type]:
    """The identifiers this plugin provides."""
    return [OutputError]
