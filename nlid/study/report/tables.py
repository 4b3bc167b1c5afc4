"""Summary tables: method x metric, median and spread over repetitions.

Every cell is ``median [min, max]`` over the repetitions that succeeded
(just the value when there is one). Error columns show absolute relative
errors in percent, as the paper's Tables 2, 4 and 7 do; the reference value
of each column is given in the first row.

Each table reads the declared column families (:mod:`nlid.study.columns`):
a scalar family declared with a table section (e.g. the residual and cost
table) is shown there without code here; a column of no declared family is
shown under "Other metrics". The pieces of a section live in
:mod:`.section`, the text outputs in :mod:`.render` (both re-exported here).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import pandas as pd

from ...base.formatting import MISSING, column_digits, sig
from ...identified.compared import equilibrium_label
from .. import columns as col
from ..values import PresetSource
from .section import Column, Section, Table, cell, exact, has_values, method_rows, runs_cell
from .verdict import build_verdict

__all__ = [
    "build_sections",
    "selection",
]

_DATASET, _MODEL, _METHOD = col.DATASET.key(), col.MODEL.key(), col.METHOD.key()
_STATUS, _REPETITION, _ERROR = col.STATUS.key(), col.REPETITION.key(), col.ERROR.key()


def build_sections(config: Any, frame: pd.DataFrame, records: list[dict[str, Any]]) -> list[Section]:
    """Group the results by dataset and model, build their tables and their verdict."""
    sections = []
    refs: dict[tuple[str, str], dict[str, Any]] = {}
    terms: dict[tuple[str, str], list[str]] = {}
    units: dict[tuple[str, str], dict[str, str]] = {}
    diagnostics: dict[tuple[str, str], dict[str, list[dict[str, Any]]]] = {}
    for rec in records:
        key = (rec["row"][_DATASET], rec["row"][_MODEL])
        if rec.get("reference") and key not in refs:
            refs[key] = rec["reference"]
        result = rec.get("result")
        if result:
            if "terms" not in result:  # an identified structure (nlid.identified.structure): its elements are the terms
                result = {**result, "terms": list((result.get("structure") or {}).get("elements") or [])}
            terms.setdefault(key, result["terms"])
            units.setdefault(key, {}).update(result.get("units") or {})
            diag = dict(result.get("diagnostics") or {})
            diag["_repetition"] = rec["row"].get(_REPETITION)
            diag["_model_terms"] = list(result["terms"])
            diag["_warnings"] = list(result.get("warnings") or [])
            diagnostics.setdefault(key, {}).setdefault(rec["row"][_METHOD], []).append(diag)
    for ds in config.datasets:
        for model in ds.models:
            key = (ds.name, model.name)
            if frame.empty:
                sub = frame
            else:
                sub = frame[(frame[_DATASET] == ds.name) & (frame[_MODEL] == model.name)].dropna(axis=1, how="all")
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


def _reference_table(section: Section) -> Table | None:
    """The reference values the error tables are relative to (SI), one per line."""
    ref = section.reference or {}
    columns = section.frame.columns
    rows: list[list[str]] = []
    for term in section.terms:
        value = (ref.get("coefficients") or {}).get(term)
        if value is not None and col.COEF.key(term) in columns:
            rows.append([f"coefficient of {term}", exact(value), section.unit(term)])
    if ref.get("mass") is not None and col.MASS_ERROR.key() in columns:
        rows.append(["mass", exact(ref["mass"]), "kg"])
    modal = ref.get("modal") or []
    for k, z in enumerate(ref.get("equilibria") or []):
        label = equilibrium_label(k)
        rows.append([f"{label}: stable equilibrium", exact(z, 4), "m"])
        if k < len(modal):
            rows.append([f"{label}: natural frequency fn", exact(modal[k]["fn_hz"], 4), "Hz"])
            rows.append([f"{label}: damping ratio zeta", exact(100 * modal[k]["zeta"], 3), "%"])
    if not rows:
        return None
    return Table("Reference values (the truth the errors are relative to)", ["quantity", "value", "unit"], rows)


def _head(columns: list[Column]) -> list[str]:
    """The header of a method table: method, runs, then the columns'."""
    return [col.METHOD.header(), "runs", *(c.header for c in columns)]


def _coefficient_error_table(section: Section) -> Table | None:
    """|Relative error| of each coefficient and of an estimated mass."""
    frame = section.frame
    err_terms = col.COEF_ERROR.labels(frame.columns)
    order = {t: i for i, t in enumerate(section.terms)}
    err_terms.sort(key=lambda t: order.get(t, len(order)))
    if not err_terms:
        return None
    cols = [Column.of(col.COEF_ERROR, t) for t in err_terms]
    if col.MASS_ERROR.key() in frame.columns:
        cols.append(Column.of(col.MASS_ERROR))
    rows, best = method_rows(section, cols)
    return Table(
        "Coefficients: |relative error| in % (median [min, max] over repetitions)", _head(cols), rows, best=best
    )


def _coefficient_table(section: Section) -> Table:
    """The identified coefficients and mass, below the reference values."""
    frame, ref = section.frame, section.reference or {}
    ref_coefs = ref.get("coefficients") or {}
    value_terms = section.terms_with(col.COEF)
    cols = [Column.of(col.COEF, t, unit=section.unit(t)) for t in value_terms]
    mass = col.MASS.key()
    has_mass = frame.get(mass) is not None and pd.to_numeric(frame[mass], errors="coerce").notna().any()
    if has_mass:
        cols.append(Column.of(col.MASS))
    rows, _ = method_rows(section, cols)
    if ref_coefs:
        reference_row = ["reference", "", *(exact(ref_coefs.get(t)) for t in value_terms)]
        if has_mass:
            reference_row.append(exact(ref.get("mass")))
        rows = [reference_row, *rows]
    return Table("Identified coefficients (SI, coefficients of R = f - m z'')", _head(cols), rows)


def _modal_table(section: Section) -> Table | None:
    """Modal parameters and equilibria per stable well: errors when there is a reference, else values."""
    frame, ref = section.frame, section.reference or {}
    eq_labels = col.EQ_ERROR.labels(frame.columns)
    modal_labels = sorted(set(col.FN.labels(frame.columns)) | set(eq_labels), key=col.label_order)
    if not modal_labels:
        return None
    errors = bool(eq_labels)
    families = (col.FN_ERROR, col.ZETA_ERROR, col.EQ_ERROR) if errors else (col.FN, col.ZETA)
    cols = [Column.of(f, label) for label in modal_labels for f in families if f.key(label) in frame.columns]
    rows, best = method_rows(section, cols)
    if not errors:
        return Table("Modal parameters (Eq. 8, 22)", _head(cols), rows)
    for row, method in zip(rows, section.present_methods, strict=True):
        row.append(_found_cell(section.ok(method)))
    header = [*_head(cols), f"wells found (of {len(ref.get('equilibria') or [])})"]
    title = "Modal parameters (Eq. 8, 22) and stable equilibria sK (see the reference values): |relative error| in %"
    return Table(title, header, rows, best=best)


def _structure_modes_table(section: Section) -> Table | None:
    """A structure's underlying linear modes (mK) and modes per well (sJ.mK): |relative error| in % (a structure)."""
    columns = section.frame.columns
    cols = []
    for families in ((col.LINEAR_FN_ERROR, col.LINEAR_ZETA_ERROR), (col.WELL_FN_ERROR, col.WELL_ZETA_ERROR)):
        labels = list(dict.fromkeys(label for f in families for label in f.labels(columns)))
        cols += [Column.of(f, label) for label in labels for f in families if f.key(label) in columns]
    if not cols:
        return None
    rows, best = method_rows(section, cols)
    title = "Modes of the structure: underlying linear (mK) and linearised at each stable well (sJ.mK), |error| in %"
    return Table(title, _head(cols), rows, best=best)


def _residual_table(section: Section) -> Table:
    """The families declared for the residual and cost table, with why a free run was skipped."""
    frame = section.frame
    # cost columns measure the machine, not the method's result: their digits are fixed in the declaration
    cols = [Column.of(f) for f in col.section_families(col.SECTION_RESIDUALS) if f.always or f.key() in frame.columns]
    notes = []
    note = col.FREERUN_NOTE.key()
    if note in frame.columns:
        for method in section.methods:
            ok = section.ok(method) if not frame.empty else frame
            skipped = ok[note].dropna() if note in ok else pd.Series(dtype=str)
            skipped = skipped[skipped != ""]
            if len(skipped):
                notes.append(f"{method}: free run {skipped.iloc[0]} ({len(skipped)} of {len(ok)} runs)")
    rule = col.FREERUN_RULE.key()
    if rule in frame.columns:  # every rule a free-run figure was computed under is stated
        said = sorted({r for r in frame[rule].dropna() if r})
        notes += [f"free run scored under: {r}" for r in said[:3]]
        if len(said) > 3:
            notes.append(f"free run scored under {len(said) - 3} more rules (column {rule} of the rows)")
    rows, best = method_rows(section, cols)
    return Table("Residuals (eps: Eq. 26), simulation error and cost", _head(cols), rows, notes, best=best)


def _response_table(section: Section) -> Table | None:
    """The ``[response]`` columns: each fit's resonance peak and its error against the reference's response."""
    frame = section.frame
    cols = [Column.of(f) for f in col.section_families(col.SECTION_RESPONSE) if f.key() in frame.columns]
    if not cols:
        return None
    rows, best = method_rows(section, cols)
    notes = [
        "harmonic balance and continuation (nlid.response) at the study's force amplitudes over its band: the peak "
        "is the largest first-harmonic amplitude of the forced DOF over the stable points, at the largest force; "
        "its errors are the largest over the forces, against the reference's true model (when it can run as one)"
    ]
    return Table(
        "Frequency response (nlid.response): resonance peak and its error", _head(cols), rows, notes, best=best
    )


def _other_table(section: Section) -> Table | None:
    """Columns of no declared family (a plugin's or a hook's own), as they come."""
    frame = section.frame
    other = [c for c in frame.columns if not col.declared(c) and not frame[c].dropna().empty]
    if not other:
        return None
    rows, _ = method_rows(section, [Column(c, c) for c in other])
    return Table(
        "Other metrics (median [min, max]; true/false as the fraction true)",
        [col.METHOD.header(), "runs", *other],
        rows,
    )


def _fill(section: Section) -> None:
    frame = section.frame
    tables = [
        _reference_table(section),
        _coefficient_error_table(section),
        _coefficient_table(section),
        _modal_table(section),
        _structure_modes_table(section),
        _term_table(
            section,
            col.QUALITY,
            "Quality indicator E[Re/Im] of each coefficient (NSI, paper Table 5; methods that report one)",
            drop_empty=True,
        ),
        _posterior_table(section),
        _selection_table(section),
        _term_table(
            section, col.RMS, "RMS contribution of each term to the identified restoring force, N (paper Fig. 22)"
        ),
        _residual_table(section),
        _response_table(section),
        _other_table(section),
    ]
    section.tables += [t for t in tables if t is not None]
    for _, row in frame[frame[_STATUS] != "ok"].iterrows():
        section.failures.append(f"{row[_METHOD]} r{row[_REPETITION]}: {row[_STATUS]}: {row[_ERROR]}")


def _term_table(section: Section, family: col.ColumnFamily, title: str, drop_empty: bool = False) -> Table | None:
    """Method x term table of a per-term family, when it has columns.

    ``drop_empty`` leaves out the methods without a value (e.g. those that report no quality indicator).
    """
    terms = section.terms_with(family)
    if not terms:
        return None
    rows, _ = method_rows(section, [Column.of(family, t) for t in terms])
    if drop_empty:
        rows = [r for r in rows if has_values(r)]
    return Table(title, [col.METHOD.header(), "runs", *(family.header(t) for t in terms)], rows)


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
    terms = section.terms_with(col.CI_LO)
    if not terms:
        return None
    levels = pd.to_numeric(frame.get(col.POSTERIOR_LEVEL.key(), pd.Series(dtype=float)), errors="coerce").dropna()
    level = f"{100 * levels.iloc[0]:g} %" if len(levels) else "credible"
    rows = []
    for method in section.methods:
        sub = section.runs(method)
        ok = sub[sub[_STATUS] == "ok"]
        if ok.empty or ok[col.CI_LO.key(terms[0])].dropna().empty:
            continue
        cells = [method, runs_cell(sub)]
        for t in terms:
            lo = float(pd.to_numeric(ok[col.CI_LO.key(t)], errors="coerce").dropna().median())
            hi = float(pd.to_numeric(ok[col.CI_HI.key(t)], errors="coerce").dropna().median())
            d = column_digits([(0.5 * (lo + hi), lo, hi)])
            text = f"[{sig(lo, d)}, {sig(hi, d)}]"
            if col.CI_COVERS.key(t) in ok.columns:
                covers = ok[col.CI_COVERS.key(t)].dropna().astype(bool)
                if len(covers):
                    text += f" covers {int(covers.sum())}/{len(covers)}"
            cells.append(text)
        for family in (col.POSTERIOR_TAU, col.POSTERIOR_SECONDS):
            cells.append(cell(ok[family.key()]) if family.key() in ok.columns else "–")
        rows.append(cells)
    if not rows:
        return None
    title = (
        f"Posterior (emcee): {level} credible interval of each coefficient (median of each bound over the runs) "
        "and how many runs' intervals cover the reference"
    )
    header = [col.METHOD.header(), "runs", *terms, col.POSTERIOR_TAU.header(), col.POSTERIOR_SECONDS.header()]
    return Table(title, header, rows)


def _found_cell(ok: pd.DataFrame) -> str:
    found_key = col.EQ_FOUND.key()
    if ok.empty or found_key not in ok.columns:
        return "–"
    found = pd.to_numeric(ok[found_key], errors="coerce").dropna().astype(int)
    lo, hi = int(found.min()), int(found.max())
    return f"{lo}" if lo == hi else f"{lo}–{hi}"
