"""A study's outputs: results.csv, summary.md / summary.txt / summary.csv, figures and a self-contained report.html.

``summary.txt`` is what ``nlid study run`` prints: the verdict first, then the
tables, no line wider than :data:`nlid.base.formatting.TERMINAL_WIDTH`.

The outputs are written again only when they are stale: ``report.html`` carries
the digest of what it was written from (:func:`report_digest`: every stored
row and result of the study's runs, the study file and nlid's code), so a
re-run with nothing new reads the store and keeps the report; and a report that
is written again redraws only the figures whose inputs changed
(:class:`~nlid.study.report.figurecache.FigureCache`).
"""

from __future__ import annotations

import base64
import datetime
import functools
import hashlib
import html
import re
from pathlib import Path
from typing import Any

import pandas as pd

from ... import __version__
from ...report.html import html_table
from ..store import ResultStore
from .codedigest import code_digest
from .figurecache import Figure, FigureCache
from .figures import section_figures
from .render import summary_long, summary_markdown, summary_text
from .section import Section, Table
from .tables import build_sections

__all__ = ["write_report", "report_html", "report_digest", "stored_digest", "code_digest", "TEXT_SUMMARY"]

#: The terminal summary's file name in the study folder.
TEXT_SUMMARY = "summary.txt"
#: The ``<meta name=...>`` of report.html that holds :func:`report_digest`.
DIGEST_META = "nlid-report-digest"
#: The text outputs written with the report (each must exist for the report to be fresh).
_TEXT_OUTPUTS = ("results.csv", "summary.md", TEXT_SUMMARY, "summary.csv")
_META_RE = re.compile(rf'<meta name="{DIGEST_META}" content="([0-9a-f]{{64}})">')


@functools.lru_cache(maxsize=8)
def _plugin_packages(identifiers: tuple[str, ...]) -> tuple[str, ...]:
    """The top-level packages of the study's identifiers (already imported: the study was loaded with them)."""
    from ...contract.registry import default_registry

    found = set()
    registry = default_registry()
    for name in identifiers:
        cls = registry.identifiers.get(name)
        if cls is not None:
            found.add(cls.__module__.split(".")[0])
    return tuple(sorted(found - {"nlid"}))


def report_digest(config: Any, runs: list, digests: list[str], code: str | None = None) -> str:
    """The digest a study's outputs are written from.

    Parameters
    ----------
    config
        The study (its text, name and identifiers).
    runs
        The planned runs (ids and spec digests).
    digests
        :meth:`~nlid.study.store.ResultStore.snapshot`'s digest of each stored run (the rows and results).
    code
        :func:`code_digest` of nlid and the study's plugins (default: computed).
    """
    code = code if code is not None else code_digest(_plugin_packages(tuple(config.identifiers)))
    h = hashlib.sha256(code.encode())
    h.update(
        repr((config.name, config.text, tuple(config.identifiers), sorted(config.skipped_identifiers.items()))).encode()
    )
    for run in runs:
        h.update(f"{run.run_id}\0{run.digest}\n".encode())
    for d in digests:
        h.update(d.encode())
    return h.hexdigest()


def stored_digest(folder: Path) -> str | None:
    """The digest report.html in ``folder`` was written from, or ``None`` (no report, or one of an older nlid)."""
    try:
        with open(Path(folder) / "report.html", encoding="utf-8", errors="replace") as fh:
            head = fh.read(4096)
    except OSError:
        return None
    found = _META_RE.search(head)
    return found.group(1) if found else None


def _fresh(folder: Path, digest: str) -> bool:
    """True when every output in ``folder`` was written from ``digest`` and is there."""
    if stored_digest(folder) != digest or not all((folder / name).is_file() for name in _TEXT_OUTPUTS):
        return False
    cache = FigureCache(folder / "figures", code="")
    return all((cache.folder / f"{stem}{suffix}").is_file() for stem in cache.stored for suffix in (".png", ".svg"))


def write_report(config: Any, runs: list, store: ResultStore, *, force: bool = False) -> tuple[str, Path]:
    """Write every output of a study from its stored runs, unless they are up to date.

    The outputs are kept when ``report.html`` was written from the same rows, results, study and code
    (:func:`report_digest`); otherwise everything is written again, and only the figures whose inputs
    changed are drawn (:class:`~nlid.study.report.figurecache.FigureCache`).

    Parameters
    ----------
    config, runs, store
        The study, its planned runs and its folder.
    force
        Write every output and draw every figure, fresh or not.

    Returns
    -------
    summary : str
        The Markdown summary (also in ``summary.md``).
    report : pathlib.Path
        ``report.html``.
    """
    folder = store.folder
    path = folder / "report.html"
    records, digests = store.snapshot(runs)
    code = code_digest(_plugin_packages(tuple(config.identifiers)))
    digest = report_digest(config, runs, digests, code)
    if not force and _fresh(folder, digest):
        try:
            text = (folder / "summary.md").read_text()
            return text[:-1] if text.endswith("\n") else text, path  # as written: the summary and a newline
        except OSError:
            pass
    frame = pd.DataFrame([r["row"] for r in records])
    store.write_results(runs, frame)
    sections = build_sections(config, frame, records)
    summary = summary_markdown(config, sections)
    (folder / "summary.md").write_text(summary + "\n")
    (folder / TEXT_SUMMARY).write_text(summary_text(config, sections) + "\n")
    summary_long(frame).to_csv(folder / "summary.csv", index=False)
    cache = FigureCache(folder / "figures", code=code)
    if force:
        cache.stored = {}
    figures = {(s.dataset, s.model): section_figures(s, records, store, cache.folder, cache) for s in sections}
    cache.write_index()
    # written last: its digest says every output above is complete
    store.write_text(path, report_html(config, sections, figures, len(runs), len(records), digest))
    return summary, path


_CSS = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 1200px; color: #222; }
table { border-collapse: collapse; margin: 0.5em 0 1.2em; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: right; }
th:first-child, td:first-child { text-align: left; }
tr.reference td { background: #f3f3f3; font-style: italic; }
td.best { background: #dff0d8; font-weight: bold; }
section.verdict { border: 2px solid #4a7; border-radius: 6px; padding: 0.2em 1em 0.6em; margin: 1em 0 2em;
  background: #f7fcf8; }
section.verdict td, section.verdict th { text-align: left; }
p.caption { font-size: 0.9em; color: #555; margin-top: -0.6em; }
figure { margin: 1em 0 2em; }
figure img { max-width: 100%; border: 1px solid #eee; }
figcaption { font-size: 0.9em; color: #555; }
.failures { color: #a00; }
"""

# Marks the page once every embedded image has decoded (used by the headless-browser test).
_SCRIPT = """
window.addEventListener("load", function () {
  var imgs = Array.prototype.slice.call(document.images);
  var ok = imgs.filter(function (i) { return i.complete && i.naturalWidth > 0; }).length;
  document.body.setAttribute("data-images", ok + "/" + imgs.length);
});
"""


def _rows_html(header: list[str], rows: list[list[str]], best: set[tuple[int, int]] = frozenset()) -> list[str]:
    return [
        html_table(
            header,
            rows,
            cell_class=lambda i, j: "best" if (i, j) in best else None,
            row_class=lambda i, row: "reference" if row and row[0] == "reference" else None,
        )
    ]


def _table_html(table: Table) -> str:
    out = [f"<h4>{html.escape(table.title)}</h4>", *_rows_html(table.header, table.rows, table.best)]
    if table.notes:
        out.append("<ul>" + "".join(f"<li>{html.escape(n)}</li>" for n in table.notes) + "</ul>")
    return "\n".join(out)


def _verdict_html(section: Section, titled: bool) -> str:
    v = section.verdict
    header, rows = v.table_rows()
    parts = ['<section class="verdict">']
    parts.append(f"<h2>Verdict{': ' + html.escape(section.dataset + ' / ' + section.model) if titled else ''}</h2>")
    parts.append(f"<p><b>{html.escape(v.headline())}</b></p><p>{html.escape(v.separation())}</p>")
    parts += _rows_html(header, rows)
    parts.append("<p>Why:</p><ul>")
    parts += [f"<li><b>{html.escape(m)}</b>: {html.escape('; '.join(why))}</li>" for m, why in v.reasons.items()]
    parts.append("</ul></section>")
    return "\n".join(parts)


def _figure_html(fig: Figure) -> str:
    data = base64.b64encode(fig.png.read_bytes()).decode("ascii")
    return (
        f'<figure><img alt="{html.escape(fig.title)}" src="data:image/png;base64,{data}">'
        f"<figcaption><b>{html.escape(fig.title)}.</b> {html.escape(fig.caption)} "
        f"(<code>figures/{html.escape(fig.stem.name)}.svg</code>)</figcaption></figure>"
    )


def report_html(
    config: Any,
    sections: list[Section],
    figures: dict[tuple[str, str], list[Figure]],
    planned: int,
    finished: int,
    digest: str | None = None,
) -> str:
    """The report as one HTML page with the figures embedded (opens offline).

    ``digest`` (:func:`report_digest`) is kept in a ``<meta>`` tag: what the page was written from.
    """
    now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f'<meta name="{DIGEST_META}" content="{digest}">' if digest else "",
        f"<title>nlid study {html.escape(config.name)}</title>",
        f"<style>{_CSS}</style><script>{_SCRIPT}</script></head><body>",
        f"<h1>Study {html.escape(config.name)}</h1>",
        f"<p>{html.escape(config.description)}</p>" if config.description else "",
        f"<p>{finished} of {planned} runs finished; identifiers: {html.escape(', '.join(config.identifiers))}; "
        f"study seed {config.seed}; nlid {__version__}; written {now}.</p>",
    ]
    judged = [sec for sec in sections if sec.verdict is not None]
    if judged:
        parts.append('<a id="verdict"></a>')
    parts += [_verdict_html(sec, len(sections) > 1) for sec in judged]
    parts.append(
        "<p>Cells are median [min, max] over repetitions, with significant digits chosen from the spread; error "
        "columns are |relative error| in % of the reference values listed first; highlighted: the best (lowest) "
        "median of an error or cost column (every one of a tie). Epsilon is Eq. 26, computed by nlid from the data.</p>"
    )
    for section in sections:
        parts.append(f"<h2>{html.escape(section.dataset)} / {html.escape(section.model)}</h2>")
        terms = f"; terms: {', '.join(section.terms)}" if section.terms else ""
        parts.append(f"<p>{html.escape(section.description + terms)}</p>")
        if section.frame.empty:
            parts.append("<p>No finished runs yet.</p>")
            continue
        parts += [_table_html(t) for t in section.tables]
        if section.failures:
            items = "".join(f"<li>{html.escape(f)}</li>" for f in section.failures)
            parts.append(f'<div class="failures"><h4>Failed runs</h4><ul>{items}</ul></div>')
        parts += [_figure_html(f) for f in figures.get((section.dataset, section.model), [])]
    parts.append("</body></html>")
    return "\n".join(p for p in parts if p)
