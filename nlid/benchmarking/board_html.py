"""``leaderboard.html``: the leaderboard as one self-contained, styled and sortable page.

No external file, script or style sheet: the CSS and a few lines of JavaScript (click a column
header to sort by it; click again to reverse) are inline, and each test set's figure is inlined
as SVG. Each table states its rule once in its caption; each row shows what it knew as badges,
explained once under the table; nlid's rows, the peers, the published figures and the true
model are told apart by colour (the same as the figures').
"""

from __future__ import annotations

import html
import math
from collections.abc import Mapping, Sequence
from typing import Any

from .board_figures import STYLES
from .board_rows import (
    badges,
    groups,
    integer,
    legend,
    num,
    range_note,
    ranks,
    remark,
    rule_text,
    scored,
    seconds,
    source_of,
    sources,
    unscored,
    who,
)
from .declarations import Protocol

__all__ = ["leaderboard_html", "CSS", "SORT_SCRIPT"]

#: The page's style sheet (inline).
CSS = """
body{font-family:system-ui,-apple-system,"Segoe UI",sans-serif;max-width:72em;margin:2em auto;padding:0 1em;
color:#222;line-height:1.45}
h1{font-size:1.6em}h2{margin-top:2em;border-bottom:2px solid #ddd;padding-bottom:.2em}
h3{margin-top:1.6em}
table.board{border-collapse:collapse;margin:.6em 0 .3em;width:100%;font-size:.92em}
table.board caption{caption-side:top;text-align:left;padding:.3em 0;color:#444}
table.board th{background:#f3f4f6;border-bottom:2px solid #ccc;padding:4px 8px;text-align:left;cursor:pointer;
white-space:nowrap;user-select:none}
table.board th[aria-sort=ascending]::after{content:" \\25B2"}
table.board th[aria-sort=descending]::after{content:" \\25BC"}
table.board td{border-bottom:1px solid #e3e3e3;padding:4px 8px;vertical-align:top}
table.board td.num{text-align:right;font-variant-numeric:tabular-nums;white-space:nowrap}
table.board tr:hover td{background:#fafafa}
tr.kind-nlid td:first-child{border-left:4px solid @nlid}
tr.kind-truth td:first-child{border-left:4px solid @truth}
tr.kind-peer td:first-child{border-left:4px solid @peer}
tr.kind-published td:first-child{border-left:4px solid @published}
tr.kind-reference td{color:#777;font-style:italic}
tr.other-rule td{color:#888}
.who{font-weight:600}.kind{font-size:.78em;text-transform:uppercase;letter-spacing:.04em;color:#666;margin-right:.4em}
.badge{display:inline-block;font-size:.78em;padding:1px 7px;margin:1px 2px;border-radius:9px;background:#eef2f7;
color:#234;border:1px solid #cfd8e3;white-space:nowrap}
.badge.b-true-model{background:#e6f4ea;border-color:#a8d5b5}.badge.b-black-box{background:#f1f1f1;border-color:#d5d5d5}
.legend,.notes{font-size:.88em;color:#444}.legend .badge{margin-right:.3em}
figure{margin:.8em 0}figure svg{max-width:100%;height:auto}
.protocol{background:#f8f8f8;border-left:3px solid #ccc;padding:.4em .8em;font-size:.92em}
"""
for _kind, _style in STYLES.items():
    CSS = CSS.replace(f"@{_kind}", _style["color"])

#: Click a header to sort its table by that column (numbers by value; "-" last); click again to reverse.
SORT_SCRIPT = """
document.querySelectorAll("table.board").forEach(function (table) {
  table.querySelectorAll("th").forEach(function (th, col) {
    th.addEventListener("click", function () {
      var body = table.tBodies[0], rows = Array.from(body.rows);
      var down = th.getAttribute("aria-sort") === "ascending";
      table.querySelectorAll("th").forEach(function (h) { h.removeAttribute("aria-sort"); });
      th.setAttribute("aria-sort", down ? "descending" : "ascending");
      var key = function (row) {
        var cell = row.cells[col], v = cell.getAttribute("data-v");
        if (v === null) { return [1, cell.textContent.trim().toLowerCase()]; }
        var x = parseFloat(v);
        return isNaN(x) ? [2, 0] : [0, x];
      };
      rows.sort(function (a, b) {
        var ka = key(a), kb = key(b);
        if (ka[0] !== kb[0]) { return ka[0] - kb[0]; }
        var c = ka[1] < kb[1] ? -1 : (ka[1] > kb[1] ? 1 : 0);
        return down ? -c : c;
      });
      rows.forEach(function (row) { body.appendChild(row); });
    });
  });
});
"""


def _e(text: Any) -> str:
    return html.escape(str(text))


def _slug(text: str) -> str:
    return "b-" + "".join(c if c.isalnum() else "-" for c in text.lower())


def _badges(names: Sequence[str]) -> str:
    return "".join(f'<span class="badge {_slug(b)}">{_e(b)}</span>' for b in names) or "-"


def _number(x: Any, text: str) -> str:
    try:
        value = float(x)
    except (TypeError, ValueError):
        value = math.nan
    v = "" if math.isnan(value) else f' data-v="{value:.10g}"'
    return f'<td class="num"{v}>{_e(text)}</td>'


def _who_cell(r: Mapping[str, Any], cited: Sequence[tuple[str, str, str]]) -> str:
    kind = {"nlid": "nlid", "peer": "peer", "published": "published", "truth": "truth", "reference": ""}[r["kind"]]
    name = who(r).split(" ", 1)[1] if r["kind"] in ("nlid", "peer", "published") else who(r)
    mark = f" [{list(cited).index(source_of(r)) + 1}]" if r["kind"] == "published" and source_of(r) in cited else ""
    label = f'<span class="kind">{_e(kind)}</span>' if kind else ""
    title = f' title="{_e(r.get("method") or "")}"' if r.get("method") else ""
    return f'<td{title}>{label}<span class="who">{_e(name)}</span>{_e(mark)}</td>'


def table_html(rows: Sequence[Mapping[str, Any]], caption: str) -> str:
    """The sortable table of one test set, its legend, what was not scored and the published rows' sources."""
    unit = rows[0]["unit"]
    shown = scored(rows)
    cited = sources(shown)
    head = ["#", "row", "knew", f"RMSE ({unit})", "NRMSE %", "fit %", "parameters", "time (s)", "model", "notes"]
    out = [
        '<table class="board">',
        f"<caption>{caption}</caption>",
        "<thead><tr>" + "".join(f'<th scope="col">{_e(h)}</th>' for h in head) + "</tr></thead>",
        "<tbody>",
    ]
    for rank, r in zip(ranks(shown), shown, strict=True):
        classes = [f"kind-{r['kind']}"] + ([] if r.get("same_rule", True) else ["other-rule"])
        cells = [
            _number(rank if rank != "-" else None, rank),
            _who_cell(r, cited),
            f"<td>{_badges(badges(r))}</td>",
            _number(r["rmse"], num(r["rmse"])),
            _number(r["nrmse_percent"], num(r["nrmse_percent"])),
            _number(r["fit_percent"], num(r["fit_percent"])),
            _number(r["parameters"], integer(r["parameters"])),
            _number(r["seconds"], seconds(r["seconds"])),
            f"<td>{_e(r.get('model') or '')}</td>",
            f"<td>{_e(remark(r))}</td>",
        ]
        out.append(f'<tr class="{" ".join(classes)}">' + "".join(cells) + "</tr>")
    out.append("</tbody></table>")
    used = legend(shown)
    if used:
        items = "; ".join(f"{_badges([b])} {_e(text)}" for b, text in used)
        out.append(f'<p class="legend">Knew: {items}.</p>')
    by_note: dict[str, list[str]] = {}
    for r in unscored(rows):
        by_note.setdefault(str(r.get("note", "")), []).append(str(r["pipeline"]))
    for note, names in by_note.items():
        out.append(f'<p class="notes">Not scored ({_e(", ".join(names))}): {_e(note)}</p>')
    if cited:
        out.append('<ol class="notes">')
        out += [f"<li>{_e(paper)}; checked in {_e(where)} ({_e(status)}).</li>" for paper, where, status in cited]
        out.append("</ol>")
    return "\n".join(out)


def leaderboard_html(
    protocols: Mapping[str, Protocol], rows: Sequence[Mapping[str, Any]], svgs: Mapping[tuple[str, str], str]
) -> str:
    """The whole page: per benchmark its protocol, per test set its rule, figure (inline SVG) and table."""
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8"><meta name="viewport" content="width=device-width">',
        "<title>nlid bench: leaderboard</title>",
        f"<style>{CSS}</style>",
        "</head><body>",
        "<h1>nlid bench: leaderboard</h1>",
        "<p>Free-run RMSE of the displacement on each test set, under the test set's transient rule; every row was "
        "given the estimation part only. Click a column header to sort.</p>",
    ]
    for name, p in protocols.items():
        parts.append(f"<h2>{_e(p.title)}</h2>")
        kind = "the benchmark's split" if p.official else "<b>nlid's own protocol</b> (not an official split)"
        parts.append(
            f'<p class="protocol">Benchmark <code>{_e(p.name)}</code>: {kind}: {_e(p.protocol)}.<br>'
            f"Estimation: {_e(p.estimation.description)}.</p>"
        )
        for bench, test, group in groups(rows):
            if bench != name:
                continue
            t = p.test(test)
            parts.append(f'<h3 id="{_e(bench)}--{_e(test)}">test <code>{_e(test)}</code></h3>')
            parts.append(f"<p>{_e(t.source.description or test)}.</p>")
            rule = _e(rule_text(group).replace("`", "")) + (f" ({_e(t.rule_note)})" if t.rule_note else "")
            beyond = range_note(group)
            if beyond:
                rule += f"<br><b>Range</b> {_e(beyond)}."
            svg = svgs.get((bench, test))
            if svg:
                parts.append(f"<figure>{svg}</figure>")
            parts.append(table_html(group, f"<b>Rule</b> {rule}"))
        if p.not_comparable:
            parts.append('<p class="notes">Published figures not shown:</p><ul class="notes">')
            parts += [f"<li>{_e(n.what)}: {_e(n.why)}.</li>" for n in p.not_comparable]
            parts.append("</ul>")
    parts += [f"<script>{SORT_SCRIPT}</script>", "</body></html>"]
    return "\n".join(parts) + "\n"
