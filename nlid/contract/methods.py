"""What the core knows of the installed identifiers, read from their own attributes: it names none.

The attributes (:class:`nlid.contract.identifier.Identifier`; all optional, so that a
class that does not subclass it works too) and who reads them:

* ``preference``: :func:`choose_method`, the default method of ``nlid
  discover`` and the start of a refining method;
* ``refines``: :func:`choose_refiner`, the method ``nlid discover --refine``
  refines the final model with (its ``init`` option names the start);
* ``advice`` and ``advice_order``: the "Which method?" list of ``nlid methods``
  (:func:`advice_of`, :func:`ranked`);
* ``docs``: :data:`doc_pages`, the pages the study verdict links to.

An identifier that says nothing comes after those that do (alphabetically),
shows its ``summary`` as advice and has no page.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from typing import Any

from ..errors import InputError
from .registry import Registry, default_registry, registry_for

__all__ = ["choose_method", "choose_refiner", "comparison_methods", "ranked", "advice_of", "doc_pages", "DocPages"]


def _rank(cls: Any, attribute: str) -> int | None:
    value = getattr(cls, attribute, None)
    return value if isinstance(value, int) and not isinstance(value, bool) else None


def ranked(identifiers: Mapping[str, Any], attribute: str = "preference") -> list[str]:
    """Identifier names ordered by an integer class attribute (lower first), then the others alphabetically.

    Parameters
    ----------
    identifiers
        ``{name: identifier class}`` (e.g. :attr:`nlid.contract.registry.Registry.identifiers`).
    attribute
        ``"preference"`` or ``"advice_order"``; a missing or ``None`` value ranks after every given one.
    """
    placed = [n for n in identifiers if _rank(identifiers[n], attribute) is not None]
    placed.sort(key=lambda n: (_rank(identifiers[n], attribute), n))
    return placed + sorted(n for n in identifiers if _rank(identifiers[n], attribute) is None)


def advice_of(cls: Any) -> str:
    """When to choose an identifier, in one line: its ``advice``, else its ``summary``."""
    return getattr(cls, "advice", "") or getattr(cls, "summary", "")


def choose_method(mass: float | None, registry: Registry | None = None) -> tuple[str, list[str]]:
    """The default identifier and the messages explaining the choice.

    Goes through the installed identifiers in ``preference`` order (:func:`ranked`), then any other
    alphabetically; one that cannot estimate the mass (``needs_mass``) is skipped (with a message) when
    ``mass`` is ``None``.

    Raises
    ------
    InputError
        If no installed identifier can be used.
    """
    reg = registry or default_registry()
    order = ranked(reg.identifiers, "preference")
    preferred = [n for n in order if _rank(reg.identifiers[n], "preference") is not None]
    notes: list[str] = []
    for name in order:
        if mass is None and getattr(reg.identifiers[name], "needs_mass", False):
            notes.append(f"skipped {name!r}: it cannot estimate the mass (give mass=)")
            continue
        notes.append(
            f"method {name!r} chosen (preference order {', '.join(preferred)}; installed: {', '.join(reg.names())})"
        )
        return name, notes
    raise InputError(
        "no installed identifier can run without the mass: give mass= (in kg) "
        f"(installed: {', '.join(reg.names()) or 'none'})"
    )


def choose_refiner(registry: Registry | None = None) -> str:
    """The installed identifier that refines another method's fit (``refines = True``), the preferred one first.

    Raises
    ------
    InputError
        If none is installed.
    """
    reg = registry or default_registry()
    found = [n for n in ranked(reg.identifiers, "preference") if getattr(reg.identifiers[n], "refines", False) is True]
    if not found:
        raise InputError(
            "no installed identifier refines another method's fit (one with refines = True, e.g. an output-error "
            f"method); installed: {', '.join(reg.names()) or 'none'}"
        )
    return found[0]


def comparison_methods(registry: Registry | None = None) -> list[str]:
    """The methods :func:`nlid.compare` runs when none are named: every installed identifier but the refiners.

    A refining identifier (``refines = True``, such as the output-error ``oe``) starts from another method's fit
    and costs 10-100 times more (176 s of 239 s on EMPS); like the built-in studies, ``compare`` runs it only
    when it is named.
    """
    reg = registry or default_registry()
    return [n for n in reg.names() if getattr(reg.identifiers[n], "refines", False) is not True]


class DocPages(Mapping[str, str]):
    """``{identifier name: documentation page}`` from the identifiers' ``docs`` attributes, looked up lazily.

    Looking one name up loads only that identifier's plugin (:func:`nlid.contract.registry.registry_for`);
    iterating loads them all. Identifiers without a page are absent.
    """

    def __init__(self, registry: Registry | None = None) -> None:
        self._registry = registry

    def _page(self, name: str) -> str:
        reg = self._registry or registry_for(name)
        docs = getattr(reg.identifiers.get(name), "docs", "")
        return docs if isinstance(docs, str) else ""

    def __getitem__(self, name: str) -> str:
        page = self._page(name) if isinstance(name, str) else ""
        if not page:
            raise KeyError(name)
        return page

    def __iter__(self) -> Iterator[str]:
        reg = self._registry or default_registry()
        return iter([n for n in reg.names() if getattr(reg.identifiers[n], "docs", "")])

    def __len__(self) -> int:
        return sum(1 for _ in self)

    def __repr__(self) -> str:
        return "DocPages(<the installed identifiers' docs attributes>)"


#: Each installed identifier's documentation page (its ``docs`` attribute), looked up when asked.
doc_pages: Mapping[str, str] = DocPages()
