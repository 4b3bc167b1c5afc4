"""The leaderboard: nlid's rows beside the peer's and the published ones, per benchmark and test set.

:func:`leaderboard_rows` turns the stored jobs and the benchmark files into rows (one table per
benchmark and test set); :func:`write_leaderboard` writes them as ``leaderboard.csv`` (every
row, the columns of :data:`COLUMNS`), ``leaderboard.md`` and ``leaderboard.html`` (a table per
benchmark and test set, the rule stated above each table, rows scored under another rule
marked). RMSE is in the benchmark's unit; NRMSE = RMSE / std(z over the scored samples) in %;
fit % is MATLAB ``compare``'s ``100 (1 - |z - z_sim| / |z - mean z|)``.
"""

from __future__ import annotations

import html
import math
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from ..formatting import sig
from .protocol import Protocol

__all__ = ["COLUMNS", "leaderboard_rows", "write_leaderboard", "markdown_tables", "table_markdown", "read_leaderboard"]

#: The leaderboard's columns, in order.
COLUMNS = (
    "benchmark",
    "official",
    "test",
    "rule_declared",
    "kind",
    "pipeline",
    "method",
    "model",
    "rmse",
    "unit",
    "nrmse_percent",
    "fit_percent",
    "parameters",
    "seconds",
    "rule",
    "same_rule",
    "scored_samples",
    "status",
    "note",
    "source",
)
_KIND_ORDER = {"nlid": 0, "peer": 1, "published": 2, "reference": 3, "truth": 4}


def _nan(x: Any) -> float:
    try:
        return float(x) if x is not None else math.nan
    except (TypeError, ValueError):
        return math.nan


def leaderboard_rows(protocols: Mapping[str, Protocol], records: Iterable[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """Every row: the jobs' rows (RMSE scaled to the benchmark's unit), the noise floors, the published figures.

    Parameters
    ----------
    protocols
        The benchmarks, by name.
    records
        Stored jobs (:meth:`nlid.study.store.ResultStore.load`): ``{"row", "result"}``.
    """
    rows: list[dict[str, Any]] = []
    floors: dict[tuple[str, str], float] = {}
    failed: list[tuple[str, str]] = []
    for rec in records:
        result = rec.get("result") or {}
        job = rec.get("row") or {}
        if job.get("status") != "ok":
            failed.append(
                (str(job.get("benchmark", "")), f"{job.get('run_id')}: {job.get('status')}: {job.get('error')}")
            )
        for name, sigma in (result.get("noise_floors") or {}).items():
            floors.setdefault((job.get("benchmark", ""), name), float(sigma))
        for r in result.get("rows", []):
            p = protocols.get(r["benchmark"])
            if p is None:
                continue
            out = {c: r.get(c) for c in COLUMNS}
            out["rmse"] = _nan(r.get("rmse")) * p.scale
            out["unit"] = p.unit
            out["official"] = p.official
            out["same_rule"] = r.get("status") == "not run" or r.get("rule_applied") == r.get("rule_declared")
            out["source"] = r.get("data", "")
            rows.append(out)
    for p in protocols.values():
        for t in p.tests:
            sigma = floors.get((p.name, t.name))
            if sigma is not None and t.noise_floor is not None:
                periods = ", ".join(str(k) for k in t.noise_floor.periods)
                rows.append(
                    _row(
                        p,
                        t.name,
                        t.rule,
                        kind="reference",
                        pipeline="noise floor",
                        rmse=sigma * p.scale,
                        method=f"output noise: differences of estimation periods {periods}",
                        note="the RMSE a perfect model reaches on a held-out period",
                        rule="-",
                        same_rule=True,
                        status="ok",
                    )
                )
            for pub in p.published_on(t.name):
                rows.append(
                    _row(
                        p,
                        t.name,
                        t.rule,
                        kind="published",
                        pipeline=pub.method,
                        method=pub.paper,
                        rmse=pub.rmse * p.scale,
                        fit_percent=pub.fit_percent,
                        parameters=pub.parameters,
                        rule=pub.rule,
                        same_rule=pub.same_rule,
                        status=f"published ({pub.status})",
                        note=pub.note,
                        source=pub.source,
                        model=f"{pub.value:g} {pub.unit} as published",
                    )
                )
    for bench, message in failed:
        p = protocols.get(bench)
        if p is not None:
            for t in p.tests:
                rows.append(
                    _row(p, t.name, t.rule, kind="nlid", pipeline="(job failed)", status="failed", note=message)
                )
    order = {name: i for i, name in enumerate(protocols)}

    def key(r: dict[str, Any]) -> tuple:
        p = protocols[r["benchmark"]]
        tests = [t.name for t in p.tests]
        rmse = _nan(r["rmse"])
        return (
            order[r["benchmark"]],
            tests.index(r["test"]) if r["test"] in tests else 99,
            math.isnan(rmse),
            rmse if not math.isnan(rmse) else 0.0,
            _KIND_ORDER.get(r["kind"], 9),
        )

    rows.sort(key=key)
    return rows


def _row(p: Protocol, test: str, declared: str, **values: Any) -> dict[str, Any]:
    row: dict[str, Any] = {c: None for c in COLUMNS}
    row.update(
        benchmark=p.name,
        official=p.official,
        test=test,
        rule_declared=declared,
        unit=p.unit,
        rmse=math.nan,
        nrmse_percent=math.nan,
        fit_percent=math.nan,
        note="",
        source="",
        model="",
        method="",
    )
    row.update(values)
    return row


# --------------------------------------------------------------------------- text
def _num(x: Any, digits: int = 3) -> str:
    x = _nan(x)
    return "-" if math.isnan(x) else sig(x, digits)


def _int(x: Any) -> str:
    x = _nan(x)
    return "-" if math.isnan(x) else str(int(round(x)))


def _seconds(x: Any) -> str:
    x = _nan(x)
    return "-" if math.isnan(x) else f"{x:.1f}"


def _who(r: Mapping[str, Any], sources: Sequence[Mapping[str, Any]] = ()) -> str:
    kind = r["kind"]
    if kind == "nlid":
        return f"nlid `{r['pipeline']}`"
    if kind == "peer":
        return f"peer: {r['method']}"
    if kind == "reference":
        return "noise floor"
    if kind == "truth":
        return "true system (the data's generator, under this scorer)"
    mark = f" [{list(sources).index(r) + 1}]" if r in sources else ""
    return f"published: {r['pipeline']}{mark}"


def _remark(r: Mapping[str, Any]) -> str:
    notes = []
    if r.get("status") != "not run" and not r.get("same_rule", True):
        notes.append(f"**other rule**: {r['rule']}")
    if r["kind"] == "published":
        return "; ".join(notes)
    if r.get("status") not in ("ok", None):
        notes.append(str(r["status"]))
    if r.get("note"):
        notes.append(str(r["note"]))
    return "; ".join(notes)


def _esc(text: str) -> str:
    return str(text).replace("|", "\\|")


def table_markdown(rows: Sequence[Mapping[str, Any]]) -> list[str]:
    """The Markdown table of one benchmark and test set, then what was not run and the published rows' sources."""
    unit = rows[0]["unit"]
    shown = [r for r in rows if r.get("status") != "not run"]
    sources = [r for r in shown if r["kind"] == "published"]
    lines = [
        f"| | RMSE ({unit}) | NRMSE % | fit % | parameters | time (s) | model | notes |",
        "| --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for r in shown:
        lines.append(
            f"| {_esc(_who(r, sources))} | {_num(r['rmse'])} | {_num(r['nrmse_percent'])} | {_num(r['fit_percent'])} "
            f"| {_int(r['parameters'])} | {_seconds(r['seconds'])} | {_esc(r.get('model') or '')} "
            f"| {_esc(_remark(r))} |"
        )
    skipped = [r for r in rows if r.get("status") == "not run"]
    if skipped:
        names = ", ".join(f"`{r['pipeline']}`" for r in skipped)
        lines += ["", f"Not scored ({names}): {skipped[0].get('note', '')}"]
    for i, r in enumerate(sources, 1):
        note = f" {r['note']}." if r.get("note") else ""
        status = str(r.get("status", "")).replace("published ", "").strip("()")
        lines += ["", f"[{i}] {r['method']}; {r['model']}; checked in {r['source']} ({status}).{note}"]
    return lines


def _groups(rows: Sequence[Mapping[str, Any]]) -> list[tuple[str, str, list[Mapping[str, Any]]]]:
    out: list[tuple[str, str, list[Mapping[str, Any]]]] = []
    for r in rows:
        if not out or (out[-1][0], out[-1][1]) != (r["benchmark"], r["test"]):
            out.append((r["benchmark"], r["test"], []))
        out[-1][2].append(r)
    return out


def _rule_line(rows: Sequence[Mapping[str, Any]]) -> str:
    texts = sorted(
        {str(r["rule"]) for r in rows if r["kind"] in ("nlid", "peer") and r.get("same_rule") and r.get("rule")}
    )
    declared = rows[0]["rule_declared"]
    return f"Rule: `{declared}`" + (f" — {'; '.join(texts)}" if texts else "")


def markdown_tables(protocols: Mapping[str, Protocol], rows: Sequence[Mapping[str, Any]], level: int = 3) -> list[str]:
    """Markdown: per benchmark a heading, per test set its rule and table, and the figures left out."""
    lines: list[str] = []
    hashes = "#" * level
    by_bench: dict[str, list] = {}
    for bench, test, group in _groups(rows):
        by_bench.setdefault(bench, []).append((test, group))
    for name, p in protocols.items():
        lines += [f"{hashes} {p.title}", ""]
        kind = (
            "the benchmark's split"
            if p.official
            else "**nlid's own protocol** (not an official split of the benchmark)"
        )
        lines += [f"Benchmark `{p.name}`: {kind}: {p.protocol}.", ""]
        lines += [f"Estimation: {p.estimation.description}.", ""]
        for test, group in by_bench.get(name, []):
            t = p.test(test)
            lines += [f"{hashes}# `{p.name}` — test `{test}`", ""]
            lines += [
                f"{t.source.description or test}. {_rule_line(group)}" + (f" ({t.rule_note})." if t.rule_note else "."),
                "",
            ]
            lines += table_markdown(group)
            lines.append("")
        if p.not_comparable:
            lines += ["Published figures not shown:", ""]
            lines += [f"- {_esc(n.what)}: {n.why}." for n in p.not_comparable]
            lines.append("")
    return lines


def _html_table(rows: Sequence[Mapping[str, Any]]) -> str:
    unit = rows[0]["unit"]
    head = ["", f"RMSE ({unit})", "NRMSE %", "fit %", "parameters", "time (s)", "model", "rule", "notes"]
    out = ["<table>", "<tr>" + "".join(f"<th>{html.escape(h)}</th>" for h in head) + "</tr>"]
    for r in rows:
        if r.get("status") == "not run":
            continue
        remark = _remark(r).replace("**", "")
        if r["kind"] == "published":
            remark = "; ".join(x for x in (remark, f"{r['method']}; checked in {r['source']}", r.get("note")) if x)
        cells = [
            _who(r).replace("`", ""),
            _num(r["rmse"]),
            _num(r["nrmse_percent"]),
            _num(r["fit_percent"]),
            _int(r["parameters"]),
            _seconds(r["seconds"]),
            r.get("model") or "",
            r.get("rule") or "",
            remark,
        ]
        cls = ' class="other-rule"' if not r.get("same_rule", True) else ""
        out.append(f"<tr{cls}>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in cells) + "</tr>")
    out.append("</table>")
    skipped = [r for r in rows if r.get("status") == "not run"]
    if skipped:
        names = ", ".join(str(r["pipeline"]) for r in skipped)
        out.append(f"<p>Not scored ({html.escape(names)}): {html.escape(str(skipped[0].get('note', '')))}</p>")
    return "\n".join(out)


def write_leaderboard(folder: Path, protocols: Mapping[str, Protocol], rows: Sequence[Mapping[str, Any]]) -> list[Path]:
    """Write ``leaderboard.csv``, ``leaderboard.md`` and ``leaderboard.html`` into ``folder``."""
    import pandas as pd

    frame = pd.DataFrame([{c: r.get(c) for c in COLUMNS} for r in rows], columns=list(COLUMNS))
    csv = folder / "leaderboard.csv"
    csv.write_text(frame.to_csv(index=False, float_format="%.6g"))
    md = folder / "leaderboard.md"
    md.write_text(
        "\n".join(["# nlid bench: leaderboard", "", *markdown_tables(protocols, rows, level=2)]).rstrip() + "\n"
    )
    parts = [
        "<!DOCTYPE html>",
        '<html><head><meta charset="utf-8"><title>nlid bench: leaderboard</title>',
        "<style>body{font-family:sans-serif;max-width:80em;margin:auto}table{border-collapse:collapse;margin:1em 0}"
        "td,th{border:1px solid #ccc;padding:3px 6px;text-align:left}tr.other-rule td{color:#777}</style>",
        "</head><body>",
        "<h1>nlid bench: leaderboard</h1>",
    ]
    for name, p in protocols.items():
        parts.append(f"<h2>{html.escape(p.title)}</h2>")
        parts.append(
            f"<p>Benchmark <code>{html.escape(p.name)}</code>: "
            f"{'the benchmark' + chr(39) + 's split' if p.official else '<b>nlid' + chr(39) + 's own protocol</b>'}: "
            f"{html.escape(p.protocol)}.</p>"
        )
        for bench, test, group in _groups(rows):
            if bench != name:
                continue
            t = p.test(test)
            parts.append(f"<h3>test <code>{html.escape(test)}</code></h3>")
            parts.append(
                f"<p>{html.escape(t.source.description or test)}. {html.escape(_rule_line(group).replace('`', ''))}</p>"
            )
            parts.append(_html_table(group))
        if p.not_comparable:
            parts.append("<p>Published figures not shown:</p><ul>")
            parts += [f"<li>{html.escape(n.what)}: {html.escape(n.why)}.</li>" for n in p.not_comparable]
            parts.append("</ul>")
    parts.append("</body></html>")
    page = folder / "leaderboard.html"
    page.write_text("\n".join(parts) + "\n")
    return [csv, md, page]


def read_leaderboard(path: str | Path) -> list[dict[str, Any]]:
    """Rows of a ``leaderboard.csv`` (types restored: numbers, booleans, empty notes)."""
    import pandas as pd

    frame = pd.read_csv(path, keep_default_na=False, na_values={"rmse": [""], "nrmse_percent": [""]})
    rows = []
    for rec in frame.to_dict("records"):
        r = {c: rec.get(c) for c in COLUMNS}
        for c in ("rmse", "nrmse_percent", "fit_percent", "seconds", "parameters", "scored_samples"):
            r[c] = _nan(r[c]) if r[c] not in ("", None) else math.nan
        for c in ("official", "same_rule"):
            r[c] = r[c] in (True, "True", "true", 1)
        rows.append(r)
    return rows
