"""Numbers and tables as text: the one formatting helper of nlid's tables.

Every table nlid prints or writes (the study summary on the terminal, in
``summary.md`` and in ``report.html``) formats its numbers here, so that a
value reads the same everywhere:

* :func:`sig` writes a number with a given count of significant digits,
  keeping trailing zeros (``1.000e+06``, ``0.0500``) so that the count shows;
* :func:`spread_digits` / :func:`column_digits` choose that count from the
  spread over repetitions: enough digits to tell the minimum, the median and
  the maximum of a cell apart, the same count for every row of a column;
* :func:`spread_cell` writes ``median [min, max]``;
* :func:`text_table` lays a table out for a terminal of a given width,
  splitting it into column groups (each repeating the label column) when it
  is too wide, and wrapping nothing else.
"""

from __future__ import annotations

import math
import textwrap
from collections.abc import Iterable, Sequence

__all__ = [
    "MISSING",
    "TERMINAL_WIDTH",
    "sig",
    "spread_digits",
    "column_digits",
    "spread_cell",
    "text_table",
    "column_groups",
    "wrap",
]

#: What a missing value prints as.
MISSING = "–"
#: Width of the terminal output of nlid's tables (characters).
TERMINAL_WIDTH = 100
#: Bounds on the significant digits chosen from a spread.
MIN_DIGITS, MAX_DIGITS = 2, 7


def _finite(x: float | None) -> bool:
    return x is not None and isinstance(x, (int, float)) and math.isfinite(x)


def sig(x: float | None, digits: int = 3) -> str:
    """``x`` with ``digits`` significant digits, trailing zeros kept.

    Plain notation between 1e-3 and 1e5 (``0.00595``, ``4996``, ``-500.1``),
    scientific notation outside (``1.000e+06``); an en dash for a missing or
    non-finite value.

    Parameters
    ----------
    x
        The number.
    digits
        Significant digits (at least 1).

    Returns
    -------
    str
        The text.
    """
    if not _finite(x):
        return MISSING
    x = float(x)  # type: ignore[arg-type]
    digits = max(1, int(digits))
    if x == 0:
        return "0"
    rounded = float(f"{x:.{digits - 1}e}")  # the exponent after rounding (0.0996 -> 0.10 at 2 digits)
    exponent = math.floor(math.log10(abs(rounded)))
    if -3 <= exponent < 5:
        decimals = digits - 1 - exponent
        if decimals >= 0:
            return f"{rounded:.{decimals}f}"
        return f"{round(rounded, decimals):.0f}"
    return f"{rounded:.{digits - 1}e}"


def spread_digits(median: float, lo: float, hi: float, *, default: int = 3) -> int:
    """Significant digits that tell ``lo``, ``median`` and ``hi`` apart (one digit beyond the smallest gap).

    Parameters
    ----------
    median, lo, hi
        The statistics of one cell.
    default
        For a cell without spread (one value, or identical values).

    Returns
    -------
    int
        Between 2 and 7.
    """
    values = [v for v in (median, lo, hi) if _finite(v)]
    if not values:
        return default
    size = max(abs(v) for v in values)
    if size == 0:
        return default
    # the smallest gap between the median and either end: every number of the cell must read differently
    gaps = [abs(b - a) for a, b in ((lo, median), (median, hi)) if _finite(a) and _finite(b)]
    gaps = [g for g in gaps if g > 1e-12 * size] or ([abs(hi - lo)] if _finite(lo) and _finite(hi) else [])
    spread = min(gaps) if gaps else 0.0
    if spread <= 1e-12 * size:
        return default
    digits = math.ceil(math.log10(size / spread)) + 1
    return int(min(MAX_DIGITS, max(MIN_DIGITS, digits)))


def column_digits(cells: Iterable[tuple[float, float, float]], *, default: int = 3) -> int:
    """One count of significant digits for a column: the largest any of its cells needs.

    Parameters
    ----------
    cells
        ``(median, min, max)`` of each row.
    default
        For a column whose cells have no spread.
    """
    counts = [spread_digits(m, lo, hi, default=default) for m, lo, hi in cells]
    return max(counts) if counts else default


def spread_cell(median: float | None, lo: float | None = None, hi: float | None = None, digits: int = 3) -> str:
    """``median [min, max]``, or just the median when there is no range."""
    if not _finite(median):
        return MISSING
    if not (_finite(lo) and _finite(hi)) or lo == hi == median:
        return sig(median, digits)
    return f"{sig(median, digits)} [{sig(lo, digits)}, {sig(hi, digits)}]"


def wrap(text: str, width: int = TERMINAL_WIDTH, indent: str = "", subsequent: str | None = None) -> str:
    """``text`` wrapped at ``width`` (words are never broken)."""
    return textwrap.fill(
        text,
        width=width,
        initial_indent=indent,
        subsequent_indent=indent + "  " if subsequent is None else subsequent,
        break_long_words=False,
        break_on_hyphens=False,
    )


def _layout(header: Sequence[str], rows: Sequence[Sequence[str]], columns: Sequence[int]) -> list[str]:
    widths = [max(len(header[j]), *(len(r[j]) for r in rows)) if rows else len(header[j]) for j in columns]
    lines = []
    for k, cells in enumerate([header, *rows]):
        parts = []
        for i, (j, w) in enumerate(zip(columns, widths, strict=True)):
            parts.append(cells[j].ljust(w) if i == 0 else cells[j].rjust(w))
        lines.append("  ".join(parts).rstrip())
        if k == 0:
            lines.append("  ".join("-" * w for w in widths))
    return lines


def text_table(
    header: Sequence[str],
    rows: Sequence[Sequence[str]],
    *,
    width: int = TERMINAL_WIDTH,
    keep: int = 1,
) -> str:
    """A table as aligned text no wider than ``width``, split into column groups if need be.

    Parameters
    ----------
    header
        Column titles.
    rows
        Cells (text), one list per row, as long as ``header``.
    width
        Largest line length. A single column wider than that is still shown
        whole (its line is longer).
    keep
        Leading columns repeated in every group (the row labels).

    Returns
    -------
    str
        One or more blocks separated by a blank line.
    """
    keep = min(keep, len(header))
    widths = [max(len(header[j]), *(len(r[j]) for r in rows)) if rows else len(header[j]) for j in range(len(header))]
    fixed = list(range(keep))
    blocks = ["\n".join(_layout(header, rows, fixed + g)) for g in column_groups(widths, keep, width)]
    return "\n\n".join(blocks)


def column_groups(widths: Sequence[int], keep: int, width: int | None) -> list[list[int]]:
    """The columns after the first ``keep`` in groups that fit ``width`` characters beside those ``keep``.

    Columns are two spaces apart; a column wider than ``width`` is a group of its own, and ``width=None``
    gives one group. There is always at least one group (perhaps empty).
    """
    base = sum(widths[:keep]) + 2 * max(0, keep - 1)
    groups: list[list[int]] = []
    current: list[int] = []
    used = base
    for j in range(keep, len(widths)):
        w = widths[j] + 2
        if width is not None and current and used + w > width:
            groups.append(current)
            current, used = [], base
        current.append(j)
        used += w
    if current or not groups:
        groups.append(current)
    return groups
