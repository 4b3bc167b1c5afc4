"""A study summary as text: Markdown (``summary.md``), for a terminal (``summary.txt``), long (``summary.csv``).

The verdict of every section comes first, then its tables (:mod:`.tables`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from ...base.formatting import TERMINAL_WIDTH, text_table, wrap
from .. import columns as col
from .section import Section

__all__ = ["summary_long", "summary_markdown", "summary_text"]


def _md_escape(text: str) -> str:
    return text.replace("|", "\\|")


def _md_table(header: list[str], rows: list[list[str]], best: set[tuple[int, int]] = frozenset()) -> list[str]:
    lines = ["| " + " | ".join(_md_escape(h) for h in header) + " |"]
    lines.append("|" + "|".join(" --- " for _ in header) + "|")
    for i, row in enumerate(rows):
        cells = [f"**{_md_escape(c)}**" if (i, j) in best else _md_escape(c) for j, c in enumerate(row)]
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def _title(section: Section) -> str:
    return f"{section.dataset} / {section.model}"


def summary_markdown(config: Any, sections: list[Section]) -> str:
    """The summary as Markdown: the verdict of every section first, then the sections' tables."""
    lines = [f"# Study {config.name}", ""]
    if config.description:
        lines += [config.description, ""]
    judged = [s for s in sections if s.verdict is not None]
    if judged:
        lines += ["## Verdict", ""]
        for section in judged:
            v = section.verdict
            if len(sections) > 1:
                lines += [f"### {_title(section)}", ""]
            lines += [_md_escape(v.headline()), "", _md_escape(v.separation()), ""]
            header, rows = v.table_rows()
            lines += _md_table(header, rows) + [""]
            lines += ["Why:", ""]
            lines += [f"- **{m}**: {_md_escape('; '.join(why))}" for m, why in v.reasons.items()] + [""]
    lines += [
        "Tables: median [min, max] over repetitions, significant digits chosen from the spread; "
        "**bold**: the best (lowest) median of an error or cost column (every one of a tie).",
        "",
    ]
    for section in sections:
        lines += [f"## {_title(section)}", ""]
        lines += [_md_escape(section.description) + (f"; terms: {', '.join(section.terms)}" if section.terms else "")]
        lines.append("")
        if section.frame.empty:
            lines += ["No finished runs yet.", ""]
            continue
        for table in section.tables:
            lines += [f"### {table.title}", ""]
            lines += _md_table(table.header, table.rows, table.best)
            lines.append("")
            for note in table.notes:
                lines += [f"- {_md_escape(note)}"]
            if table.notes:
                lines.append("")
        if section.failures:
            lines += ["Failed runs:", ""] + [f"- {_md_escape(f)}" for f in section.failures] + [""]
    return "\n".join(lines)


def summary_text(config: Any, sections: list[Section], width: int = TERMINAL_WIDTH) -> str:
    """The summary for a terminal: the verdict first, then every table, no line wider than ``width``.

    Wide tables are split into column groups that repeat the method column; the best cell of an
    error or cost column is marked with ``*``.
    """
    rule = "=" * min(width, 72)
    lines = [f"Study {config.name}"]
    if config.description:
        lines.append(wrap(config.description, width, subsequent=""))
    for section in sections:
        lines += ["", rule, f"{_title(section)}", rule]
        lines.append(
            wrap(
                section.description + (f"; terms: {', '.join(section.terms)}" if section.terms else ""),
                width,
                subsequent="",
            )
        )
        if section.frame.empty:
            lines.append("No finished runs yet.")
            continue
        if section.verdict is not None:
            lines += ["", "VERDICT", section.verdict.text(width)]
        lines += [
            "",
            "Tables: median [min, max] over repetitions; * = best (lowest) median of an error or cost column,",
            "every cell of a tie marked.",
        ]
        for table in section.tables:
            rows = [
                [f"{c}*" if (i, j) in table.best else c for j, c in enumerate(row)] for i, row in enumerate(table.rows)
            ]
            lines += ["", wrap(table.title, width, subsequent="  "), text_table(table.header, rows, width=width)]
            lines += [wrap(f"- {n}", width, subsequent="  ") for n in table.notes]
        if section.failures:
            lines += ["", "Failed runs:"] + [wrap(f"- {f}", width, subsequent="  ") for f in section.failures]
    return "\n".join(lines)


#: Columns of a row that are no metric (who, which record, what went wrong).
_NOT_METRICS = (
    col.RUN_ID,
    col.DATASET,
    col.MODEL,
    col.METHOD,
    col.STATUS,
    col.ERROR,
    col.WARNINGS,
    col.REPETITION,
    col.SEED,
    col.SAMPLES,
    col.Z_MIN,
    col.Z_MAX,
)
_LONG = [col.DATASET.key(), col.MODEL.key(), col.METHOD.key(), "metric", "n", "median", "min", "max"]


def summary_long(frame: pd.DataFrame) -> pd.DataFrame:
    """Long-format summary: dataset, model, method, metric, n, median, min, max (signed values)."""
    if frame.empty:
        return pd.DataFrame(columns=_LONG)
    ok = frame[frame[col.STATUS.key()] == "ok"]
    skip = {f.key() for f in _NOT_METRICS}
    metrics = [c for c in ok.columns if c not in skip]
    out = []
    by = [col.DATASET.key(), col.MODEL.key(), col.METHOD.key()]
    for (ds, model, method), sub in ok.groupby(by, sort=False):
        for c in metrics:
            x = pd.to_numeric(sub[c], errors="coerce").to_numpy(dtype=float)
            x = x[np.isfinite(x)]
            if x.size:
                out.append([ds, model, method, c, x.size, np.median(x), x.min(), x.max()])
    return pd.DataFrame(out, columns=_LONG)
