"""Entry point of ``nsi-shift`` (group ``nlid.identifiers``)."""

from nlid.plugin import hookimpl

from .shift import NSIZeroShift


@hookimpl
def nlid_identifiers() -> list[type]:
    """The identifier this plugin provides."""
    return [NSIZeroShift]
