"""How :func:`nlid.identify` runs an identifier on a structure record (several DOFs).

:func:`identify_structure` is the multi-DOF branch of :func:`nlid.identify`:
it resolves the identifier, refuses one that handles a single DOF (its
``dofs`` class attribute, :class:`nlid.plugin.Identifier`), parses the elements,
checks the mass matrix, runs the identifier (timing it and isolating its
failures as for one DOF), checks its :class:`~nlid.contract.structure_estimate.StructureEstimate`
and completes it into an :class:`~nlid.identified.structure.IdentifiedStructure`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Mapping
from typing import Any

from ..base.validate import check_cutoff
from ..contract.estimate import timed_call
from ..contract.registry import Registry, make_identifier
from ..contract.structure_estimate import check_structure_estimate
from ..data.record import Record
from ..errors import InputError
from ..identified.structure import IdentifiedStructure
from ..model.elements import ElementSet
from ..model.spelling import Connection
from ..model.structure import structure_mass
from .provenance import structure_provenance

__all__ = ["identify_structure", "as_elements", "check_dofs"]


def as_elements(
    terms: Any,
    n_dofs: int,
    *,
    without: str | Iterable[str] | None = (),
    px_roots: Mapping[Connection, Any] | None = None,
) -> ElementSet:
    """The :class:`ElementSet` to identify on ``n_dofs`` DOFs from terms on connections or an element set.

    ``without="1"`` leaves out the constant force per DOF (the counterpart of the one-DOF default term ``1``).

    Raises
    ------
    InputError
        Missing terms, an element beyond the record's DOFs, ``without`` naming other than ``1``, or ``px_roots``
        that is not a mapping of connections (one DOF's pair of roots).
    """
    if px_roots is not None and not isinstance(px_roots, Mapping):
        raise InputError(
            "px_roots= of a structure maps each connection to its roots, {(1, 2): (z_minus, z_plus)}; "
            "a pair of roots is one DOF's px(z)"
        )
    if terms is None:
        raise InputError(
            "terms are missing: give the elements, e.g. '(z1-z2)^3, z3^3' ('' for the linear system alone)"
        )
    removed = [] if without is None else [without] if isinstance(without, str) else list(without)
    removed = [t.strip() for item in removed for t in str(item).split(",") if t.strip()]
    if any(t != "1" for t in removed):
        raise InputError(
            f"without= can remove the constant force per DOF ('1') of a structure, not {removed[0]!r} "
            "(the linear system M, C, K is always identified)"
        )
    if isinstance(terms, ElementSet):
        elements = terms
        if elements.n_dofs != n_dofs:
            raise InputError(f"the elements are on {elements.n_dofs} DOFs but the record has {n_dofs}")
    elif isinstance(terms, (str, Iterable)):
        elements = ElementSet.from_spec(terms if isinstance(terms, str) else [t for t in terms], n_dofs)
    else:
        raise InputError(f"terms must be a string such as '(z1-z2)^3' or a list of terms, got {type(terms).__name__}")
    static = elements.static and not removed
    roots = {**dict(elements.px_roots), **{k: tuple(v) for k, v in dict(px_roots or {}).items()}}
    elements = ElementSet(elements.elements, n_dofs, static, roots)
    missing = [e for e in elements if e.term.uses_px and e.connection not in elements.px_roots]
    if missing:
        raise InputError(
            f"{missing[0].name} uses px: give its roots, px_roots={{{missing[0].connection}: (z_minus, z_plus)}}"
        )
    return elements


def check_dofs(identifier: Any, record: Record) -> None:
    """Refuse, in one line naming it, an identifier that does not declare ``dofs = "multi"``."""
    if getattr(identifier, "dofs", "single") != "multi":
        name = str(getattr(identifier, "name", type(identifier).__name__))
        raise InputError(
            f"method {name!r} identifies one degree of freedom, but the record has {record.n_dofs} "
            f"(z1..z{record.n_dofs}); choose a method for several (its Identifier declares dofs = 'multi')"
            + (" or identify record.dof(1)" if record.n_dofs == 1 else "")
        )


def identify_structure(
    record: Record,
    terms: Any,
    method: Any = None,
    *,
    mass: Any = None,
    options: Mapping[str, Any] | None = None,
    without: str | Iterable[str] = (),
    px_roots: Mapping[Connection, Any] | None = None,
    cutoff: float | None = None,
    registry: Registry | None = None,
) -> IdentifiedStructure:
    """Identify a structure's elements and underlying linear system (the multi-DOF branch of :func:`nlid.identify`).

    Parameters
    ----------
    record
        The structure record.
    terms
        The elements, ``"(z1-z2)^3, sign(v2-v1)"``, or an :class:`ElementSet`.
    method
        Identifier name or instance; it must declare ``dofs = "multi"``.
    mass
        The mass matrix (kg; a vector is a lumped mass, text as :func:`nlid.base.validate.parse_mass`); ``None``:
        the record's (``meta['mass']``, a file's sidecar), as ``discover`` takes it
        (:func:`~nlid.model.structure.structure_mass`); ``"estimate"``: the method estimates it.
    options, registry
        As for :func:`nlid.identify`.
    without
        ``"1"`` leaves out the constant force per DOF.
    px_roots
        ``{(i, j): (z-, z+)}`` for elements using ``px``.
    cutoff
        The balance filter's cut-off (Hz) for the residual per DOF.

    Raises
    ------
    InputError
        A single-DOF method, bad terms, mass or options.
    PluginError
        The identifier is broken or broke the contract.
    IdentificationError
        The answer cannot be trusted.
    """
    if method is None:
        raise InputError("method= is needed for a structure: name an identifier that handles several DOFs")
    identifier = make_identifier(method, options, registry)
    name = str(getattr(identifier, "name", type(identifier).__name__))
    check_dofs(identifier, record)
    elements = as_elements(terms, record.n_dofs, without=without, px_roots=px_roots)
    M = structure_mass(mass, record)
    check_cutoff(cutoff, record.fs)
    if M is None and getattr(identifier, "needs_mass", False):
        raise InputError(
            f"method {name!r} cannot estimate the mass matrix: give mass= (kg; a vector for a lumped mass) "
            "or the record's meta['mass']"
        )
    # an Identifier takes a structure in identify_structure; a class of its own may take it in identify
    estimate, seconds = timed_call(
        name, getattr(identifier, "identify_structure", identifier.identify), record, elements, mass=M
    )
    estimate = check_structure_estimate(estimate, elements, name, M)
    settings = dict(getattr(identifier, "settings", None) or {})
    result = IdentifiedStructure.from_estimate(
        estimate,
        elements=estimate.elements,
        record=record,
        method=name,
        mass=M,
        options=settings,
        seconds=seconds,
        cutoff=cutoff,
    )
    provenance = structure_provenance(record, elements, method=name, mass=M, options=settings)
    return dataclasses.replace(result, provenance=provenance)
