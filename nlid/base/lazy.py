"""A package face that loads its names on first use (PEP 562), written once for every lazy package.

A face whose names live in heavy modules (numba's kernels, pandas) lists them in a table
``{name: defining module}``; :func:`lazy_face` gives the module's ``__getattr__`` and ``__dir__``.
A loaded name is stored in the package's namespace, so later lookups never reach ``__getattr__``.
(``nlid/__init__.py`` keeps its own copy: the package root imports nothing but the errors.)
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Mapping, Sequence
from typing import Any

__all__ = ["lazy_face"]


def lazy_face(
    package: str, table: Mapping[str, str], names: Sequence[str]
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """``(__getattr__, __dir__)`` for ``package``, loading each name of ``table`` from its module on first use.

    Parameters
    ----------
    package
        The package's ``__name__``.
    table
        ``{name: module that defines it}``.
    names
        The package's ``__all__`` (listed by ``dir()`` before they are loaded).
    """

    def __getattr__(name: str) -> Any:
        module = table.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module), name)
        setattr(sys.modules[package], name, value)  # later lookups skip this function
        return value

    def __dir__() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(names))

    return __getattr__, __dir__
