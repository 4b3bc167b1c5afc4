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

__all__ = ["hookspec", "hookimpl", "nlid_identifiers", "nlid_candidates"]

PROJECT = "nlid"
hookspec = pluggy.HookspecMarker(PROJECT)
hookimpl = pluggy.HookimplMarker(PROJECT)


@hookspec
def nlid_identifiers() -> list[type]:
    """Return the identifier classes this plugin provides.

    Each class follows :class:`nlid.contract.identifier.Identifier`: it has ``name``,
    ``summary``, ``options``, ``needs_mass`` and an ``identify(record, model,
    *, mass=None)`` method returning an
    :class:`~nlid.contract.estimate.Estimate`.
    """


@hookspec
def nlid_candidates() -> list:
    """Return candidate effects for the residual -> missing-effect loop (``nlid discover``).

    Each item is an :class:`nlid.discovery.Candidate`: a name (what the report
    and ``--candidates`` call it), the terms it adds to a model and,
    optionally, a shape parameter the loop chooses on a grid. A plugin that
    only provides candidates registers under the same entry-point group
    (``nlid.identifiers``) and implements just this hook.
    """
