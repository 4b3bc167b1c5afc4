"""The pieces of a study summary: a :class:`Section` (one dataset x model), its :class:`Table`\\ s and their cells.

Every cell is ``median [min, max]`` over the repetitions that succeeded
(just the value when there is one). The tables (:mod:`.tables`), the
verdict (:mod:`.verdict`) and the figures (:mod:`.figures`) all read a
section through these pieces and the declared columns
(:mod:`nlid.study.columns`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from ...base.formatting import MISSING, column_digits, sig, spread_cell
from ...errors import NlidError
from ...model.terms import parse_term
from .. import columns as col

__all__ = [
    "Column",
    "Section",
    "Stats",
    "Table",
    "cell",
    "exact",
    "fmt",
    "has_values",
    "method_rows",
    "runs_cell",
    "stats",
]

_METHOD = col.METHOD.key()
_STATUS = col.STATUS.key()


def fmt(x: float | None, digits: int = 3) -> str:
    """``digits`` significant digits (:func:`nlid.base.formatting.sig`); an en dash for a missing value."""
    return sig(x, digits)


def exact(x: float | None, max_digits: int = 6) -> str:
    """The shortest text of ``x`` with at most ``max_digits`` significant digits (for reference values)."""
    if x is None or not math.isfinite(x):
        return MISSING
    for digits in range(1, max_digits + 1):
        text = sig(x, digits)
        if math.isclose(float(text), x, rel_tol=0.5 * 10 ** -(max_digits - 1)):
            return text
    return sig(x, max_digits)


@dataclass(frozen=True)
class Stats:
    """Median, minimum and maximum of a cell over the repetitions (``n`` values)."""

    median: float
    lo: float
    hi: float
    n: int

    @property
    def triple(self) -> tuple[float, float, float]:
        """``(median, min, max)``."""
        return self.median, self.lo, self.hi


def stats(values: pd.Series | np.ndarray | list, absolute: bool = False) -> Stats | None:
    """The :class:`Stats` of the finite values (``None`` when there is none)."""
    x = pd.to_numeric(pd.Series(values), errors="coerce").to_numpy(dtype=float)
    x = x[np.isfinite(x)]
    if absolute:
        x = np.abs(x)
    if x.size == 0:
        return None
    return Stats(float(np.median(x)), float(x.min()), float(x.max()), int(x.size))


def is_flags(values: pd.Series) -> bool:
    """True for a column of true/false values."""
    present = values.dropna()
    return bool(len(present)) and all(isinstance(v, (bool, np.bool_)) for v in present)


def flags_cell(values: pd.Series) -> str:
    """The fraction of true values, and how many of how many."""
    present = values.dropna().astype(bool)
    return f"{sig(float(np.mean(present)), 2)} ({int(present.sum())} of {len(present)})"


def cell(values: pd.Series, absolute: bool = False, digits: int | None = None) -> str:
    """``median [min, max]`` of the finite values (true/false values: the fraction true).

    ``digits`` defaults to what the spread needs (:func:`nlid.base.formatting.spread_digits`).
    """
    if is_flags(values):
        return flags_cell(values)
    st = stats(values, absolute)
    if st is None:
        return MISSING
    if digits is None:
        digits = column_digits([st.triple])
    return spread_cell(*st.triple, digits=digits) if st.n > 1 else sig(st.median, digits)


@dataclass(frozen=True)
class Column:
    """A metric column of a method table: results column, header, absolute value?, lower is better?"""

    key: str
    header: str
    absolute: bool = False
    lower_better: bool = False
    digits: int | None = None  # fixed significant digits (default: from the spread)

    @classmethod
    def of(cls, family: col.ColumnFamily, label: str | None = None, unit: str | None = None) -> Column:
        """The table column of a declared family (errors shown as their magnitude)."""
        return cls(
            family.key(label), family.header(label, unit), bool(family.error), family.lower_better, family.digits
        )


@dataclass
class Table:
    """A titled table: header, rows of cells, notes below; ``best`` cells are highlighted."""

    title: str
    header: list[str]
    rows: list[list[str]]
    notes: list[str] = field(default_factory=list)
    best: set[tuple[int, int]] = field(default_factory=set)
    caption: str = ""


@dataclass
class Section:
    """One dataset x model of a study."""

    dataset: str
    model: str
    description: str
    terms: list[str]
    methods: list[str]
    frame: pd.DataFrame
    reference: dict[str, Any] | None
    tables: list[Table] = field(default_factory=list)
    failures: list[str] = field(default_factory=list)
    units: dict[str, str] = field(default_factory=dict)
    diagnostics: dict[str, list[dict[str, Any]]] = field(default_factory=dict)
    verdict: Any = None

    def terms_with(self, family: col.ColumnFamily) -> list[str]:
        """The section's terms, in model order, that have a column of the per-term ``family``."""
        return [t for t in self.terms if family.key(t) in self.frame.columns]

    @property
    def present_methods(self) -> list[str]:
        """The methods with at least one run in this section, in study order."""
        if self.frame.empty:
            return []
        return [m for m in self.methods if (self.frame[_METHOD] == m).any()]

    def runs(self, method: str) -> pd.DataFrame:
        """Every run of ``method``."""
        return self.frame[self.frame[_METHOD] == method]

    def ok(self, method: str) -> pd.DataFrame:
        """The successful runs of ``method``."""
        f = self.frame
        return f[(f[_METHOD] == method) & (f[_STATUS] == "ok")]

    def unit(self, term: str) -> str:
        """SI unit of a term's coefficient (from the results; computed from the term otherwise)."""
        if term in self.units:
            return self.units[term]
        try:
            return parse_term(term).coefficient_unit
        except NlidError:
            return ""


def runs_cell(sub: pd.DataFrame) -> str:
    """``ok/n`` runs, with how many failed and timed out."""
    n = len(sub)
    ok = int((sub[_STATUS] == "ok").sum())
    text = f"{ok}/{n}"
    timeouts = int((sub[_STATUS] == "timeout").sum())
    failed = n - ok - timeouts
    extra = [f"{failed} failed"] * bool(failed) + [f"{timeouts} timed out"] * bool(timeouts)
    return text + (f" ({', '.join(extra)})" if extra else "")


def method_rows(section: Section, columns: list[Column], digits: int | None = None) -> tuple[list[list[str]], set]:
    """One row per method with runs: ``[method, runs, cells...]``, and the best cells ``{(row, column)}``.

    Every column has one count of significant digits, chosen from the spread of its cells
    (:func:`nlid.base.formatting.column_digits`) unless ``digits`` is given; in a lower-is-better
    column the cells with the lowest median are the best, and so is every cell whose median shows the same
    digits (a tie marks all the tied cells, never one of them).
    """
    methods = section.present_methods
    table: dict[str, list[Stats | str | None]] = {}
    for method in methods:
        ok = section.ok(method)
        cells: list[Stats | str | None] = []
        for c in columns:
            if c.key not in ok.columns:
                cells.append(None)
            elif is_flags(ok[c.key]):
                cells.append(flags_cell(ok[c.key]))
            else:
                cells.append(stats(ok[c.key], c.absolute))
        table[method] = cells
    rows = [[m, runs_cell(section.runs(m))] for m in methods]
    best: set[tuple[int, int]] = set()
    for j, c in enumerate(columns):
        numeric = {m: table[m][j] for m in methods if isinstance(table[m][j], Stats)}
        d = c.digits or digits or column_digits([st.triple for st in numeric.values()])
        for i, m in enumerate(methods):
            value = table[m][j]
            if isinstance(value, Stats):
                text = spread_cell(*value.triple, digits=d) if value.n > 1 else sig(value.median, d)
            else:
                text = value if isinstance(value, str) else MISSING
            rows[i].append(text)
        if c.lower_better and len(numeric) > 1:
            # a tie marks every tied cell: medians equal at the digits the column shows (identical methods
            # differ in the last bits of their derived numbers) are all the best
            lowest = min(st.median for st in numeric.values())
            shown = sig(lowest, d)
            for i, m in enumerate(methods):
                st = numeric.get(m)
                if st is not None and (st.median == lowest or sig(st.median, d) == shown):
                    best.add((i, j + 2))
    return rows, best


def has_values(row: list[str]) -> bool:
    """False for a table row whose value cells are all empty."""
    return any(c not in ("", "–") for c in row[2:])
