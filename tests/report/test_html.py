"""The one HTML table writer (issue 32): every cell escaped once, classes and alignment where asked."""

from __future__ import annotations

from nlid.report.html import html_table


def test_cells_and_titles_are_escaped_and_classes_placed():
    page = html_table(
        ["<m>", "x"],
        [["reference", "<1>"], ["rfs", 2.5]],
        cell_class=lambda i, j: "best" if (i, j) == (1, 1) else None,
        row_class=lambda i, row: "reference" if row[0] == "reference" else None,
    )
    assert "<th>&lt;m&gt;</th>" in page and "<td>&lt;1&gt;</td>" in page
    assert '<tr class="reference"><td>reference</td>' in page and '<td class="best">2.5</td>' in page
    assert page.startswith("<table><thead>") and page.endswith("</tbody></table>")


def test_fields_have_a_header_cell_per_row_and_alignment():
    page = html_table(None, [["a & b", "1"]], align=("left", "right"), row_header=True, table_class="f")
    assert page == (
        "<table class=\"f\"><tbody><tr><th style='text-align:left'>a &amp; b</th>"
        "<td style='text-align:right'>1</td></tr></tbody></table>"
    )
