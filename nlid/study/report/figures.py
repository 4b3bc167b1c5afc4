"""Study figures (PNG and SVG through :mod:`nlid.report.plotting`, never pyplot).

Every figure has units on its axes, a legend and a one-line caption.

* ``summary_<dataset>_<model>``: the metrics that separate the methods - the
  |error| of every coefficient, of the modal parameters and equilibria, the
  held-out residual and free-run error, and the time per identification: bar
  = median, whisker = min-max over repetitions, log scale; one bar per
  method, also for methods with identical coefficients (``sindy (= rfs)`` in
  the legend): their accuracy bars are equal, their times their own.
* ``kz_<dataset>_<model>``: the identified elastic force K(z) (Eq. 6) against
  the reference, equilibria marked, and below the difference identified -
  reference per method (line: median over the repetitions, band: min-max).
* ``rms_*``: each term's RMS contribution to R (paper Fig. 22).
* From a result's ``arrays`` when the method provides them
  (:class:`nlid.identified.model.IdentifiedModel`): ``sv_*`` singular values
  (paper Fig. 9/12), ``frf_*`` the method's underlying-linear receptance(s)
  (Fig. 10/15) with the identified model linearised at each stable
  equilibrium, ``coef_*`` the frequency-dependent coefficient estimates, real
  and imaginary parts, with the band they are averaged over (Fig. 11/13).
  Which arrays are receptances and spectra the method declares
  (:meth:`nlid.plugin.Identifier.figure_arrays`); no array name is parsed here.

A figure is drawn again only when what it shows changed (:class:`FigureCache`:
``figures/index.json`` keeps the digest of each figure's inputs and of the
code that draws it): a re-run whose coefficients are the same redraws the
summary figure (it shows the times) and reuses the others.
"""

from __future__ import annotations

import re
import textwrap
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ...base.formatting import sig
from ...contract.identifier import FigureArray
from ...identified.responseplots import declared_arrays
from ...model import physics
from ...model.terms import Model
from ...report.plotting import new_figure
from .. import columns as col
from .figurecache import Figure, FigureCache
from .section import Section
from .verdict import identical_methods

__all__ = [
    "section_figures",
    "figure_arrays",
    "draw_summary",
]

_SAFE = re.compile(r"[^A-Za-z0-9_.+-]+")
_DATASET, _MODEL, _METHOD = col.DATASET.key(), col.MODEL.key(), col.METHOD.key()


def _stem(folder: Path, *parts: str) -> Path:
    return folder / _SAFE.sub("_", "_".join(parts))


def _model(terms: list[str], px_roots: Any) -> Model:
    return Model.from_spec(terms, defaults=False, px_roots=px_roots)


def _colors(n: int) -> list[Any]:
    from matplotlib import colormaps

    cmap = colormaps["tab10"]
    return [cmap(i % 10) for i in range(n)]


def section_figures(
    section: Section, records: list[dict[str, Any]], store: Any, folder: Path, cache: FigureCache | None = None
) -> list[Figure]:
    """Every figure of one dataset x model; returns them (drawn, or kept when ``cache`` says they are fresh)."""
    cache = cache if cache is not None else FigureCache(folder)
    figures: list[Figure] = []
    recs = [
        r
        for r in records
        if r["row"][_DATASET] == section.dataset and r["row"][_MODEL] == section.model and r.get("result")
    ]
    if not recs:
        return figures
    structure = "terms" not in recs[0]["result"]  # an identified structure: no 1-DOF stiffness curve
    for make in (_summary_figure, _rms_figure) if structure else (_summary_figure, _kz_figure, _rms_figure):
        fig = make(section, folder, cache) if make is not _kz_figure else make(section, recs, folder, cache)
        if fig:
            figures.append(fig)
    for method in section.methods:
        for rec in recs:
            if rec["row"][_METHOD] == method and rec.get("arrays"):
                figures += _array_figures(section, method, rec, store.arrays(rec["run_id"]), folder, cache)
                break
    return figures


def _groups(section: Section) -> list[tuple[str, ...]]:
    """The methods with runs, those with identical coefficients on every record merged (``rfs = sindy``)."""
    same = identical_methods(section)
    out: list[tuple[str, ...]] = []
    for m in section.present_methods:
        if same.get(m, (m,)) not in out:
            out.append(same.get(m, (m,)))
    return out


def _kz_figure(section: Section, recs: list[dict[str, Any]], folder: Path, cache: FigureCache) -> Figure | None:
    stem = _stem(folder, "kz", section.dataset, section.model)
    figure = Figure(
        "Elastic restoring force K(z)",
        stem,
        "Top: identified K(z) (median over repetitions per method) against the reference, with the stable "
        "equilibria; bottom: identified minus reference per method, line the median, band min-max over "
        "repetitions (dotted: reference equilibria).",
    )
    groups = _groups(section)
    key = cache.key(
        "kz",
        section.dataset,
        section.model,
        section.reference,
        groups,
        section.present_methods,
        [(r["row"][_METHOD], r["row"][col.Z_MIN.key()], r["row"][col.Z_MAX.key()], r["result"]) for r in recs],
    )
    if cache.fresh(stem, key):
        return figure
    ref = section.reference or {}
    z_lo = min(r["row"][col.Z_MIN.key()] for r in recs)
    z_hi = max(r["row"][col.Z_MAX.key()] for r in recs)
    z = np.linspace(z_lo, z_hi, 400)
    k_ref = None
    if ref.get("terms") and ref.get("coefficients"):
        ref_model = _model(ref["terms"], ref.get("px_roots"))
        k_ref = physics.elastic(ref_model, ref["coefficients"], z)
    fig, axes = new_figure(2 if k_ref is not None else 1, 1, width=7.0, height=6.4 if k_ref is not None else 4.0)
    ax = axes[0] if k_ref is not None else axes
    if k_ref is not None:
        ax.plot(z, k_ref, color="black", lw=2.5, label="reference")
        eq = ref.get("equilibria") or []
        ax.plot(eq, np.zeros(len(eq)), "o", mfc="none", mec="black", ms=10, label="reference stable equilibria")
    colors = dict(zip(groups, _colors(len(groups)), strict=True))
    curves: dict[tuple[str, ...], list[np.ndarray]] = {g: [] for g in groups}
    for rec in recs:
        res, method = rec["result"], rec["row"][_METHOD]
        group = next((g for g in groups if method in g), None)
        if group is None or method != group[0]:
            continue  # identical methods: drawn once
        model = _model(res["terms"], res.get("px_roots"))
        curves[group].append(physics.elastic(model, res["coefficients"], z))
        stable = (res.get("equilibria") or {}).get("stable", [])
        ax.plot(stable, np.zeros(len(stable)), "x", color=colors[group], ms=7)
    for group, ks in curves.items():
        if not ks:
            continue
        k = np.asarray(ks)
        name = " = ".join(group)
        ax.plot(z, np.median(k, axis=0), color=colors[group], lw=1.0, label=f"{name} (median of {len(ks)} runs)")
        if k_ref is not None:
            d = k - k_ref
            axes[1].fill_between(z, d.min(axis=0), d.max(axis=0), color=colors[group], alpha=0.2, lw=0)
            axes[1].plot(z, np.median(d, axis=0), color=colors[group], lw=1.5, label=f"{name}: median, band min-max")
    ax.plot([], [], "x", color="0.3", label="identified stable equilibria")
    ax.axhline(0.0, color="0.6", lw=0.5)
    ax.set_ylabel("K(z) (N)")
    ax.set_title(f"{section.dataset} / {section.model}: elastic restoring force K(z)")
    ax.legend(fontsize=8)
    if k_ref is not None:
        axes[1].axhline(0.0, color="0.6", lw=0.5)
        axes[1].set_ylabel("identified - reference (N)")
        axes[1].set_xlabel("z (m)")
        axes[1].set_title(f"error of K(z) over the {len(recs) // max(1, len(section.present_methods))} repetitions")
        axes[1].legend(fontsize=8)
        for zq in ref.get("equilibria") or []:
            axes[1].axvline(zq, color="0.5", lw=0.6, ls=":")
    else:
        ax.set_xlabel("z (m)")
    cache.save(fig, stem, key)
    return figure


def _stats(frame: pd.DataFrame, column: str, methods: list[str], absolute: bool = True) -> tuple[list, list, list]:
    med, lo, hi = [], [], []
    for m in methods:
        sub = frame[(frame[_METHOD] == m) & (frame[col.STATUS.key()] == "ok")]
        x = pd.to_numeric(sub[column], errors="coerce").to_numpy(dtype=float) if column in sub else np.array([])
        x = x[np.isfinite(x)]
        if absolute:
            x = np.abs(x)
        if x.size:
            med.append(float(np.median(x)))
            lo.append(float(np.median(x) - x.min()))
            hi.append(float(x.max() - np.median(x)))
        else:
            med.append(np.nan)
            lo.append(0.0)
            hi.append(0.0)
    return med, lo, hi


def _grouped_bars(ax: Any, frame: pd.DataFrame, columns: list[tuple[str, str]], methods: list[str]) -> None:
    """Bars of ``columns`` (x axis) per method (colours): median, whiskers min-max, log scale.

    Every method has its own bar with its own values, also where methods tie: their bars are then equal.
    """
    x = np.arange(len(columns))
    width = 0.8 / max(1, len(methods))
    colors = _colors(len(methods))
    for i, method in enumerate(methods):
        med, lo, hi = [], [], []
        for key, _ in columns:
            m, a, b = _stats(frame, key, [method])
            med.append(m[0])
            lo.append(a[0])
            hi.append(b[0])
        med = np.asarray(med)
        # a log axis cannot show a bar reaching zero: the lower whisker stops at 1 % of the median
        lo = np.minimum(np.asarray(lo), 0.99 * np.nan_to_num(med))
        ax.bar(
            x + (i - (len(methods) - 1) / 2) * width,
            med,
            width,
            yerr=[lo, hi],
            capsize=2,
            color=colors[i],
            label=method,
            error_kw={"lw": 0.8},
        )
    ax.set_yscale("log")
    ax.set_xticks(x, [label for _, label in columns], rotation=30, ha="right", fontsize=8)


def draw_summary(section: Section) -> Any:
    """The summary figure of a section (a :class:`matplotlib.figure.Figure`), or None without runs.

    The metrics that separate the methods: coefficient, modal and equilibrium errors, residuals, time; one
    panel per family, one bar per method and metric (median, whiskers min-max, log scale).
    """
    frame = section.frame
    groups = _groups(section)
    if not groups:
        return None
    cols = frame.columns

    def present(*families: col.ColumnFamily, label: str | None = None) -> list[tuple[str, str]]:
        return [(f.key(label), f.short(label)) for f in families if f.key(label) in cols]

    coef = [(col.COEF_ERROR.key(t), col.COEF_ERROR.short(t)) for t in section.terms_with(col.COEF_ERROR)]
    coef += present(col.MASS_ERROR)
    modal = []
    for label in sorted(col.EQ_ERROR.labels(cols), key=col.label_order):
        modal += present(col.FN_ERROR, col.ZETA_ERROR, col.EQ_ERROR, label=label)
    fit = present(col.EPS_HOLDOUT, col.FREERUN_NRMSE) or present(col.EPS)
    panels = [
        (coef, "coefficients: |error| (%)"),
        (modal, "modal parameters and equilibria: |error| (%)"),
        (fit, "held-out residual, free run (%)"),
        (present(col.SECONDS), "time per identification (s)"),
    ]
    panels = [p for p in panels if p[0]]
    methods = [m for g in groups for m in g]
    widths = [max(1.5, 0.55 * len(c) * max(1, len(methods)) / 2 + 0.8) for c, _ in panels]
    fig, axes = new_figure(
        1,
        len(panels),
        width=min(16.0, sum(widths) + 1.5),
        height=4.4,
        squeeze=False,
        gridspec_kw={"width_ratios": widths},
    )
    width = min(16.0, sum(widths) + 1.5)
    for ax, (columns, title), w in zip(axes[0], panels, widths, strict=True):
        _grouped_bars(ax, frame, columns, methods)
        # a title wider than its panel is cut at the figure's edge: wrapped to the panel (9 pt, 0.6 em a glyph)
        chars = max(10, int((width - 1.5) * w / sum(widths) * 72 / (0.6 * 9)))
        ax.set_title("\n".join(textwrap.wrap(title, chars)), fontsize=9)
    axes[0, 0].set_ylabel("median (whiskers: min-max)")
    handles, _ = axes[0, 0].get_legend_handles_labels()
    # identical methods keep their own bars (equal on the accuracy panels, their own times); the legend says so
    names = [m if len(g) == 1 or m == g[0] else f"{m} (= {g[0]})" for g in groups for m in g]
    fig.legend(handles, names, loc="outside upper center", ncols=len(methods), fontsize=9)
    return fig


def _summary_figure(section: Section, folder: Path, cache: FigureCache) -> Figure | None:
    """Write the summary figure (:func:`draw_summary`), unless it is fresh."""
    if not _groups(section):
        return None
    stem = _stem(folder, "summary", section.dataset, section.model)
    key = cache.key("summary", section.dataset, section.model, section.terms, section.methods, section.frame)
    if not cache.fresh(stem, key):
        fig = draw_summary(section)
        if fig is None:
            return None
        cache.save(fig, stem, key)
    return Figure(
        "What separates the methods",
        stem,
        "Median over repetitions (whiskers: min-max, log scale) of each coefficient's |error|, the modal and "
        "equilibrium errors, the held-out residual and free-run error, and the time per identification; lower "
        "is better; methods with identical coefficients (legend: = another method) have equal accuracy bars.",
    )


def _rms_figure(section: Section, folder: Path, cache: FigureCache) -> Figure | None:
    """Grouped bars of each term's RMS contribution to R per method (paper Fig. 22)."""
    frame = section.frame
    terms = section.terms_with(col.RMS)
    methods = [m for m in section.methods if (frame[_METHOD] == m).any()]
    if not terms or not methods:
        return None
    stem = _stem(folder, "rms", section.dataset, section.model)
    figure = Figure(
        "RMS contribution of each term",
        stem,
        "RMS of theta_i g_i(z, v) over the record, median over repetitions (paper Fig. 22); log scale.",
    )
    used = [_METHOD, col.STATUS.key(), *(col.RMS.key(t) for t in terms)]
    key = cache.key("rms", section.dataset, section.model, terms, methods, frame[used])
    if cache.fresh(stem, key):
        return figure
    fig, ax = new_figure(width=max(6.0, 1.1 * len(terms) + 2.0), height=3.8)
    x = np.arange(len(terms))
    width = 0.8 / len(methods)
    for i, method in enumerate(methods):
        med = [_stats(frame, col.RMS.key(t), [method])[0][0] for t in terms]
        ax.bar(x + (i - (len(methods) - 1) / 2) * width, med, width, label=method)
    ax.set_yscale("log")
    ax.set_xticks(x, terms, rotation=30, ha="right", fontsize=8)
    ax.set_ylabel("RMS contribution (N)")
    ax.set_title(f"{section.dataset} / {section.model}: terms of the identified restoring force")
    ax.legend(fontsize=8)
    cache.save(fig, stem, key)
    return figure


def _slices_figure(
    section: Section, method: str, tag: str, arrays: dict, folder: Path, cache: FigureCache, key: str
) -> Figure | None:
    """Measured damping force near each slice position against the identified D(z0, v) (Fig. 21 b-d)."""
    count = col.SLICES.count(arrays)
    if not count:
        return None
    stem = _stem(folder, "slices", section.dataset, section.model, method)
    figure = Figure(
        f"Damping force slices, {method}",
        stem,
        f"Measured R_e - K(z) of the samples near each position (grey) against the identified D(z0, v) ({tag}); "
        "paper Fig. 21 b-d.",
    )
    if cache.fresh(stem, key):
        return figure
    fig, axes = new_figure(1, count, width=3.2 * count + 0.6, height=3.4, squeeze=False)
    for k in range(count):
        ax = axes[0, k]

        def part(name: str, k: int = k) -> np.ndarray:
            return arrays[col.SLICES.key(k, name)]

        z0 = float(np.asarray(part("z0")))
        ax.plot(part("v"), part("measured"), ".", color="0.6", ms=2, label="measured")
        ax.plot(part("v_grid"), part("model"), color="C0", lw=1.5, label="identified")
        ax.set_title(f"z near {z0:+.3g} m", fontsize=9)
        ax.set_xlabel("v (m/s)")
    axes[0, 0].set_ylabel("damping force D (N)")
    axes[0, 0].legend(fontsize=8)
    cache.save(fig, stem, key)
    return figure


def figure_arrays(method: str, arrays: dict) -> tuple[FigureArray, ...]:
    """The arrays of a run that the method declares for figures
    (:func:`nlid.identified.responseplots.declared_arrays`)."""
    return declared_arrays(method, arrays)


def _curve(arrays: dict, declared: FigureArray) -> tuple[np.ndarray, np.ndarray]:
    """``(frequency, values)`` of a declared array."""
    return np.asarray(arrays[declared.frequency], dtype=float).ravel(), np.asarray(arrays[declared.values]).ravel()


def _frf_figure(
    section: Section, method: str, rec: dict[str, Any], arrays: dict, folder: Path, cache: FigureCache, key: str
) -> Figure | None:
    """The method's underlying-linear FRF(s) with the identified model linearised at each stable equilibrium."""
    frfs = [a for a in figure_arrays(method, arrays) if a.kind == "frf"]
    if not frfs:
        return None
    stem = _stem(folder, "frf", section.dataset, section.model, method)
    k_tilde = (rec["result"].get("diagnostics") or {}).get("k_tilde")
    if k_tilde is not None:
        why = (
            f"Solid: the FRF {method} identifies, that of the system perturbed by the virtual stiffness k~1 "
            f"= {sig(float(k_tilde), 3)} N/m about z = 0 (Sec. 3.2), so its peak is not a natural frequency of the "
            "oscillator"
        )
    else:
        why = f"Solid: the underlying-linear FRF {method} identifies (paper Fig. 10/15)"
    figure = Figure(
        f"Underlying-linear FRF, {method}",
        stem,
        why + "; dashed: the identified model linearised at each stable equilibrium, whose peaks (dotted) are the "
        "natural frequencies of the modal table.",
    )
    if cache.fresh(stem, key):
        return figure
    curves = [(a, *_curve(arrays, a)) for a in frfs]
    res = rec["result"]
    diag = res.get("diagnostics") or {}
    mass = res.get("mass")
    modal = [m for m in res.get("modal") or [] if m.get("stiffness") is not None]
    f_max = max(float(c[1].max()) for c in curves)
    if modal:
        f_max = max(f_max, 2.0 * max(m["fn_hz"] for m in modal))
    freq = np.linspace(f_max / 2000, f_max, 1500)
    w = 2 * np.pi * freq
    fig, axes = new_figure(2, 1, width=7.0, height=6.4, sharex=True)
    uls = diag.get("uls") if isinstance(diag.get("uls"), dict) else {}
    for i, (declared, f, h) in enumerate(curves):
        if k_tilde is not None:
            label = f"{method}: identified underlying-linear system with k~1 = {sig(float(k_tilde), 3)} N/m added"
            if uls.get("fn_hz"):
                label += f" (fn {sig(uls['fn_hz'], 3)} Hz)"
        elif declared.label:
            label = f"{method}: underlying-linear system of {declared.label}"
        else:
            label = f"{method}: underlying-linear system"
        axes[0].semilogy(f, np.abs(h), color=f"C{i}", lw=1.8, label=label)
        axes[1].plot(f, np.degrees(np.unwrap(np.angle(h))), color=f"C{i}", lw=1.8)
    for j, m in enumerate(modal):
        k, c = float(m["stiffness"]), float(m.get("damping") or 0.0)
        if mass is None:
            continue
        h = 1.0 / (k - mass * w**2 + 1j * c * w)
        color = f"C{len(curves) + j}"
        label = f"identified model linearised at z* = {sig(m['equilibrium'], 3)} m (fn {sig(m['fn_hz'], 3)} Hz)"
        axes[0].semilogy(freq, np.abs(h), "--", color=color, lw=1.2, label=label)
        axes[1].plot(freq, np.degrees(np.unwrap(np.angle(h))), "--", color=color, lw=1.2)
        for ax in axes:
            ax.axvline(m["fn_hz"], color=color, lw=0.6, ls=":")
    axes[0].set_ylabel("|H| (m/N)")
    axes[0].set_title(f"receptance ({method}, {rec['run_id']})", fontsize=10)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", fontsize=7)  # below the panels: the curves fill them
    axes[1].set_ylabel("phase (deg)")
    axes[1].set_xlabel("frequency (Hz)")
    cache.save(fig, stem, key)
    return figure


def _coef_figure(
    section: Section, method: str, rec: dict[str, Any], arrays: dict, folder: Path, cache: FigureCache, key: str
) -> Figure | None:
    """Real and imaginary parts of each coefficient spectrum, the band averaged over and the reported value."""
    spectra = [a for a in figure_arrays(method, arrays) if a.kind == "coefficient spectrum"]
    if not spectra:
        return None
    spectra = [a for a in spectra if a.label == spectra[0].label]  # one fit's (nsi-shift: the first well's)
    res = rec["result"]
    diag = res.get("diagnostics") or {}
    stem = _stem(folder, "coef", section.dataset, section.model, method)
    note = ""
    if "k_tilde_ensemble" in diag or "mean over" in str(diag.get("reported_fit", "")):
        note = " The reported value is the mean over the k~1 ensemble, so it differs from this one fit's estimate."
    elif "wells" in diag:
        note = " Spectra of the first well in its shifted basis x = z - z*; the reported values combine the wells."
    figure = Figure(
        f"Coefficient spectra, {method}",
        stem,
        f"Frequency-dependent coefficient estimates of {method} ({rec['run_id']}; paper Fig. 11/13): shaded, the "
        f"band the estimate averages; solid horizontal, that average; dashed, the reported coefficient.{note}",
    )
    if cache.fresh(stem, key):
        return figure
    band = diag.get("band_hz")
    band = band if isinstance(band, (list, tuple)) and len(band) == 2 else None
    fig, axes = new_figure(len(spectra), 2, width=8.5, height=2.4 * len(spectra) + 0.8, squeeze=False)
    for i, spectrum in enumerate(spectra):
        term = spectrum.term
        freq, c = _curve(arrays, spectrum)
        unit = section.unit(term) if term in section.terms else ""
        axes[i, 0].plot(freq, c.real, color="C0", lw=1.5, label="estimate at each frequency")
        axes[i, 1].plot(freq, c.imag, color="C0", lw=1.5)
        values = [c.real]
        if band is not None:
            for ax in axes[i]:
                ax.axvspan(band[0], band[1], color="C2", alpha=0.15, lw=0, label="band averaged over")
            inside = (freq >= band[0]) & (freq <= band[1])
            if inside.any():
                mean = float(np.mean(c.real[inside]))
                axes[i, 0].axhline(mean, color="C2", lw=1.2, label=f"this fit's estimate {sig(mean, 5)}")
                values.append(np.array([mean]))
        reported = res["coefficients"].get(term)
        if reported is not None:
            axes[i, 0].axhline(reported, color="black", ls="--", lw=1.0, label=f"reported {sig(reported, 5)}")
            values.append(np.array([reported]))
        lo = min(float(np.min(v)) for v in values)
        hi = max(float(np.max(v)) for v in values)
        pad = 0.1 * (hi - lo) if hi > lo else 0.01 * max(abs(hi), 1e-12)
        axes[i, 0].set_ylim(lo - pad, hi + pad)
        axes[i, 0].ticklabel_format(axis="y", useOffset=False)
        axes[i, 0].set_ylabel(f"{term}" + (f" ({unit})" if unit else ""))
        axes[i, 0].legend(fontsize=7, loc="best")
    axes[0, 0].set_title("real part")
    axes[0, 1].set_title("imaginary part")
    axes[-1, 0].set_xlabel("frequency (Hz)")
    axes[-1, 1].set_xlabel("frequency (Hz)")
    cache.save(fig, stem, key)
    return figure


def _array_figures(
    section: Section, method: str, rec: dict[str, Any], arrays: dict, folder: Path, cache: FigureCache
) -> list[Figure]:
    out = []
    tag = f"{method}, {rec['run_id']}"
    # every figure of one run's arrays is drawn from that run's result and arrays, and the section's units
    key = cache.key(
        "arrays",
        section.dataset,
        section.model,
        method,
        rec["run_id"],
        rec["result"],
        arrays,
        section.terms,
        {t: section.unit(t) for t in section.terms},
    )
    slices = _slices_figure(section, method, tag, arrays, folder, cache, key)
    if slices:
        out.append(slices)
    if "singular_values" in arrays:
        stem = _stem(folder, "sv", section.dataset, section.model, method)
        if not cache.fresh(stem, key):
            sv = np.asarray(arrays["singular_values"], dtype=float).ravel()
            fig, ax = new_figure(width=6.0, height=3.6)
            ax.semilogy(np.arange(1, sv.size + 1), sv, "o-", ms=3, label="singular values")
            order = (rec["result"].get("diagnostics") or {}).get("order")
            if isinstance(order, int) and 0 < order <= sv.size:
                ax.axvline(order + 0.5, color="C3", ls="--", lw=1.0, label=f"model order {order}")
            ax.set_xlabel("index")
            ax.set_ylabel("singular value (normalised channels)")
            ax.set_title(f"singular values ({tag})", fontsize=10)
            ax.legend(fontsize=8)
            cache.save(fig, stem, key)
        out.append(
            Figure(
                f"Singular values, {method}",
                stem,
                "Subspace singular values (paper Fig. 9/12); the gap after the model order separates the system "
                "from the noise.",
            )
        )
    for make in (_frf_figure, _coef_figure):
        fig = make(section, method, rec, arrays, folder, cache, key)
        if fig:
            out.append(fig)
    return out
