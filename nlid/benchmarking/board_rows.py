"""The rows of one leaderboard table as its renderers read them: grouping, names, badges, ranks, notes, numbers.

Shared by the Markdown (:mod:`nlid.benchmarking.leaderboard`), the HTML page
(:mod:`nlid.benchmarking.board_html`) and the figures (:mod:`nlid.benchmarking.board_figures`), so
the three say the same thing of a row.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from ..base.formatting import sig
from .prior import LEGEND, prior_from_row

__all__ = [
    "KINDS",
    "UNSCORED",
    "value",
    "groups",
    "figure_name",
    "scored",
    "unscored",
    "who",
    "badges",
    "rule_text",
    "legend",
    "ranks",
    "remark",
    "sources",
    "source_of",
    "num",
    "integer",
    "seconds",
]

#: Row kinds, in the order a tie is broken: nlid's pipelines, the true model, peers, published, references.
KINDS = ("nlid", "truth", "peer", "published", "reference")
#: Statuses of rows that carry no figure (they are listed under the table, not in it).
UNSCORED = ("not run", "skipped")


def value(x: Any) -> float:
    """``x`` as a float, NaN when missing or not a number."""
    try:
        return float(x) if x is not None else math.nan
    except (TypeError, ValueError):
        return math.nan


def groups(rows: Sequence[Mapping[str, Any]]) -> list[tuple[str, str, list[Mapping[str, Any]]]]:
    """``(benchmark, test, rows)`` per table, in the rows' order."""
    out: list[tuple[str, str, list[Mapping[str, Any]]]] = []
    for r in rows:
        if not out or (out[-1][0], out[-1][1]) != (r["benchmark"], r["test"]):
            out.append((r["benchmark"], r["test"], []))
        out[-1][2].append(r)
    return out


def figure_name(benchmark: str, test: str) -> str:
    """The stem of a test set's figure (``figures/<stem>.png``)."""
    return f"{benchmark}--{test}"


def scored(rows: Sequence[Mapping[str, Any]]) -> list[Mapping[str, Any]]:
    """The rows a table shows (those with a figure, or failed), in rank order."""
    return [r for r in rows if r.get("status") not in UNSCORED]


def unscored(rows: Sequence[Mapping[str, Any]]) -> list[Mapping[str, Any]]:
    """The rows not in the table (the test set could not be read, an optional peer is not installed)."""
    return [r for r in rows if r.get("status") in UNSCORED]


def who(r: Mapping[str, Any]) -> str:
    """The row's name, saying whose it is: ``nlid rfs``, ``peer pysindy``, ``published PNLSS``, ``true model``."""
    kind = r["kind"]
    if kind == "nlid":
        return f"nlid {r['pipeline']}"
    if kind == "peer":
        return f"peer {r['pipeline']}"
    if kind == "truth":
        return "true model"
    if kind == "reference":
        return str(r["pipeline"])
    return f"published {r['pipeline']}"


def badges(r: Mapping[str, Any]) -> list[str]:
    """The row's prior-knowledge badges (none for a reference line such as the noise floor or a failed job)."""
    if r["kind"] == "reference" or not r.get("prior_structure"):
        return []
    return prior_from_row(r).badges()


def rule_text(rows: Sequence[Mapping[str, Any]]) -> str:
    """The rule of a table, said once: the declared spelling and what it means, from the rows scored under it."""
    texts: list[str] = []
    for kinds in (("nlid", "truth"), ("peer",)):  # in the scorer's words; a peer's own words only without them
        texts = sorted({str(r["rule"]) for r in rows if r["kind"] in kinds and r.get("same_rule") and r.get("rule")})
        if texts:
            break
    declared = rows[0]["rule_declared"]
    return f"`{declared}`" + (f": {'; '.join(texts)}" if texts else "")


def range_note(rows: Sequence[Mapping[str, Any]]) -> str:
    """How far a table's test set leaves the estimation range, capitalised (:func:`nlid.scoring.range_excess`).

    Empty when the test stays within the range, or for rows written before the column existed.
    """
    text = next((str(r["extrapolation"]) for r in rows if r.get("extrapolation")), "")
    return text[:1].upper() + text[1:]


def legend(rows: Sequence[Mapping[str, Any]]) -> list[tuple[str, str]]:
    """``(badge, meaning)`` of the badges the rows use, in :data:`~nlid.benchmarking.prior.LEGEND` order."""
    used = {b for r in rows for b in badges(r)}
    return [(b, text) for b, text in LEGEND.items() if b in used]


def ranks(rows: Sequence[Mapping[str, Any]]) -> list[str]:
    """Rank of each row by RMSE (``"-"`` for a reference line, a row without a figure or scored under another rule)."""
    out, k = [], 0
    for r in rows:
        if r["kind"] == "reference" or math.isnan(value(r["rmse"])) or not r.get("same_rule", True):
            out.append("-")
        else:
            k += 1
            out.append(str(k))
    return out


def remark(r: Mapping[str, Any]) -> str:
    """What the table's notes column says of a row: another rule, a failure, a note."""
    notes = []
    if r.get("status") not in (*UNSCORED, "failed") and not r.get("same_rule", True):
        notes.append(f"other rule: {r['rule']}")
    if r["kind"] == "published":
        if "dB" in str(r.get("model", "")):  # the figure as published, when it was not an RMSE
            notes.append(str(r["model"]))
    elif r.get("status") not in ("ok", None):
        notes.append(str(r["status"]))
    if r.get("note"):
        notes.append(str(r["note"]))
    return "; ".join(notes)


def sources(rows: Sequence[Mapping[str, Any]]) -> list[tuple[str, str, str]]:
    """The distinct sources of a table's published rows: ``(paper, where it was checked, status)``."""
    out: list[tuple[str, str, str]] = []
    for r in rows:
        if r["kind"] == "published":
            key = source_of(r)
            if key not in out:
                out.append(key)
    return out


def source_of(r: Mapping[str, Any]) -> tuple[str, str, str]:
    """A published row's ``(paper, where it was checked, status)``."""
    return str(r["method"]), str(r["source"]), str(r.get("status", "")).replace("published ", "").strip("()")


def num(x: Any, digits: int = 3) -> str:
    """``x`` to ``digits`` significant digits, ``-`` when missing."""
    x = value(x)
    return "-" if math.isnan(x) else sig(x, digits)


def integer(x: Any) -> str:
    """``x`` rounded, ``-`` when missing."""
    x = value(x)
    return "-" if math.isnan(x) else str(int(round(x)))


def seconds(x: Any) -> str:
    """Seconds to 0.1 s, ``-`` when missing."""
    x = value(x)
    return "-" if math.isnan(x) else f"{x:.1f}"
