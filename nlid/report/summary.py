"""One summary type for every result: a title, key-value lines, tables and text, rendered for each medium.

:class:`Summary` is what :meth:`nlid.IdentifiedModel.summary`,
:meth:`nlid.discovery.DiscoveryResult.summary` and
:meth:`nlid.bayes.Posterior.summary` return (in the spirit of statsmodels'
``summary2.Summary``). It holds blocks in order:

* :class:`Fields`: ``key: value`` lines (one per line, or several on one line);
* :class:`Table`: rows of text cells under column headers (:class:`Column`:
  title, alignment, least width);
* :class:`Text`: paragraphs, wrapped to a width on the terminal.

and renders them as aligned text (:meth:`Summary.as_text`, also ``str()``
and ``print()``), Markdown (:meth:`Summary.as_markdown`) and HTML
(:meth:`Summary.as_html`, also the notebook's ``_repr_html_``)::

    summary = fit.summary()
    print(summary)                  # the table ``nlid identify`` prints
    summary.tables[0].to_frame()    # the coefficient table as a DataFrame

The producer formats the numbers (cells are text), so a value reads the same
in every medium. A block with ``gap=True`` is preceded by a blank line in the
text rendering (also when the block itself is empty, so that a producer states
its layout once); Markdown and HTML separate every block.
"""

from __future__ import annotations

import html
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

from ..base.formatting import column_groups, wrap
from .html import html_table

__all__ = ["Summary", "Column", "Table", "Fields", "Text"]

Align = Literal["left", "right"]


@dataclass(frozen=True)
class Column:
    """A column of a :class:`Table`.

    Attributes
    ----------
    title
        The header cell.
    align
        ``"left"`` or ``"right"`` (numbers).
    width
        Least width of the column in the text rendering (characters); the
        column is as wide as its widest cell or header when that is more.
    """

    title: str
    align: Align = "left"
    width: int = 0

    def __post_init__(self) -> None:
        if self.align not in ("left", "right"):
            raise ValueError(f"column {self.title!r}: align must be 'left' or 'right', got {self.align!r}")


@dataclass(frozen=True)
class Table:
    """Rows of text cells under column headers.

    Attributes
    ----------
    columns
        The columns (titles, alignment, least widths).
    rows
        Cells as text, one tuple per row, as long as ``columns``.
    rule
        Draw a line of dashes under the header (text).
    width
        Largest line length of the text rendering: a wider table is split
        into column groups, each repeating the first ``keep`` columns (the
        row labels), separated by a blank line. ``None``: never split.
    keep
        Leading columns repeated in every group.
    gap
        A blank line before the table (text).
    """

    columns: tuple[Column, ...]
    rows: tuple[tuple[str, ...], ...]
    rule: bool = False
    width: int | None = None
    keep: int = 1
    gap: bool = True

    def __post_init__(self) -> None:
        for k, row in enumerate(self.rows):
            if len(row) != len(self.columns):
                raise ValueError(f"row {k} has {len(row)} cells for {len(self.columns)} columns")

    @property
    def headers(self) -> list[str]:
        """The column titles."""
        return [c.title for c in self.columns]

    def to_frame(self) -> Any:
        """The table as a :class:`pandas.DataFrame` of text cells, one column per header."""
        import pandas as pd

        return pd.DataFrame([list(r) for r in self.rows], columns=self.headers)

    def text_lines(self) -> list[str]:
        """The aligned text (two spaces between columns; trailing blanks removed)."""
        n = len(self.columns)
        widths = [max(c.width, len(c.title), *(len(r[j]) for r in self.rows)) for j, c in enumerate(self.columns)]
        keep = min(self.keep, n)
        fixed = list(range(keep))
        lines: list[str] = []
        for g, group in enumerate(column_groups(widths, keep, self.width)):
            if g:
                lines.append("")
            shown = fixed + group
            for k, cells in enumerate([self.headers, *self.rows]):
                parts = [
                    cells[j].rjust(widths[j]) if self.columns[j].align == "right" else cells[j].ljust(widths[j])
                    for j in shown
                ]
                lines.append("  ".join(parts).rstrip())
                if k == 0 and self.rule:
                    lines.append("  ".join("-" * widths[j] for j in shown))
        return lines


@dataclass(frozen=True)
class Fields:
    """``key: value`` lines.

    Attributes
    ----------
    items
        ``(key, value)`` pairs, in order (a key may repeat, e.g. ``warning``).
    separator
        ``None``: one pair per line; else every pair on one line, joined by it.
    gap
        A blank line before the block (text).
    """

    items: tuple[tuple[str, str], ...]
    separator: str | None = None
    gap: bool = False

    def text_lines(self) -> list[str]:
        """``key: value`` per pair, on one line when a separator is set (no line when empty)."""
        pairs = [f"{k}: {v}" for k, v in self.items]
        if self.separator is None:
            return pairs
        return [self.separator.join(pairs)] if pairs else []


@dataclass(frozen=True)
class Text:
    """Paragraphs of text.

    Attributes
    ----------
    paragraphs
        The paragraphs, one line each before wrapping.
    width
        Wrap each paragraph at this width in the text rendering (words are
        never broken); ``None``: one line per paragraph.
    indent, subsequent
        Indent of the first line of each paragraph and of its continuation
        lines (text).
    gap
        A blank line before the block (text).
    """

    paragraphs: tuple[str, ...]
    width: int | None = None
    indent: str = ""
    subsequent: str = ""
    gap: bool = False

    def text_lines(self) -> list[str]:
        """Each paragraph, indented and wrapped."""
        if self.width is None:
            return [self.indent + p for p in self.paragraphs]
        return [wrap(p, self.width, indent=self.indent, subsequent=self.subsequent) for p in self.paragraphs]


Block = Fields | Table | Text


@dataclass
class Summary:
    """A result's summary: a title and blocks of fields, tables and text, rendered as text, Markdown or HTML.

    Build it with :meth:`add_fields`, :meth:`add_table` and :meth:`add_text`
    (each returns the summary, so calls chain); results return a finished one.

    Attributes
    ----------
    title
        First line of the text rendering, heading of the others (none when empty).
    blocks
        The blocks, in order.
    """

    title: str = ""
    blocks: list[Block] = field(default_factory=list)

    # ------------------------------------------------------------------ building
    def add_fields(
        self,
        items: Mapping[str, str] | Iterable[tuple[str, str]],
        *,
        separator: str | None = None,
        gap: bool = False,
    ) -> Summary:
        """Add ``key: value`` lines (see :class:`Fields`)."""
        pairs = items.items() if isinstance(items, Mapping) else items
        self.blocks.append(Fields(tuple((str(k), str(v)) for k, v in pairs), separator, gap))
        return self

    def add_table(
        self,
        headers: Sequence[str | Column],
        rows: Iterable[Sequence[Any]],
        *,
        rule: bool = False,
        width: int | None = None,
        keep: int = 1,
        gap: bool = True,
    ) -> Summary:
        """Add a table (see :class:`Table`); a plain header is a left-aligned :class:`Column`."""
        columns = tuple(h if isinstance(h, Column) else Column(str(h)) for h in headers)
        cells = tuple(tuple(str(c) for c in r) for r in rows)
        self.blocks.append(Table(columns, cells, rule=rule, width=width, keep=keep, gap=gap))
        return self

    def add_text(
        self,
        *paragraphs: str,
        width: int | None = None,
        indent: str = "",
        subsequent: str | None = None,
        gap: bool = False,
    ) -> Summary:
        """Add paragraphs (see :class:`Text`); continuation lines are indented two more spaces by default."""
        after = indent + "  " if subsequent is None else subsequent
        self.blocks.append(Text(tuple(paragraphs), width, indent, after, gap))
        return self

    @property
    def tables(self) -> list[Table]:
        """The tables, in order."""
        return [b for b in self.blocks if isinstance(b, Table)]

    # ------------------------------------------------------------------ rendering
    def as_text(self) -> str:
        """The summary as aligned text (what the command line prints)."""
        lines = [self.title] if self.title else []
        for block in self.blocks:
            if block.gap:
                lines.append("")
            lines += block.text_lines()
        return "\n".join(lines)

    def as_markdown(self) -> str:
        """The summary as Markdown: a heading, field lists, pipe tables, paragraphs."""
        out = [f"### {_md(self.title)}"] if self.title else []
        for block in self.blocks:
            if isinstance(block, Fields):
                if block.items:
                    out.append("\n".join(f"- **{_md(k)}**: {_md(v)}" for k, v in block.items))
            elif isinstance(block, Table):
                align = {"left": " :--- ", "right": " ---: "}
                lines = ["| " + " | ".join(_md(h) for h in block.headers) + " |"]
                lines.append("|" + "|".join(align[c.align] for c in block.columns) + "|")
                lines += ["| " + " | ".join(_md(c) for c in row) + " |" for row in block.rows]
                out.append("\n".join(lines))
            else:
                out += [_md(p.strip()) for p in block.paragraphs if p.strip()]
        return "\n\n".join(out) + "\n"

    def as_html(self) -> str:
        """The summary as an HTML fragment (a ``div``; the notebook's rendering)."""
        e = html.escape
        parts = [f"<h4>{e(self.title)}</h4>"] if self.title else []
        for block in self.blocks:
            if isinstance(block, Fields):
                if block.items:
                    rows = [list(item) for item in block.items]
                    parts.append(
                        html_table(None, rows, align=("left", "left"), table_class="nlid-fields", row_header=True)
                    )
            elif isinstance(block, Table):
                align = [c.align for c in block.columns]
                parts.append(html_table([c.title for c in block.columns], block.rows, align=align))
            else:
                parts += [f"<p>{e(p.strip())}</p>" for p in block.paragraphs if p.strip()]
        return "<div class='nlid-summary'>" + "".join(parts) + "</div>"

    def to_dict(self) -> dict[str, Any]:
        """The content as plain data: ``{"title", "blocks": [{"kind": "fields" | "table" | "text", ...}]}``."""
        blocks: list[dict[str, Any]] = []
        for block in self.blocks:
            if isinstance(block, Fields):
                blocks.append({"kind": "fields", "items": [list(i) for i in block.items]})
            elif isinstance(block, Table):
                blocks.append(
                    {
                        "kind": "table",
                        "columns": [{"title": c.title, "align": c.align} for c in block.columns],
                        "rows": [list(r) for r in block.rows],
                    }
                )
            else:
                blocks.append({"kind": "text", "paragraphs": [p.strip() for p in block.paragraphs]})
        return {"title": self.title, "blocks": blocks}

    def __str__(self) -> str:
        return self.as_text()

    def __contains__(self, text: object) -> bool:
        """Whether ``text`` occurs in the text rendering (``"epsilon" in fit.summary()``)."""
        return isinstance(text, str) and text in self.as_text()

    def _repr_html_(self) -> str:
        return self.as_html()

    def __repr__(self) -> str:
        kinds = [type(b).__name__.lower() for b in self.blocks]
        counts = ", ".join(f"{kinds.count(k)} {k}" for k in ("fields", "table", "text") if k in kinds)
        return f"<Summary {self.title!r}: {counts or 'empty'}>"


def _md(text: str) -> str:
    """Text safe in a Markdown table cell or paragraph (no emphasis, no cell breaks, no raw HTML)."""
    for ch in ("\\", "`", "*", "_", "|"):
        text = text.replace(ch, "\\" + ch)
    return text.replace("<", "&lt;").replace(">", "&gt;")
