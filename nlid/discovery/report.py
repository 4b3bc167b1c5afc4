"""The report of a discovery run: a terminal table, and Markdown + HTML with figures.

The functions read a :class:`~nlid.discovery.result.DiscoveryResult` (and its
stages) by their attributes and import nothing from :mod:`nlid.discovery.result`,
which imports them (the result's :meth:`~nlid.discovery.result.DiscoveryResult.summary`
and ``write_report``): one direction, no import circle.

:func:`discovery_summary` (a :class:`~nlid.report.summary.Summary`; its text is
:func:`summary_table`) is what ``nlid discover`` prints: one row per model
(the declared one, then one per accepted effect) with epsilon (Eq. 26) and
the force residual on the estimation and held-out records and the free-run
simulation error on the held-out record, then why the loop stopped and the
final coefficients.

:func:`write_report` writes to a folder

* ``report.md`` and ``report.html`` (the same content): data and method, the
  acceptance rule, the before/after table, for each step the candidates'
  evidence and the residual figures before and after, the final check, and
  the final model's coefficients (with standard errors, and posterior
  summaries when the identifier put them in ``diagnostics["posterior"]`` as
  ``{term: {"mean", "sd", "q05", "q95"}}``);
* ``result.json`` (the ``--json`` object), ``models.csv`` (one row per
  model) and ``coefficients.csv`` (the final model);
* ``figures/residual_<k>.png`` (model k's residual against z, v, the (z, v)
  plane and frequency) and ``figures/progress.png``.
"""

from __future__ import annotations

import html
import json
from pathlib import Path
from typing import Any

import pandas as pd

from ..base.dimensions import mass_unit
from ..base.formatting import TERMINAL_WIDTH
from ..data.forcehold import describe_force_hold
from ..model.terms import parse_term
from ..report.html import html_table
from ..report.plotting import save_figure
from ..report.summary import Column, Summary
from .evidence import Evidence
from .library import SIGN_WHY
from .probes import describe_remaining

__all__ = ["discovery_summary", "summary_table", "write_report", "coefficient_unit"]

#: A discovery result (:class:`~nlid.discovery.result.DiscoveryResult`), read by its attributes.
Result = Any
#: One of its stages (:class:`~nlid.discovery.result.Stage`).
StageLike = Any


def coefficient_unit(term: str, units: dict[str, str] | None = None) -> str:
    """Unit of a term's coefficient, with the record's units (SI by default)."""
    units = units or {}
    return parse_term(term).coefficient_unit_in(units.get("f", "N"), units.get("z", "m"))


def _mass_unit(units: dict[str, str]) -> str:
    """The mass's unit, derived from the record's (``kg``; ``s^2`` for a record in volts)."""
    return mass_unit(units.get("f", "N"), units.get("z", "m"))


def _labels(result: Result) -> list[str]:
    return ["declared: " + ", ".join(result.declared)] + [
        f"+ {s.effect}: " + (", ".join(s.terms) or f"m = {s.after.mass:.4g} {_mass_unit(result.info.get('units', {}))}")
        for s in result.steps
    ]


def _num(x: float) -> str:
    """Three significant digits, trailing zeros kept (17.0, 5.86, 0.889)."""
    return f"{x:.0f}" if abs(x) >= 100 else f"{x:#.3g}"


def _pct(x: float | None) -> str:
    return "-" if x is None else f"{_num(x)} %"


def _length(x: float | None, units: dict[str, str]) -> str:
    """A displacement (free-run error) in mm (mV for a voltage record), "-" when missing."""
    if x is None:
        return "-"
    zu = units.get("z", "m")
    if zu in ("m", "V"):
        prefix = {"m": "mm", "V": "mV"}[zu]
        return f"{_num(1000 * x)} {prefix}"
    return f"{x:.3g} {zu}"


def _sim(fit: StageLike, units: dict[str, str]) -> str:
    return _length(fit.sim_rms_holdout, units)


def _prediction(fit: StageLike, units: dict[str, str]) -> str:
    """The stage's pooled cross-fitted prediction error (``-`` when the search did not measure it)."""
    found = getattr(fit, "prediction", None)
    if found is None:
        return "-"
    pooled = found.pooled
    return _length(pooled, units) if pooled < float("inf") else "failed"


def _model_rows(result: Result) -> tuple[list[str], list[list[str]]]:
    units = result.info.get("units", {})
    validation = any(st.validation is not None for st in result.states)
    predicted = any(getattr(st, "prediction", None) is not None for st in result.states)
    headers = list(_MODEL_HEADERS) + (["x-fit prediction"] if predicted else [])
    headers += ["free-run validation"] if validation else []
    rows = []
    for label, fit in zip(_labels(result), result.states, strict=True):
        s = fit.scores
        row = [
            label,
            _pct(s.eps),
            _pct(s.eps_holdout),
            _pct(s.force_residual),
            _pct(s.force_residual_holdout),
            _sim(fit, units),
        ]
        if predicted:
            row.append(_prediction(fit, units))
        if validation:
            row.append(_length(fit.sim_rms_validation, units))
        rows.append(row)
    return headers, rows


_MODEL_HEADERS = [
    "model",
    "eps",
    "eps held-out",
    "force res.",
    "force res. held-out",
    "free-run held-out",
]
#: What the columns of the before/after table are (printed under it).
_MODEL_NOTE = (
    "eps: Eq. 26, relative to f - m a; force res.: the same error relative to f; free-run: RMS error of the "
    "displacement simulated from the held-out (validation) force; x-fit prediction: the pooled RMS error of "
    "the cross-fitted held-out prediction each step was judged by (nlid.discovery.crossfit)"
)


def _coefficient_rows(fit: StageLike, units: dict[str, str]) -> tuple[list[str], list[list[str]]]:
    se = fit.identified.standard_errors or {}
    post = fit.identified.diagnostics.get("posterior") if isinstance(fit.identified.diagnostics, dict) else None
    headers = ["term", "coefficient", "std. error", "unit"]
    if isinstance(post, dict) and post:
        headers += ["posterior mean", "posterior sd", "5 %", "95 %"]
    rows = []
    for name, value in fit.coefficients.items():
        row = [name, f"{value:.6g}", "-" if se.get(name) is None else f"{se[name]:.3g}", coefficient_unit(name, units)]
        if len(headers) > 4:
            p = post.get(name) if isinstance(post, dict) else None  # type: ignore[union-attr]
            row += ["-"] * 4 if not p else [f"{p.get(k, float('nan')):.6g}" for k in ("mean", "sd", "q05", "q95")]
        rows.append(row)
    return headers, rows


def freerun_rules(result: Result) -> list[str]:
    """The transient rule of each record's free-run figures, one line each (held-out, and validation if any)."""
    lines = [f"free run held-out: {result.info.get('freerun_rule') or 'not computed'}"]
    if result.info.get("validation"):
        lines.append(f"free run validation: {result.info.get('freerun_rule_validation') or 'not computed'}")
    return lines


def discovery_summary(result: Result) -> Summary:
    """The before/after table ``nlid discover`` prints, as a :class:`~nlid.report.summary.Summary`."""
    units = result.info.get("units", {})
    final = result.final
    how = "estimated" if final.identified.mass_estimated else "given"
    out = Summary()
    out.add_fields(
        [
            ("method", result.method),
            ("mass", f"{final.mass:.6g} {_mass_unit(units)} ({how})"),
            ("held-out", result.info.get("holdout", "")),
        ],
        separator="   ",
    )
    if result.info.get("force_hold"):  # the assumption about the force between samples, and its source
        hold = describe_force_hold(result.info["force_hold"], result.info.get("force_hold_source", "default"))
        out.add_text(f"force between samples: {hold}", width=TERMINAL_WIDTH, subsequent="  ")
    out.add_text(*(f"data: {w}" for w in result.info.get("data_warnings") or ()), width=TERMINAL_WIDTH, subsequent="  ")
    out.add_text(*freerun_rules(result), width=TERMINAL_WIDTH, subsequent="  ")
    judged = result.info.get("prediction_rule") or {}
    if judged.get("enabled") and judged.get("folds_note"):
        out.add_text(f"prediction: {judged['folds_note']}", width=TERMINAL_WIDTH)
    _add_table(out, *_model_rows(result))
    out.add_text(_MODEL_NOTE, width=TERMINAL_WIDTH)
    out.add_text(
        *(
            f"step {number}: {step.effect}"
            + (f" ({step.evidence.input_path})" if step.evidence.input_path else "")
            + f" explains {100 * step.evidence.explained_holdout:.3g} % of the held-out "
            f"residual variance, dBIC = {step.evidence.delta_bic:.4g} (N_eff = {step.evidence.n_eff:.4g})"
            + (_judged_text(step.evidence) if step.evidence.prediction_after else "")
            for number, step in enumerate(result.steps, 1)
        ),
        width=TERMINAL_WIDTH,
        gap=True,
    )
    out.add_text(
        *(f"  note (step {number}): {n}" for number, step in enumerate(result.steps, 1) for n in step.notes),
        width=TERMINAL_WIDTH,
        subsequent="    ",
    )
    out.add_text(f"stopped: {result.stop_reason}", width=TERMINAL_WIDTH)
    out.add_text(
        *(f"  {ev.effect:<28} {_explained(ev)}" for ev in result.final_ranking[:3] if ev.explained_holdout is not None)
    )
    if result.validation_note:
        out.add_text(f"validation: {result.validation_note}", width=TERMINAL_WIDTH)
    elif result.validation_range:  # the note, when there is one, already says how far
        out.add_text(f"validation: {result.validation_range}", width=TERMINAL_WIDTH)
    if result.info.get("refine_failed"):
        out.add_text(f"refinement: {result.info['refine_failed']}", width=TERMINAL_WIDTH, subsequent="  ")
    _add_table(out, *_coefficient_rows(final, units))
    out.add_text(*(f"NOT TRUSTED: {f}" for f in final.identified.flags), width=TERMINAL_WIDTH, subsequent="  ")
    return out


def _judged_text(ev: Evidence) -> str:
    """``"; cross-fitted free run 7.25e-3 -> 4.48e-3"`` of a judged candidate."""
    before, after = ev.prediction_before or {}, ev.prediction_after or {}
    b, a = before.get("pooled"), after.get("pooled")
    if b is None or a is None:
        return ""
    return f"; cross-fitted {after.get('kind', 'prediction')} error {b:.4g} -> {a:.4g}"


def _add_table(out: Summary, headers: list[str], rows: list[list[str]]) -> None:
    """A table as :func:`nlid.base.formatting.text_table` lays it out: labels left, figures right, within the width."""
    columns = [Column(h, "left" if j == 0 else "right") for j, h in enumerate(headers)]
    out.add_table(columns, rows, rule=True, width=TERMINAL_WIDTH, keep=1)


def summary_table(result: Result) -> str:
    """The before/after table ``nlid discover`` prints (the text of :func:`discovery_summary`)."""
    return discovery_summary(result).as_text()


def _explained(ev: Evidence) -> str:
    return f"explains {100 * ev.explained_holdout:.3g} % of held-out residual variance, dBIC = {ev.delta_bic:.4g}"  # type: ignore[operator]


#: Largest width of the HTML report's page (px): every figure fits it at its own size (10 in at 120 dpi: 1200 px).
PAGE_PX = 1400
#: What a ranking row says in place of the physical-sign explanation, given once below its table.
_SIGN_SHORT = "(physical sign: below the table)"


def _ranking_rows(ranking: list[Evidence]) -> list[list[str]]:
    """One row per candidate; the explanation of a wrong sign, the same for every such row, is said once below."""
    rows = []
    for ev in ranking:
        rows.append(
            [
                ev.effect,
                ", ".join(ev.terms) or "-",
                "-" if ev.explained_holdout is None else f"{100 * ev.explained_holdout:.3g} %",
                "-" if ev.delta_bic is None else f"{ev.delta_bic:.4g}",
                "-" if ev.scores is None else _pct(ev.scores.eps),
                "-" if ev.scores is None else _pct(ev.scores.eps_holdout),
                ev.status,
                ev.reason.replace(f"({SIGN_WHY})", _SIGN_SHORT),
            ]
        )
    return rows


def _ranking_table(doc: _Doc, ranking: list[Evidence]) -> None:
    rows = _ranking_rows(ranking)
    doc.table(_RANK_HEADERS, rows)
    if any(_SIGN_SHORT in row[-1] for row in rows):
        doc.p(f"Physical sign: a candidate whose fitted coefficient has the wrong sign is not its effect: {SIGN_WHY}.")


_RANK_HEADERS = [
    "candidate",
    "terms",
    "held-out variance explained",
    "dBIC (N_eff)",
    "eps after",
    "eps after, held-out",
    "status",
    "reason",
]


# --------------------------------------------------------------------------- document
class _Doc:
    """A tiny document model rendered to Markdown and to HTML."""

    def __init__(self) -> None:
        self.blocks: list[tuple[str, Any]] = []

    def h(self, level: int, text: str) -> None:
        self.blocks.append(("h", (level, text)))

    def p(self, text: str) -> None:
        self.blocks.append(("p", text))

    def items(self, items: list[str]) -> None:
        self.blocks.append(("ul", items))

    def table(self, headers: list[str], rows: list[list[str]]) -> None:
        self.blocks.append(("table", (headers, rows)))

    def images(self, images: list[tuple[str, str]]) -> None:
        self.blocks.append(("img", images))

    def markdown(self) -> str:
        out: list[str] = []
        for kind, data in self.blocks:
            if kind == "h":
                out.append("#" * data[0] + " " + data[1])
            elif kind == "p":
                out.append(data)
            elif kind == "ul":
                out.append("\n".join(f"- {x}" for x in data))
            elif kind == "table":
                headers, rows = data
                esc = [[str(c).replace("|", "\\|") for c in r] for r in [headers, *rows]]
                out.append("| " + " | ".join(esc[0]) + " |")
                out[-1] += "\n|" + "|".join(" --- " for _ in headers) + "|"
                for r in esc[1:]:
                    out[-1] += "\n| " + " | ".join(r) + " |"
            elif kind == "img":
                out.append("\n\n".join(f"![{cap}]({src})\n\n*{cap}*" for src, cap in data))
        return "\n\n".join(out) + "\n"

    def html(self, title: str) -> str:
        e = html.escape
        body: list[str] = []
        for kind, data in self.blocks:
            if kind == "h":
                body.append(f"<h{data[0]}>{e(data[1])}</h{data[0]}>")
            elif kind == "p":
                body.append(f"<p>{e(data)}</p>")
            elif kind == "ul":
                body.append("<ul>" + "".join(f"<li>{e(x)}</li>" for x in data) + "</ul>")
            elif kind == "table":
                headers, rows = data
                body.append(html_table(headers, rows))
            elif kind == "img":
                figs = "".join(
                    f'<figure><img src="{e(src)}" alt="{e(cap)}"><figcaption>{e(cap)}</figcaption></figure>'
                    for src, cap in data
                )
                body.append(f'<div class="figures">{figs}</div>')
        style = (
            f"body{{font-family:sans-serif;max-width:{PAGE_PX}px;margin:2em auto;padding:0 1em;line-height:1.4}}"
            "table{border-collapse:collapse;margin:1em 0;font-size:0.9em}"
            "td,th{border:1px solid #ccc;padding:3px 8px;text-align:left}th{background:#f2f2f2}"
            # one figure per row at its own size (never stretched, shrunk only to fit the page): two four-panel
            # figures side by side were drawn at half size, their labels unreadable without zoom
            ".figures{display:flex;flex-direction:column;gap:1.5em}figure{margin:0}"
            "figure img{max-width:100%;height:auto}figcaption{font-size:0.85em;color:#555}"
        )
        return (
            f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8"><title>{e(title)}</title>'
            f"<style>{style}</style></head><body>\n" + "\n".join(body) + "\n</body></html>\n"
        )


def write_report(result: Result, out_dir: str | Path, *, force: bool = False) -> list[Path]:
    """Write the report (see the module docstring) and return the files written.

    nlid writes only into folders it created or that were empty; ``force=True``
    writes beside files it did not write, never replacing them (:mod:`nlid.runtime.outputs`).
    """
    from ..runtime.outputs import DISCOVERY_OUTPUTS, output_folder

    with output_folder(out_dir, DISCOVERY_OUTPUTS, force=force) as out:
        return _write_report(result, out)


def _write_report(result: Result, out: Path) -> list[Path]:
    from .plots import progress_figure, remaining_figure, residual_figure

    figures = out / "figures"
    figures.mkdir(parents=True, exist_ok=True)
    units = result.info.get("units", {})
    written: list[Path] = []

    fig_paths: list[str | None] = []
    for k, view in enumerate(result.views):
        fig = residual_figure(view, units)
        written += save_figure(fig, figures / f"residual_{k}", formats=("png",))
        fig_paths.append(f"figures/residual_{k}.png")
    if len(fig_paths) < len(result.states):
        fig_paths += [None] * (len(result.states) - len(fig_paths))
    written += save_figure(progress_figure(result), figures / "progress", formats=("png",))

    labels = _labels(result)
    doc = _Doc()
    title = "Residual -> missing effect: " + (Path(result.info.get("source", "")).name or "record")
    doc.h(1, title)
    doc.items(
        [
            f"data: {result.info.get('source', '')} - estimation {result.info.get('samples_estimation')} samples, "
            f"held-out {result.info.get('holdout', '')}",
            f"equation band: {result.info.get('band_hz', float('nan')):.4g} Hz "
            f"(sampling {result.info.get('fs_hz', float('nan')):.6g} Hz)",
            f"method: {result.method} ({'; '.join(result.method_notes)})",
            "declared model (taken literally): " + ", ".join(result.declared),
            "acceptance rule: " + result.rule.describe(),
            f"run time: {result.info.get('seconds', float('nan')):.3g} s",
        ]
    )
    doc.h(2, "Error before and after")
    doc.p(
        "epsilon is Eq. 26 (RMS residual relative to the restoring force f - m a); the force residual is the "
        "same residual relative to the force f (the figure inverse-dynamics benchmarks quote); the free-run "
        "error is the RMS difference between the measured displacement of the held-out record and the "
        "model's simulated response to its measured force."
    )
    doc.items(freerun_rules(result))
    doc.table(*_model_rows(result))
    doc.images([("figures/progress.png", "residuals after each step")])

    for number, step in enumerate(result.steps, 1):
        doc.h(2, f"Step {number}: {step.effect} ({', '.join(step.terms)})")
        ev = step.evidence
        doc.p(
            f"Accepted: {ev.reason}. Effective sample size of the current residual N_eff = {ev.n_eff:.4g} "
            f"(integrated autocorrelation time {ev.tau_samples:.3g} samples)."
            + (f" Shape parameter(s) chosen: {ev.shape}." if ev.shape is not None else "")
        )
        _ranking_table(doc, step.ranking)
        imgs = []
        for k, caption in ((number - 1, "before: " + labels[number - 1]), (number, "after: " + labels[number])):
            if fig_paths[k]:
                imgs.append((fig_paths[k], caption))  # type: ignore[arg-type]
        if imgs:
            doc.images(imgs)
        if step.notes:
            doc.items(step.notes)

    doc.h(2, "Final check: is anything else significant?")
    doc.p(f"Stopped: {result.stop_reason}.")
    if result.final_ranking:
        _ranking_table(doc, result.final_ranking)
    if not result.steps and fig_paths and fig_paths[0]:
        doc.images([(fig_paths[0], "residual of the declared model")])

    doc.h(2, "What remains")
    remaining = result.remaining
    if remaining is not None:
        doc.p(describe_remaining(remaining)[:1].upper() + describe_remaining(remaining)[1:] + ".")
        doc.table(
            ["probe", "held-out variance predicted", "fitted on held-out, scored on estimation", "structure"],
            [
                [
                    name,
                    _pct(100 * p.explained_holdout),
                    _pct(100 * p.explained_estimation),
                    "yes" if p.structured else "no",
                ]
                for name, p in remaining.probes.items()
            ],
        )
        if result.views:
            fig = remaining_figure(result.views[-1], remaining, units)
            written += save_figure(fig, figures / "remaining", formats=("png",))
            doc.images([("figures/remaining.png", "what remains in the final model's residual")])

    doc.h(2, "Final model")
    final = result.final
    how = "estimated" if final.identified.mass_estimated else "given"
    doc.p(
        f"Terms: {', '.join(final.model.names)}; mass {final.mass:.6g} {_mass_unit(units)} ({how})."
        + (
            f" px(z) roots: {final.model.px_roots[0]:.6g}, {final.model.px_roots[1]:.6g} {units.get('z', 'm')}."
            if final.model.px_roots
            else ""
        )
    )
    headers, rows = _coefficient_rows(final, units)
    doc.table(headers, rows)
    if not (isinstance(final.identified.diagnostics, dict) and final.identified.diagnostics.get("posterior")):
        doc.p(
            "Standard errors are the identifier's own; the least-squares ones are batch-means sandwich errors, "
            "which allow for the correlated, filtered equation error but take the regressors as exact "
            "(docs/rfs.md); no posterior was available."
        )
    notes = [*(result.info.get("data_warnings") or ()), *(f.sim_note for f in result.states if f.sim_note)]
    notes += list(final.identified.warnings)
    if notes:
        doc.h(3, "Notes")
        doc.items(list(dict.fromkeys(notes)))

    md = out / "report.md"
    md.write_text(doc.markdown(), encoding="utf-8")
    page = out / "report.html"
    page.write_text(doc.html(title), encoding="utf-8")
    data = out / "result.json"
    data.write_text(json.dumps(result.to_dict(), indent=1, allow_nan=False), encoding="utf-8")
    models = out / "models.csv"
    pd.DataFrame(
        [
            {
                "model": label,
                "terms": ", ".join(fit.model.names),
                "eps_percent": fit.scores.eps,
                "eps_holdout_percent": fit.scores.eps_holdout,
                "force_residual_percent": fit.scores.force_residual,
                "force_residual_holdout_percent": fit.scores.force_residual_holdout,
                "sim_rms_holdout": fit.sim_rms_holdout,
                "mass": fit.mass,
            }
            for label, fit in zip(labels, result.states, strict=True)
        ]
    ).to_csv(models, index=False)
    coeffs = out / "coefficients.csv"
    se = final.identified.standard_errors or {}
    pd.DataFrame(
        [
            {"term": n, "coefficient": v, "std_error": se.get(n), "unit": coefficient_unit(n, units)}
            for n, v in final.coefficients.items()
        ]
    ).to_csv(coeffs, index=False)
    return [md, page, data, models, coeffs, *written]
