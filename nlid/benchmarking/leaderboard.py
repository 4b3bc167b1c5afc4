"""The leaderboard: nlid's rows beside the peers', the published ones and the true model, per test set.

:func:`leaderboard_rows` turns the stored jobs and the benchmark files into rows (one table per
benchmark and test set); :func:`write_leaderboard` writes them as ``leaderboard.csv`` (every row,
the columns of :data:`COLUMNS`), ``leaderboard.md`` (:func:`markdown_tables`), a self-contained
``leaderboard.html`` (styled, sortable: :mod:`nlid.benchmarking.board_html`) and a figure per test
set (``figures/BENCHMARK--TEST.png`` and ``.svg``: :mod:`nlid.benchmarking.board_figures`).

Every table says its transient rule once, above it; every row says what it knew (its prior
knowledge, :mod:`nlid.benchmarking.prior`) as badges, explained once under the table. RMSE is in
the benchmark's unit; NRMSE = RMSE / std(z over the scored samples) in %; fit % is MATLAB
``compare``'s ``100 (1 - |z - z_sim| / |z - mean z|)``.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from .board_rows import (
    KINDS,
    UNSCORED,
    badges,
    figure_name,
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
from .board_rows import value as _nan
from .declarations import Protocol
from .prior import Prior

__all__ = [
    "COLUMNS",
    "leaderboard_rows",
    "write_leaderboard",
    "markdown_tables",
    "table_markdown",
    "read_leaderboard",
]

#: The leaderboard's columns, in order.
COLUMNS = (
    "benchmark",
    "official",
    "test",
    "rule_declared",
    "kind",
    "pipeline",
    "method",
    "prior",
    "prior_mass",
    "prior_structure",
    "prior_shape",
    "prior_detail",
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
    "extrapolation",
)


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
            out["same_rule"] = r.get("status") in UNSCORED or r.get("rule_applied") == r.get("rule_declared")
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
                        **Prior("none", pub.structure, "none", f"published {pub.year}").to_row(),
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
            KINDS.index(r["kind"]) if r["kind"] in KINDS else 9,
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
        prior="",
    )
    row.update(values)
    return row


# --------------------------------------------------------------------------- Markdown
def _esc(text: str) -> str:
    return str(text).replace("|", "\\|")


def _md_who(r: Mapping[str, Any], cited: Sequence[tuple[str, str, str]]) -> str:
    kind = r["kind"]
    if kind == "nlid":
        return f"**nlid** `{r['pipeline']}`"
    if kind == "peer":
        return f"peer `{r['pipeline']}`"
    if kind == "truth":
        return "*true model*"
    if kind == "reference":
        return f"*{r['pipeline']}*"
    mark = f" [{list(cited).index(source_of(r)) + 1}]" if source_of(r) in cited else ""
    return f"published: {r['pipeline']}{mark}"


def table_markdown(rows: Sequence[Mapping[str, Any]]) -> list[str]:
    """The Markdown table of one benchmark and test set, its legend, what was not scored and the sources."""
    unit = rows[0]["unit"]
    shown = scored(rows)
    cited = sources(shown)
    lines = [
        f"| # | row | knew | RMSE ({unit}) | NRMSE % | fit % | parameters | time (s) | notes |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for rank, r in zip(ranks(shown), shown, strict=True):
        knew = " · ".join(badges(r)) or "-"
        rmse = num(r["rmse"])
        lines.append(
            f"| {rank} | {_esc(_md_who(r, cited))} | {knew} | {rmse} | {num(r['nrmse_percent'])} "
            f"| {num(r['fit_percent'])} | {integer(r['parameters'])} | {seconds(r['seconds'])} "
            f"| {_esc(remark(r)).replace('other rule:', '**other rule**:')} |"
        )
    used = legend(shown)
    if used:
        lines += ["", "Knew: " + "; ".join(f"**{b}**: {text}" for b, text in used) + "."]
    missing = unscored(rows)
    by_note: dict[str, list[str]] = {}
    for r in missing:
        by_note.setdefault(str(r.get("note", "")), []).append(f"`{r['pipeline']}`")
    for note, names in by_note.items():
        lines += ["", f"Not scored ({', '.join(names)}): {note}"]
    for i, (paper, where, status) in enumerate(cited, 1):
        lines += ["", f"[{i}] {paper}; checked in {where} ({status})."]
    return lines


def _models(rows: Sequence[Mapping[str, Any]]) -> list[str]:
    """One line per fitted pipeline of a benchmark: its model and what it was given."""
    seen: dict[str, Mapping[str, Any]] = {}
    for r in rows:
        if r["kind"] in ("nlid", "peer", "truth") and r.get("status") not in UNSCORED and r.get("model"):
            seen.setdefault(who(r), r)
    out = []
    for name, r in seen.items():
        detail = f" ({r['prior_detail']})" if r.get("prior_detail") and r["kind"] != "truth" else ""
        out.append(f"- {name}: {_esc(str(r['model']))}{_esc(detail)}")
    return out


def markdown_tables(
    protocols: Mapping[str, Protocol],
    rows: Sequence[Mapping[str, Any]],
    level: int = 3,
    figures: str | None = None,
    models: bool = True,
) -> list[str]:
    """Markdown: per benchmark a heading, per test set its rule, figure and table, the models, the figures left out.

    ``figures`` is the folder (relative to the Markdown file) of the test sets' figures; ``None``: no figures.
    ``models``: list the model behind each row once per benchmark.
    """
    lines: list[str] = []
    hashes = "#" * level
    by_bench: dict[str, list] = {}
    for bench, test, group in groups(rows):
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
            lines += [f"{t.source.description or test}.", ""]
            lines += [f"Rule {rule_text(group)}" + (f" ({t.rule_note})." if t.rule_note else "."), ""]
            beyond = range_note(group)
            if beyond:
                lines += [f"Range: {beyond}.", ""]
            if figures is not None and any(not math.isnan(_nan(r["rmse"])) for r in group):
                lines += [f"![RMSE of every row, log axis]({figures}/{figure_name(p.name, test)}.png)", ""]
            lines += table_markdown(group)
            lines.append("")
        behind = _models([r for _, g in by_bench.get(name, []) for r in g]) if models else []
        if behind:
            lines += ["Models behind the rows (fitted on the estimation part):", "", *behind, ""]
        if p.not_comparable:
            lines += ["Published figures not shown:", ""]
            lines += [f"- {_esc(n.what)}: {n.why}." for n in p.not_comparable]
            lines.append("")
    return lines


# --------------------------------------------------------------------------- files
def write_leaderboard(folder: Path, protocols: Mapping[str, Protocol], rows: Sequence[Mapping[str, Any]]) -> list[Path]:
    """Write ``leaderboard.csv``, ``leaderboard.md``, ``leaderboard.html`` and ``figures/`` into ``folder``."""
    import pandas as pd

    from .board_figures import write_figures
    from .board_html import leaderboard_html

    frame = pd.DataFrame([{c: r.get(c) for c in COLUMNS} for r in rows], columns=list(COLUMNS))
    csv = folder / "leaderboard.csv"
    csv.write_text(frame.to_csv(index=False, float_format="%.6g"))
    svgs = write_figures(folder / "figures", protocols, rows)
    md = folder / "leaderboard.md"
    md.write_text(
        "\n".join(
            ["# nlid bench: leaderboard", "", *markdown_tables(protocols, rows, level=2, figures="figures")]
        ).rstrip()
        + "\n"
    )
    page = folder / "leaderboard.html"
    page.write_text(leaderboard_html(protocols, rows, svgs))
    return [csv, md, page]


def read_leaderboard(path: str | Path) -> list[dict[str, Any]]:
    """Rows of a ``leaderboard.csv`` (types restored: numbers, booleans, empty notes)."""
    import pandas as pd

    frame = pd.read_csv(path, keep_default_na=False, na_values={"rmse": [""], "nrmse_percent": [""]})
    rows = []
    for rec in frame.to_dict("records"):
        r = {c: rec.get(c, "") for c in COLUMNS}
        for c in ("rmse", "nrmse_percent", "fit_percent", "seconds", "parameters", "scored_samples"):
            r[c] = _nan(r[c]) if r[c] not in ("", None) else math.nan
        for c in ("official", "same_rule"):
            r[c] = r[c] in (True, "True", "true", 1)
        rows.append(r)
    return rows
