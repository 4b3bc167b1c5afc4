"""Summary tables: method x metric, median and spread over repetitions.

Every cell is ``median [min, max]`` over the repetitions that succeeded
(just the value when there is one). Error columns show absolute relative
errors in percent, as the paper's Tables 2, 4 and 7 do; the reference value
of each column is given in the first row.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from ...errors import NlidError
from ...formatting import MISSING, TERMINAL_WIDTH, column_digits, sig, spread_cell, text_table, wrap
from ...terms import parse_term
from ..values import PresetSource

__all__ = [
    "Column",
    "Section",
    "Stats",
    "Table",
    "build_sections",
    "cell",
    "exact",
    "fmt",
    "selection",
    "stats",
    "summary_long",
    "summary_markdown",
    "summary_text",
]

_KNOWN_PREFIXES = (
    "rms:",
    "quality:",
    "ci_lo:",
    "ci_hi:",
    "ci_width:",
    "ci_covers:",
    "posterior:",
    "coef:",
    "coef_error_pct:",
    "eq:",
    "eq_error_pct:",
    "fn_hz:",
    "fn_error_pct:",
    "zeta:",
    "zeta_error_pct:",
)
_KNOWN = {
    "run_id",
    "dataset",
    "model",
    "method",
    "repetition",
    "seed",
    "status",
    "error",
    "seconds",
    "peak_memory_mb",
    "method_seconds",
    "samples",
    "z_min",
    "z_max",
    "eps_percent",
    "force_residual_percent",
    "eps_holdout_percent",
    "warnings",
    "mass",
    "mass_error_pct",
    "eq_found",
    "eq_expected",
    "eq_missing",
    "eq_error_max_pct",
    "freerun_nrmse_pct",
    "freerun_rmse",
    "freerun_note",
}


def fmt(x: float | None, digits: int = 3) -> str:
    """``digits`` significant digits (:func:`nlid.formatting.sig`); an en dash for a missing value."""
    return sig(x, digits)


def exact(x: float | None, max_digits: int = 6) -> str:
    """The shortest text of ``x`` with at most ``max_digits`` significant digits (for reference values)."""
    if x is None or not math.isfinite(x):
        return MISSING
    for digits in range(1, max_digits + 1):
        text = sig(x, digits)
        if math.isclose(float(text), x, rel_tol=0.5 * 10 ** -(max_digits - 1)):
            return text
    return sig(x, max_digits)


@dataclass(frozen=True)
class Stats:
    """Median, minimum and maximum of a cell over the repetitions (``n`` values)."""

    median: float
    lo: float
    hi: float
    n: int

    @property
    def triple(self) -> tuple[float, float, float]:
        """``(median, min, max)``."""
        return self.median, self.lo, self.hi


def stats(values: pd.Series | np.ndarray | list, absolute: bool = False) -> Stats | None:
    """The :class:`Stats` of the finite values (``None`` when there is none)."""
    x = pd.to_numeric(pd.Series(values), errors="coerce").to_numpy(dtype=float)
    x = x[np.isfinite(x)]
    if absolute:
        x = np.abs(x)
    if x.size == 0:
        return None
    return Stats(float(np.median(x)), float(x.min()), float(x.max()), int(x.size))


def _is_flags(values: pd.Series) -> bool:
    present = values.dropna()
    return bool(len(present)) and all(isinstance(v, (bool, np.bool_)) for v in present)


def _flags_cell(values: pd.Series) -> str:
    present = values.dropna().astype(bool)
    return f"{sig(float(np.mean(present)), 2)} ({int(present.sum())} of {len(present)})"


def cell(values: pd.Series, absolute: bool = False, digits: int | None = None) -> str:
    """``median [min, max]`` of the finite values (true/false values: the fraction true).

    ``digits`` defaults to what the spread needs (:func:`nlid.formatting.spread_digits`).
    """
    if _is_flags(values):
        return _flags_cell(values)
    st = stats(values, absolute)
    if st is None:
        return MISSING
    if digits is None:
        digits = column_digits([st.triple])
    return spread_cell(*st.triple, digits=digits) if st.n > 1 else sig(st.median, digits)


#: Significant digits of time and memory (machine measurements: their spread is the machine's load).
COST_DIGITS = 3


@dataclass(frozen=True)
class Column:
    """A metric column of a method table: results column, header, absolute value?, lower is better?"""

    key: str
    header: str
    absolute: bool = False
    lower_better: bool = False
    digits: int | None = None  # fixed significant digits (default: from the spread)


@dataclass
class Table:
    """A titled table: header, rows of cells, notes below; ``best`` cells are highlighted."""

    title: str
    header: list[str]
    rows: list[list[str]]
    notes: list[str] = field(default_factory=list)
    best: set[tuple[int, int]] = field(default_factory=set)
    caption: str = ""


@dataclass
class Section:
    """One dataset x model of a study."""

    dataset: str
    model: str
    description: str
    terms: list[str]
    methods: list[str]
    frame: pd.DataFrame
    reference: dict[str, Any] | None
    tables: list[Table] = field(default_factory=list)
    failures: list[str] = field(default_factory=list)
    units: dict[str, str] = field(default_factory=dict)
    diagnostics: dict[str, list[dict[str, Any]]] = field(default_factory=dict)
    verdict: Any = None

    def terms_with(self, prefix: str) -> list[str]:
        """The section's terms, in model order, that have a ``<prefix><term>`` column."""
        return [t for t in self.terms if f"{prefix}{t}" in self.frame.columns]

    @property
    def present_methods(self) -> list[str]:
        """The methods with at least one run in this section, in study order."""
        if self.frame.empty:
            return []
        return [m for m in self.methods if (self.frame["method"] == m).any()]

    def ok(self, method: str) -> pd.DataFrame:
        """The successful runs of ``method``."""
        f = self.frame
        return f[(f["method"] == method) & (f["status"] == "ok")]

    def unit(self, term: str) -> str:
        """SI unit of a term's coefficient (from the results; computed from the term otherwise)."""
        if term in self.units:
            return self.units[term]
        try:
            return parse_term(term).coefficient_unit
        except NlidError:
            return ""


def _labels(frame: pd.DataFrame, prefix: str) -> list[str]:
    return [c[len(prefix) :] for c in frame.columns if c.startswith(prefix)]


def _runs_cell(sub: pd.DataFrame) -> str:
    n = len(sub)
    ok = int((sub["status"] == "ok").sum())
    text = f"{ok}/{n}"
    timeouts = int((sub["status"] == "timeout").sum())
    failed = n - ok - timeouts
    extra = [f"{failed} failed"] * bool(failed) + [f"{timeouts} timed out"] * bool(timeouts)
    return text + (f" ({', '.join(extra)})" if extra else "")


def build_sections(config: Any, frame: pd.DataFrame, records: list[dict[str, Any]]) -> list[Section]:
    """Group the results by dataset and model, build their tables and their verdict."""
    from .verdict import build_verdict

    sections = []
    refs: dict[tuple[str, str], dict[str, Any]] = {}
    terms: dict[tuple[str, str], list[str]] = {}
    units: dict[tuple[str, str], dict[str, str]] = {}
    diagnostics: dict[tuple[str, str], dict[str, list[dict[str, Any]]]] = {}
    for rec in records:
        key = (rec["row"]["dataset"], rec["row"]["model"])
        if rec.get("reference") and key not in refs:
            refs[key] = rec["reference"]
        result = rec.get("result")
        if result:
            terms.setdefault(key, result["terms"])
            units.setdefault(key, {}).update(result.get("units") or {})
            diag = dict(result.get("diagnostics") or {})
            diag["_repetition"] = rec["row"].get("repetition")
            diag["_model_terms"] = list(result["terms"])
            diag["_warnings"] = list(result.get("warnings") or [])
            diagnostics.setdefault(key, {}).setdefault(rec["row"]["method"], []).append(diag)
    for ds in config.datasets:
        for model in ds.models:
            key = (ds.name, model.name)
            if frame.empty:
                sub = frame
            else:
                sub = frame[(frame["dataset"] == ds.name) & (frame["model"] == model.name)].dropna(axis=1, how="all")
            src = ds.source
            what = ds.description or f"{ds.kind} {ds.to_dict()['source']}"
            if isinstance(src, PresetSource):
                levels = dict(src.noise) if isinstance(src.noise, Mapping) else {c: src.noise for c in src.channels}
                noise = ", ".join(f"{c} {100 * x:g} %" for c, x in levels.items()) or "none"
                what += f" (noise: {noise}; recorded: {', '.join(src.channels)}; {ds.repetitions} repetitions)"
            section = Section(
                ds.name,
                model.name,
                what,
                terms.get(key, []),
                list(config.identifiers),
                sub,
                refs.get(key),
                units=units.get(key, {}),
                diagnostics=diagnostics.get(key, {}),
            )
            if not sub.empty:
                _fill(section)
                section.verdict = build_verdict(section)
            sections.append(section)
    return sections


def _method_rows(section: Section, columns: list[Column], digits: int | None = None) -> tuple[list[list[str]], set]:
    """One row per method with runs: ``[method, runs, cells...]``, and the best cells ``{(row, column)}``.

    Every column has one count of significant digits, chosen from the spread of its cells
    (:func:`nlid.formatting.column_digits`) unless ``digits`` is given; in a lower-is-better
    column the cells with the lowest median are the best.
    """
    methods = section.present_methods
    table: dict[str, list[Stats | str | None]] = {}
    for method in methods:
        ok = section.ok(method)
        cells: list[Stats | str | None] = []
        for col in columns:
            if col.key not in ok.columns:
                cells.append(None)
            elif _is_flags(ok[col.key]):
                cells.append(_flags_cell(ok[col.key]))
            else:
                cells.append(stats(ok[col.key], col.absolute))
        table[method] = cells
    rows = [[m, _runs_cell(section.frame[section.frame["method"] == m])] for m in methods]
    best: set[tuple[int, int]] = set()
    for j, col in enumerate(columns):
        numeric = {m: table[m][j] for m in methods if isinstance(table[m][j], Stats)}
        d = col.digits or digits or column_digits([st.triple for st in numeric.values()])
        for i, m in enumerate(methods):
            value = table[m][j]
            if isinstance(value, Stats):
                text = spread_cell(*value.triple, digits=d) if value.n > 1 else sig(value.median, d)
            else:
                text = value if isinstance(value, str) else MISSING
            rows[i].append(text)
        if col.lower_better and len(numeric) > 1:
            lowest = min(st.median for st in numeric.values())
            for i, m in enumerate(methods):
                st = numeric.get(m)
                if st is not None and st.median == lowest:
                    best.add((i, j + 2))
    return rows, best


def _offset(best: set[tuple[int, int]], rows: int) -> set[tuple[int, int]]:
    """Best-cell positions after ``rows`` rows were put above."""
    return {(i + rows, j) for i, j in best}


def _reference_table(section: Section) -> Table | None:
    """The reference values the error tables are relative to (SI), one per line."""
    ref = section.reference or {}
    rows: list[list[str]] = []
    for term in section.terms:
        value = (ref.get("coefficients") or {}).get(term)
        if value is not None and f"coef:{term}" in section.frame.columns:
            rows.append([f"coefficient of {term}", exact(value), section.unit(term)])
    if ref.get("mass") is not None and "mass_error_pct" in section.frame.columns:
        rows.append(["mass", exact(ref["mass"]), "kg"])
    modal = ref.get("modal") or []
    for k, z in enumerate(ref.get("equilibria") or []):
        rows.append([f"s{k + 1}: stable equilibrium", exact(z, 4), "m"])
        if k < len(modal):
            rows.append([f"s{k + 1}: natural frequency fn", exact(modal[k]["fn_hz"], 4), "Hz"])
            rows.append([f"s{k + 1}: damping ratio zeta", exact(100 * modal[k]["zeta"], 3), "%"])
    if not rows:
        return None
    return Table("Reference values (the truth the errors are relative to)", ["quantity", "value", "unit"], rows)


def _fill(section: Section) -> None:
    frame, ref = section.frame, section.reference or {}
    ref_coefs = ref.get("coefficients") or {}
    reference = _reference_table(section)
    if reference is not None:
        section.tables.append(reference)
    err_terms = _labels(frame, "coef_error_pct:")
    order = {t: i for i, t in enumerate(section.terms)}
    err_terms.sort(key=lambda t: order.get(t, len(order)))
    if err_terms:
        cols = [Column(f"coef_error_pct:{t}", f"{t} (%)", True, True) for t in err_terms]
        if "mass_error_pct" in frame.columns:
            cols.append(Column("mass_error_pct", "mass (%)", True, True))
        rows, best = _method_rows(section, cols)
        section.tables.append(
            Table(
                "Coefficients: |relative error| in % (median [min, max] over repetitions)",
                ["method", "runs", *(c.header for c in cols)],
                rows,
                best=best,
            )
        )
    value_terms = section.terms_with("coef:")
    cols = [Column(f"coef:{t}", f"{t} ({section.unit(t)})") for t in value_terms]
    has_mass = frame.get("mass") is not None and pd.to_numeric(frame["mass"], errors="coerce").notna().any()
    if has_mass:
        cols.append(Column("mass", "mass (kg)"))
    rows, _ = _method_rows(section, cols)
    if ref_coefs:
        reference_row = ["reference", "", *(exact(ref_coefs.get(t)) for t in value_terms)]
        if has_mass:
            reference_row.append(exact(ref.get("mass")))
        rows = [reference_row, *rows]
    section.tables.append(
        Table(
            "Identified coefficients (SI, coefficients of R = f - m z'')",
            ["method", "runs", *(c.header for c in cols)],
            rows,
        )
    )

    eq_labels = _labels(frame, "eq_error_pct:")
    modal_labels = sorted(set(_labels(frame, "fn_hz:")) | set(eq_labels), key=lambda s: int(s[1:]))
    if modal_labels:
        errors = bool(eq_labels)
        cols = []
        for label in modal_labels:
            if errors:
                for key, name in (
                    (f"fn_error_pct:{label}", f"fn {label} (%)"),
                    (f"zeta_error_pct:{label}", f"zeta {label} (%)"),
                    (f"eq_error_pct:{label}", f"z* {label} (%)"),
                ):
                    if key in frame.columns:
                        cols.append(Column(key, name, True, True))
            else:
                for key, name in ((f"fn_hz:{label}", f"fn {label} (Hz)"), (f"zeta:{label}", f"zeta {label}")):
                    if key in frame.columns:
                        cols.append(Column(key, name))
        rows, best = _method_rows(section, cols)
        if errors:
            for row, method in zip(rows, section.present_methods, strict=True):
                row.append(_found_cell(section.ok(method)))
            header = [
                "method",
                "runs",
                *(c.header for c in cols),
                f"wells found (of {len(ref.get('equilibria') or [])})",
            ]
            title = (
                "Modal parameters (Eq. 8, 22) and stable equilibria sK (see the reference values): "
                "|relative error| in %"
            )
            section.tables.append(Table(title, header, rows, best=best))
        else:
            section.tables.append(
                Table("Modal parameters (Eq. 8, 22)", ["method", "runs", *(c.header for c in cols)], rows)
            )

    _append_term_table(
        section,
        "quality:",
        "Quality indicator E[Re/Im] of each coefficient (NSI, paper Table 5; methods that report one)",
        drop_empty=True,
    )
    posterior = _posterior_table(section)
    if posterior is not None:
        section.tables.append(posterior)
    selection = _selection_table(section)
    if selection is not None:
        section.tables.append(selection)
    _append_term_table(
        section, "rms:", "RMS contribution of each term to the identified restoring force, N (paper Fig. 22)", unit="N"
    )

    cols = [Column("eps_percent", "eps (%)", False, True)]
    if "eps_holdout_percent" in frame.columns:
        cols.append(Column("eps_holdout_percent", "eps held-out (%)", False, True))
    if "freerun_nrmse_pct" in frame.columns:
        cols.append(Column("freerun_nrmse_pct", "free-run NRMSE (%)", False, True))
    # cost columns measure the machine, not the method's result: three digits, whatever the spread
    cols += [
        Column("seconds", "time (s)", False, True, digits=COST_DIGITS),
        Column("peak_memory_mb", "memory (MB)", False, True, digits=COST_DIGITS),
    ]
    notes = []
    if "freerun_note" in frame.columns:
        for method in section.methods:
            ok = section.ok(method) if not frame.empty else frame
            skipped = ok["freerun_note"].dropna() if "freerun_note" in ok else pd.Series(dtype=str)
            skipped = skipped[skipped != ""]
            if len(skipped):
                notes.append(f"{method}: free run {skipped.iloc[0]} ({len(skipped)} of {len(ok)} runs)")
    rows, best = _method_rows(section, cols)
    section.tables.append(
        Table(
            "Residuals (eps: Eq. 26), simulation error and cost",
            ["method", "runs", *(c.header for c in cols)],
            rows,
            notes,
            best=best,
        )
    )

    other = [
        c
        for c in frame.columns
        if c not in _KNOWN and not c.startswith(_KNOWN_PREFIXES) and not frame[c].dropna().empty
    ]
    if other:
        cols = [Column(c, c) for c in other]
        rows, _ = _method_rows(section, cols)
        section.tables.append(
            Table(
                "Other metrics (median [min, max]; true/false as the fraction true)",
                ["method", "runs", *other],
                rows,
            )
        )

    for _, row in frame[frame["status"] != "ok"].iterrows():
        section.failures.append(f"{row['method']} r{row['repetition']}: {row['status']}: {row['error']}")


def _append_term_table(section: Section, prefix: str, title: str, drop_empty: bool = False, unit: str = "") -> None:
    """Method x term table of the ``<prefix><term>`` columns, when there are any.

    ``drop_empty`` leaves out the methods without a value (e.g. those that report no quality indicator).
    """
    terms = section.terms_with(prefix)
    if not terms:
        return
    rows, _ = _method_rows(section, [Column(f"{prefix}{t}", t) for t in terms])
    if drop_empty:
        rows = [r for r in rows if _has_values(r)]
    header = [f"{t} ({unit})" if unit else t for t in terms]
    section.tables.append(Table(title, ["method", "runs", *header], rows))


def selection(section: Section) -> dict[str, dict[str, Any]]:
    """Terms kept by methods that select their terms (``diagnostics["kept_terms"]``), per method.

    Returns
    -------
    dict
        ``{method: {"library": [terms], "runs": n, "kept": {term: runs that kept it}}}`` for every
        method whose runs report a candidate library larger than the model.
    """
    out: dict[str, dict[str, Any]] = {}
    for method in section.present_methods:
        diags = [d for d in section.diagnostics.get(method, []) if isinstance(d.get("kept_terms"), list)]
        if not diags:
            continue
        library: list[str] = []
        for d in diags:
            for t in d.get("library") or d["kept_terms"]:
                if t not in library:
                    library.append(t)
        kept = {t: sum(t in d["kept_terms"] for d in diags) for t in library}
        out[method] = {"library": library, "runs": len(diags), "kept": kept}
    return out


def _selection_table(section: Section) -> Table | None:
    """Inclusion frequency of every candidate term of the methods that select terms (SINDy)."""
    chosen = selection(section)
    if not chosen:
        return None
    methods = list(chosen)
    terms: list[str] = []
    for info in chosen.values():
        terms += [t for t in info["library"] if t not in terms]
    model = set(section.terms)
    rows = []
    for t in terms:
        row = [t, "yes" if t in model else "no"]
        for m in methods:
            info = chosen[m]
            row.append(f"{info['kept'][t]}/{info['runs']}" if t in info["kept"] else MISSING)
        rows.append(row)
    sizes = ", ".join(f"{m}: {len(chosen[m]['library'])} candidates" for m in methods)
    return Table(
        "Term selection: how many repetitions kept each candidate term (inclusion frequency)",
        ["candidate term", "in the model", *(f"{m} kept" for m in methods)],
        rows,
        notes=[
            f"{sizes}; a term in the model that a method did not keep has coefficient 0 in its results; "
            "kept terms outside the model are reported by the method, not added to the model"
        ],
    )


def _posterior_table(section: Section) -> Table | None:
    """Credible intervals of the posterior hook (``ci_*`` columns), coverage of the truth, tau and time."""
    frame = section.frame
    terms = section.terms_with("ci_lo:")
    if not terms:
        return None
    levels = pd.to_numeric(frame.get("posterior:level", pd.Series(dtype=float)), errors="coerce").dropna()
    level = f"{100 * levels.iloc[0]:g} %" if len(levels) else "credible"
    rows = []
    for method in section.methods:
        sub = frame[frame["method"] == method]
        ok = sub[sub["status"] == "ok"]
        if ok.empty or ok[f"ci_lo:{terms[0]}"].dropna().empty:
            continue
        cells = [method, _runs_cell(sub)]
        for t in terms:
            lo = float(pd.to_numeric(ok[f"ci_lo:{t}"], errors="coerce").dropna().median())
            hi = float(pd.to_numeric(ok[f"ci_hi:{t}"], errors="coerce").dropna().median())
            d = column_digits([(0.5 * (lo + hi), lo, hi)])
            text = f"[{sig(lo, d)}, {sig(hi, d)}]"
            if f"ci_covers:{t}" in ok.columns:
                covers = ok[f"ci_covers:{t}"].dropna().astype(bool)
                if len(covers):
                    text += f" covers {int(covers.sum())}/{len(covers)}"
            cells.append(text)
        for col in ("posterior:tau", "posterior:seconds"):
            cells.append(cell(ok[col]) if col in ok.columns else "–")
        rows.append(cells)
    if not rows:
        return None
    title = (
        f"Posterior (emcee): {level} credible interval of each coefficient (median of each bound over the runs) "
        "and how many runs' intervals cover the reference"
    )
    return Table(title, ["method", "runs", *terms, "tau (steps)", "time (s)"], rows)


def _has_values(row: list[str]) -> bool:
    """False for a table row whose value cells are all empty."""
    return any(c not in ("", "–") for c in row[2:])


def _found_cell(ok: pd.DataFrame) -> str:
    if ok.empty or "eq_found" not in ok.columns:
        return "–"
    found = pd.to_numeric(ok["eq_found"], errors="coerce").dropna().astype(int)
    lo, hi = int(found.min()), int(found.max())
    return f"{lo}" if lo == hi else f"{lo}–{hi}"


# --------------------------------------------------------------------------- output
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
        "**bold**: the best (lowest) median of an error or cost column.",
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
            "Tables: median [min, max] over repetitions; * = best (lowest) median of an error or cost column.",
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


_NUMERIC = re.compile(r"^(coef|coef_error_pct|eq|eq_error_pct|fn_hz|fn_error_pct|zeta|zeta_error_pct):")


def summary_long(frame: pd.DataFrame) -> pd.DataFrame:
    """Long-format summary: dataset, model, method, metric, n, median, min, max (signed values)."""
    if frame.empty:
        return pd.DataFrame(columns=["dataset", "model", "method", "metric", "n", "median", "min", "max"])
    ok = frame[frame["status"] == "ok"]
    skip = {"repetition", "seed", "samples", "z_min", "z_max"}
    metrics = [
        c
        for c in ok.columns
        if c not in skip and c not in ("run_id", "dataset", "model", "method", "status", "error", "warnings")
    ]
    out = []
    for (ds, model, method), sub in ok.groupby(["dataset", "model", "method"], sort=False):
        for col in metrics:
            x = pd.to_numeric(sub[col], errors="coerce").to_numpy(dtype=float)
            x = x[np.isfinite(x)]
            if x.size:
                out.append([ds, model, method, col, x.size, np.median(x), x.min(), x.max()])
    return pd.DataFrame(out, columns=["dataset", "model", "method", "metric", "n", "median", "min", "max"])
