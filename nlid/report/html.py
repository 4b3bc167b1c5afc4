"""The one HTML table writer of the summaries, the study report and the discover report.

Every cell is escaped here, once; callers pass plain text. (The leaderboard's sortable table,
:mod:`nlid.benchmarking.board_html`, writes its own: its cells carry sort keys and badges.)
"""

from __future__ import annotations

import html
from collections.abc import Callable, Sequence

__all__ = ["html_table"]


def _attrs(cls: str | None, style: str | None, extra: str | None = None) -> str:
    out = ""
    if cls:
        out += f' class="{html.escape(cls)}"'
    if style:
        out += f" style='{html.escape(style)}'"
    if extra:
        out += f" {extra}"
    return out


def html_table(
    header: Sequence[str] | None,
    rows: Sequence[Sequence[object]],
    *,
    align: Sequence[str] | None = None,
    cell_class: Callable[[int, int], str | None] | None = None,
    cell_attrs: Callable[[int, int], str | None] | None = None,
    row_class: Callable[[int, Sequence[object]], str | None] | None = None,
    table_class: str | None = None,
    header_scope: bool = False,
    caption: str | None = None,
    caption_html: bool = False,
    row_header: bool = False,
) -> str:
    """An HTML table of plain-text cells, escaped.

    Parameters
    ----------
    header
        Column titles (a ``thead`` row), or ``None`` for none.
    rows
        The rows; each cell is written as ``str(cell)``, escaped.
    align
        ``"left"``/``"right"``/``"center"`` per column, written as ``style='text-align:...'`` on every
        cell of the column.
    cell_class, cell_attrs
        ``(row index, column index) ->`` a class name, or further attributes written as they are
        (already escaped by the caller: numbers for sorting), or ``None``.
    row_class
        ``(row index, row) ->`` the row's class, or ``None``.
    table_class
        The table's class.
    header_scope
        Write ``scope="col"`` on the header cells (accessible tables).
    caption, caption_html
        A caption, escaped unless ``caption_html`` (the caller built its HTML from escaped parts).
    row_header
        The first cell of each row is a header cell (``th``): a table of fields, one per row.
    """
    e = html.escape

    def style(j: int) -> str | None:
        return f"text-align:{align[j]}" if align is not None else None

    out = [f"<table{_attrs(table_class, None)}>"]
    if caption is not None:
        out.append(f"<caption>{caption if caption_html else e(caption)}</caption>")
    if header is not None:
        scope = 'scope="col"' if header_scope else None
        out.append(
            "<thead><tr>"
            + "".join(f"<th{_attrs(None, style(j), scope)}>{e(str(h))}</th>" for j, h in enumerate(header))
            + "</tr></thead>"
        )
    body = []
    for i, row in enumerate(rows):
        cells = ""
        for j, c in enumerate(row):
            tag = "th" if row_header and j == 0 else "td"
            attrs = _attrs(cell_class(i, j) if cell_class else None, style(j), cell_attrs(i, j) if cell_attrs else None)
            cells += f"<{tag}{attrs}>{e(str(c))}</{tag}>"
        body.append(f"<tr{_attrs(row_class(i, row) if row_class else None, None)}>{cells}</tr>")
    out.append("<tbody>" + "".join(body) + "</tbody></table>")
    return "".join(out)
