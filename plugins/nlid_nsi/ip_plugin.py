"""Entry point of ``nsi-ip`` (group ``nlid.identifiers``)."""

from nlid.plugin import hookimpl

from .ip import NSIInputPerturbation


@hookimpl
def nlid_identifiers() -> list[type]:
    """The identifier this plugin provides."""
    return [NSIInputPerturbation]
