"""Hook specifications of nlid (pluggy project name ``"nlid"``).

Plugins are modules (or objects) registered under the entry-point group
``nlid.identifiers``; they implement these hooks with the :data:`hookimpl`
marker::

    from nlid import hookimpl

    @hookimpl
    def nlid_identifiers():
        return [MyIdentifier]

nlid's own identifiers (``rfs``, ``nsi-ip``, ...) are plugins of exactly this
kind, shipped in ``plugins/`` and registered in ``pyproject.toml``.
"""

from __future__ import annotations

import pluggy

__all__ = ["hookspec", "hookimpl", "nlid_identifiers"]

PROJECT = "nlid"
hookspec = pluggy.HookspecMarker(PROJECT)
hookimpl = pluggy.HookimplMarker(PROJECT)


@hookspec
def nlid_identifiers() -> list[type]:
    """Return the identifier classes this plugin provides.

    Each class follows :class:`nlid.interface.Identifier`: it has ``name``,
    ``summary``, ``options``, ``needs_mass`` and an ``identify(record, model,
    *, mass=None)`` method returning an
    :class:`~nlid.interface.IdentificationResult`.
    """
