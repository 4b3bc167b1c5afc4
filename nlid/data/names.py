"""The names of the measured benchmarks ``dataset:NAME[:PART]`` reads, and their parts (no numpy: the CLI's help).

:mod:`nlid.data.datasets` loads them; this module only spells them, so that ``nlid --help`` lists every
name without importing the loaders (``tests/cli/test_edges_help.py`` checks that the two agree).
"""

from __future__ import annotations

from types import MappingProxyType

__all__ = ["PARTS", "ALIASES", "canonical_name", "spellings", "describe"]

#: Each loadable benchmark and the parts ``dataset:NAME:PART`` selects (the whole record is ``dataset:NAME``).
PARTS = MappingProxyType(
    {
        "emps": (),
        "silverbox": ("estimation", "arrow-full", "arrow-no-extrapolation", "multisine-test"),
        "bouc-wen": ("sinesweep",),
    }
)
#: Other spellings accepted for a name (the Bouc-Wen files live in the folder ``boucwen/``).
ALIASES = MappingProxyType({"boucwen": "bouc-wen"})


def canonical_name(name: str) -> str:
    """The benchmark's one spelling: ``"boucwen"`` -> ``"bouc-wen"``; other names unchanged."""
    return ALIASES.get(name, name)


def spellings() -> tuple[str, ...]:
    """Every ``dataset:NAME`` and ``dataset:NAME:PART`` spelling, in :data:`PARTS` order."""
    out: list[str] = []
    for name, parts in PARTS.items():
        out += [f"dataset:{name}", *(f"dataset:{name}:{part}" for part in parts)]
    return tuple(out)


def describe() -> str:
    """Every spelling as one phrase for help texts: ``dataset:emps, dataset:silverbox, ...``."""
    return ", ".join(spellings())
