"""nlid plugin: restoring-force-surface least squares (``rfs``).

Registered under the entry-point group ``nlid.identifiers`` in nlid's
``pyproject.toml``, exactly as a third-party package would register its own.
"""

from nlid.plugin import hookimpl

from .identifier import RestoringForceSurface

__all__ = ["RestoringForceSurface", "nlid_identifiers"]


@hookimpl
def nlid_identifiers() -> list[type]:
    """The identifiers this plugin provides."""
    return [RestoringForceSurface]
