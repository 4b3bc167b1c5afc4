"""What :func:`nlid.identify` reads of its arguments on a structure record (several DOFs).

:func:`as_elements` parses the elements to identify (terms on connections, or an
:class:`~nlid.model.elements.ElementSet`), and :func:`check_dofs` refuses an identifier that handles a
single DOF (its ``dofs`` class attribute, :class:`nlid.plugin.Identifier`).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

from ..data.record import Record
from ..errors import InputError
from ..model.elements import ElementSet
from ..model.spelling import Connection

__all__ = ["as_elements", "check_dofs"]


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
