"""Numerical trouble made visible: numpy's warnings collected, non-finite figures named.

numpy reports floating-point trouble (overflow, invalid values, division by
zero) as :class:`RuntimeWarning` lines on the terminal and carries on with
``inf`` and ``nan``. nlid never lets those lines through: the code that
builds a result collects them with :func:`collect_warnings` and either turns
them into the one-line :class:`~nlid.errors.IdentificationError` that says
which reported figure is not finite (:func:`nonfinite`), or, when every
figure is finite after all, into one warning of the result
(:func:`describe_warnings`).
"""

from __future__ import annotations

import math
import os
import warnings
from collections import Counter
from collections.abc import Iterable, Iterator, Mapping
from contextlib import contextmanager

__all__ = [
    "collect_warnings",
    "describe_warnings",
    "nonfinite",
    "is_finite",
    "overflow_hint",
]


@contextmanager
def collect_warnings() -> Iterator[list[str]]:
    """Collect the :class:`RuntimeWarning` s raised inside the block as short descriptions.

    Other warnings are emitted again, unchanged, when the block ends.

    Yields
    ------
    list of str
        Filled when the block ends with ``"message (file.py:line)"`` for each
        runtime warning, in order.
    """
    found: list[str] = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", RuntimeWarning)
        try:
            yield found
        finally:
            others = []
            for w in caught:
                if issubclass(w.category, RuntimeWarning):
                    found.append(f"{w.message} ({os.path.basename(str(w.filename))}:{w.lineno})")
                else:
                    others.append(w)
    for w in others:
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno, source=w.source)


def describe_warnings(found: Iterable[str], limit: int = 3) -> str:
    """One line for collected warnings: the first ``limit`` distinct ones with their counts."""
    counts = Counter(found)
    parts = [f"{text}{f' x{n}' if n > 1 else ''}" for text, n in list(counts.items())[:limit]]
    more = len(counts) - limit
    return "; ".join(parts) + (f"; and {more} more" if more > 0 else "")


def overflow_hint(found: Iterable[str]) -> str:
    """A hint when the collected warnings include overflows (the data are probably badly scaled)."""
    if any("overflow" in text for text in found):
        return ": the numbers overflowed, so the data are probably badly scaled (rescale them, e.g. kN instead of N)"
    return ""


def is_finite(value: object) -> bool:
    """True for a finite real number."""
    try:
        return math.isfinite(float(value))  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return False


def nonfinite(what: str, values: Mapping[str, object]) -> str | None:
    """``"standard errors of z, v are nan"`` for the non-finite entries of ``values``, else ``None``.

    Parameters
    ----------
    what
        Plural noun of the figures (``"standard errors"``); empty: the names alone.
    values
        ``{name: value}``.
    """
    bad = {k: v for k, v in values.items() if not is_finite(v)}
    if not bad:
        return None
    shown = sorted({str(float(v)) if isinstance(v, (int, float)) else repr(v) for v in bad.values()})
    keys = list(bad)
    names = keys[0] if len(keys) == 1 else f"{', '.join(keys[:-1])} and {keys[-1]}"
    return f"{f'{what} of ' if what else ''}{names} {'is' if len(bad) == 1 else 'are'} {' or '.join(shown)}"
