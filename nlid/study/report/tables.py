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

from ..values import PresetSource

__all__ = ["Section", "Table", "build_sections", "summary_markdown", "summary_long", "fmt"]

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
    """``digits`` significant digits; an en dash for a missing value."""
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "–"
    return f"{x:.{digits}g}"


def cell(values: pd.Series, absolute: bool = False, digits: int = 3) -> str:
    """``median [min, max]`` of the finite values (true/false values: the fraction true)."""
    present = values.dropna()
    if len(present) and all(isinstance(v, (bool, np.bool_)) for v in present):
        return f"{fmt(float(np.mean(present.astype(bool))))} ({int(present.astype(bool).sum())} of {len(present)})"
    x = pd.to_numeric(values, errors="coerce").to_numpy(dtype=float)
    x = x[np.isfinite(x)]
    if absolute:
        x = np.abs(x)
    if x.size == 0:
        return "–"
    if x.size == 1:
        return fmt(float(x[0]), digits)
    return f"{fmt(float(np.median(x)), digits)} [{fmt(float(x.min()), digits)}, {fmt(float(x.max()), digits)}]"


@dataclass
class Table:
    """A titled table: header, rows of cells, notes below."""

    title: str
    header: list[str]
    rows: list[list[str]]
    notes: list[str] = field(default_factory=list)


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

    def terms_with(self, prefix: str) -> list[str]:
        """The section's terms, in model order, that have a ``<prefix><term>`` column."""
        return [t for t in self.terms if f"{prefix}{t}" in self.frame.columns]


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
    """Group the results by dataset and model and build their tables."""
    sections = []
    refs: dict[tuple[str, str], dict[str, Any]] = {}
    terms: dict[tuple[str, str], list[str]] = {}
    for rec in records:
        key = (rec["row"]["dataset"], rec["row"]["model"])
        if rec.get("reference") and key not in refs:
            refs[key] = rec["reference"]
        if rec.get("result") and key not in terms:
            terms[key] = rec["result"]["terms"]
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
                ds.name, model.name, what, terms.get(key, []), list(config.identifiers), sub, refs.get(key)
            )
            if not sub.empty:
                _fill(section)
            sections.append(section)
    return sections


def _method_rows(section: Section, columns: list[tuple[str, bool]], digits: int = 3) -> list[list[str]]:
    rows = []
    for method in section.methods:
        sub = section.frame[section.frame["method"] == method]
        if sub.empty:
            continue
        ok = sub[sub["status"] == "ok"]
        cells = [method, _runs_cell(sub)]
        for col, absolute in columns:
            cells.append(cell(ok[col], absolute, digits) if col in ok.columns else "–")
        rows.append(cells)
    return rows


def _fill(section: Section) -> None:
    frame, ref = section.frame, section.reference or {}
    ref_coefs = ref.get("coefficients") or {}
    err_terms = _labels(frame, "coef_error_pct:")
    order = {t: i for i, t in enumerate(section.terms)}
    err_terms.sort(key=lambda t: order.get(t, len(order)))
    if err_terms:
        cols = [(f"coef_error_pct:{t}", True) for t in err_terms]
        if "mass_error_pct" in frame.columns:
            cols.append(("mass_error_pct", True))
        header = ["method", "runs", *err_terms] + (["mass"] if "mass_error_pct" in frame.columns else [])
        reference_row = ["reference", "", *[fmt(ref_coefs.get(t)) for t in err_terms]]
        if "mass_error_pct" in frame.columns:
            reference_row.append(fmt(ref.get("mass")))
        section.tables.append(
            Table(
                "Coefficients: |relative error| in % (median [min, max] over repetitions)",
                header,
                [reference_row, *_method_rows(section, cols)],
            )
        )
    value_terms = section.terms_with("coef:")
    cols = [(f"coef:{t}", False) for t in value_terms]
    header = ["method", "runs", *value_terms]
    if frame.get("mass") is not None and pd.to_numeric(frame["mass"], errors="coerce").notna().any():
        cols.append(("mass", False))
        header.append("mass")
    section.tables.append(
        Table("Identified coefficients (SI, coefficients of R = f - m z'')", header, _method_rows(section, cols, 4))
    )

    eq_labels = _labels(frame, "eq_error_pct:")
    modal_labels = sorted(set(_labels(frame, "fn_hz:")) | set(eq_labels), key=lambda s: int(s[1:]))
    if modal_labels:
        ref_eq = ref.get("equilibria") or []
        ref_modal = ref.get("modal") or []
        cols: list[tuple[str, bool]] = []
        header = ["method", "runs"]
        reference_row = ["reference", ""]
        errors = bool(eq_labels)
        for label in modal_labels:
            k = int(label[1:]) - 1
            if errors:
                z_ref = ref_eq[k] if k < len(ref_eq) else None
                where = f" at {fmt(z_ref)} m" if z_ref is not None else ""
                m_ref = ref_modal[k] if k < len(ref_modal) else {}
                for col, name, value in (
                    (f"fn_error_pct:{label}", f"fn{where}", m_ref.get("fn_hz")),
                    (f"zeta_error_pct:{label}", f"zeta{where}", m_ref.get("zeta")),
                    (f"eq_error_pct:{label}", f"z*{where}", z_ref),
                ):
                    if col in frame.columns:
                        cols.append((col, True))
                        header.append(name)
                        reference_row.append(fmt(value))
            else:
                for col, name in ((f"fn_hz:{label}", f"fn {label} (Hz)"), (f"zeta:{label}", f"zeta {label}")):
                    if col in frame.columns:
                        cols.append((col, False))
                        header.append(name)
        rows = _method_rows(section, cols)
        if errors:
            for row, method in zip(rows, [m for m in section.methods if (frame["method"] == m).any()], strict=True):
                ok = frame[(frame["method"] == method) & (frame["status"] == "ok")]
                row.append(_found_cell(ok))
            header.append("stable equilibria found")
            reference_row.append(str(len(ref_eq)))
            title = "Modal parameters (Eq. 8, 22) and stable equilibria: |relative error| in %"
            section.tables.append(Table(title, header, [reference_row, *rows]))
        else:
            section.tables.append(Table("Modal parameters (Eq. 8, 22)", header, rows))

    _append_term_table(
        section,
        "quality:",
        "Quality indicator E[Re/Im] of each coefficient (NSI, paper Table 5; methods that report one)",
        drop_empty=True,
    )
    posterior = _posterior_table(section)
    if posterior is not None:
        section.tables.append(posterior)
    _append_term_table(
        section, "rms:", "RMS contribution of each term to the identified restoring force, N (paper Fig. 22)"
    )

    cols = [("eps_percent", False)]
    header = ["method", "runs", "eps (Eq. 26) %"]
    if "eps_holdout_percent" in frame.columns:
        cols.append(("eps_holdout_percent", False))
        header.append("eps held-out %")
    if "freerun_nrmse_pct" in frame.columns:
        cols.append(("freerun_nrmse_pct", False))
        header.append("free-run NRMSE %")
    cols += [("seconds", False), ("peak_memory_mb", False)]
    header += ["time (s)", "peak memory (MB)"]
    notes = []
    if "freerun_note" in frame.columns:
        for method in section.methods:
            ok = frame[(frame["method"] == method) & (frame["status"] == "ok")]
            skipped = ok["freerun_note"].dropna()
            skipped = skipped[skipped != ""]
            if len(skipped):
                notes.append(f"{method}: free run {skipped.iloc[0]} ({len(skipped)} of {len(ok)} runs)")
    section.tables.append(Table("Residuals, simulation error and cost", header, _method_rows(section, cols), notes))

    other = [
        c
        for c in frame.columns
        if c not in _KNOWN and not c.startswith(_KNOWN_PREFIXES) and not frame[c].dropna().empty
    ]
    if other:
        cols = [(c, False) for c in other]
        section.tables.append(
            Table(
                "Other metrics (median [min, max]; true/false as the fraction true)",
                ["method", "runs", *other],
                _method_rows(section, cols),
            )
        )

    for _, row in frame[frame["status"] != "ok"].iterrows():
        section.failures.append(f"{row['method']} r{row['repetition']}: {row['status']}: {row['error']}")


def _append_term_table(section: Section, prefix: str, title: str, drop_empty: bool = False) -> None:
    """Method x term table of the ``<prefix><term>`` columns, when there are any.

    ``drop_empty`` leaves out the methods without a value (e.g. those that report no quality indicator).
    """
    terms = section.terms_with(prefix)
    if not terms:
        return
    rows = _method_rows(section, [(f"{prefix}{t}", False) for t in terms])
    if drop_empty:
        rows = [r for r in rows if _has_values(r)]
    section.tables.append(Table(title, ["method", "runs", *terms], rows))


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
            lo = pd.to_numeric(ok[f"ci_lo:{t}"], errors="coerce").dropna()
            hi = pd.to_numeric(ok[f"ci_hi:{t}"], errors="coerce").dropna()
            text = f"[{fmt(float(lo.median()), 4)}, {fmt(float(hi.median()), 4)}]"
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


def summary_markdown(config: Any, sections: list[Section]) -> str:
    """The summary as Markdown."""
    lines = [f"# Study {config.name}", ""]
    if config.description:
        lines += [config.description, ""]
    for section in sections:
        lines += [f"## {section.dataset} / {section.model}", ""]
        lines += [_md_escape(section.description) + (f"; terms: {', '.join(section.terms)}" if section.terms else "")]
        lines.append("")
        if section.frame.empty:
            lines += ["No finished runs yet.", ""]
            continue
        for table in section.tables:
            lines += [f"### {table.title}", ""]
            lines.append("| " + " | ".join(_md_escape(h) for h in table.header) + " |")
            lines.append("|" + "|".join(" --- " for _ in table.header) + "|")
            for row in table.rows:
                lines.append("| " + " | ".join(_md_escape(c) for c in row) + " |")
            lines.append("")
            for note in table.notes:
                lines += [f"- {_md_escape(note)}"]
            if table.notes:
                lines.append("")
        if section.failures:
            lines += ["Failed runs:", ""] + [f"- {_md_escape(f)}" for f in section.failures] + [""]
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
