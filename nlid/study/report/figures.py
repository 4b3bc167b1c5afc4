"""Study figures (PNG and SVG through :mod:`nlid.plotting`, never pyplot).

* ``kz_<dataset>_<model>``: the identified elastic force K(z) (Eq. 6) of every
  successful run against the reference, equilibria marked, and the difference
  identified - reference below.
* ``bars_<dataset>_<model>``: epsilon (Eq. 26, estimation and held-out data)
  and the largest equilibrium error per method: bar = median, whisker =
  min-max over repetitions.
* From a result's ``arrays`` when the method provides them
  (:class:`nlid.identified.IdentifiedModel`): ``sv_*`` singular values
  (paper Fig. 9/12), ``frf_*`` the underlying-linear receptance (Fig. 10/15),
  ``coef_*`` the frequency-dependent coefficient estimates, real and imaginary
  parts (Fig. 11/13).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ... import physics
from ...plotting import new_figure, save_figure
from ...terms import Model
from .tables import Section

__all__ = ["section_figures", "Figure"]

_SAFE = re.compile(r"[^A-Za-z0-9_.+-]+")


class Figure:
    """A written figure: title, caption and the path without suffix."""

    def __init__(self, title: str, stem: Path, caption: str = "") -> None:
        self.title, self.stem, self.caption = title, stem, caption

    @property
    def png(self) -> Path:
        """The PNG file."""
        return self.stem.with_suffix(".png")


def _stem(folder: Path, *parts: str) -> Path:
    return folder / _SAFE.sub("_", "_".join(parts))


def _model(terms: list[str], px_roots: Any) -> Model:
    return Model.from_spec(terms, defaults=False, px_roots=px_roots)


def _colors(n: int) -> list[Any]:
    from matplotlib import colormaps

    cmap = colormaps["tab10"]
    return [cmap(i % 10) for i in range(n)]


def section_figures(section: Section, records: list[dict[str, Any]], store: Any, folder: Path) -> list[Figure]:
    """Every figure of one dataset x model; returns what was written."""
    figures: list[Figure] = []
    recs = [
        r
        for r in records
        if r["row"]["dataset"] == section.dataset and r["row"]["model"] == section.model and r.get("result")
    ]
    if not recs:
        return figures
    kz = _kz_figure(section, recs, folder)
    if kz:
        figures.append(kz)
    bars = _bars_figure(section, folder)
    if bars:
        figures.append(bars)
    rms = _rms_figure(section, folder)
    if rms:
        figures.append(rms)
    for method in section.methods:
        for rec in recs:
            if rec["row"]["method"] == method and rec.get("arrays"):
                figures += _array_figures(section, method, rec, store.arrays(rec["run_id"]), folder)
                break
    return figures


def _kz_figure(section: Section, recs: list[dict[str, Any]], folder: Path) -> Figure | None:
    ref = section.reference or {}
    z_lo = min(r["row"]["z_min"] for r in recs)
    z_hi = max(r["row"]["z_max"] for r in recs)
    z = np.linspace(z_lo, z_hi, 400)
    k_ref = None
    if ref.get("terms") and ref.get("coefficients"):
        ref_model = _model(ref["terms"], ref.get("px_roots"))
        k_ref = physics.elastic(ref_model, ref["coefficients"], z)
    fig, axes = new_figure(2 if k_ref is not None else 1, 1, width=7.0, height=6.0 if k_ref is not None else 4.0)
    ax = axes[0] if k_ref is not None else axes
    if k_ref is not None:
        ax.plot(z, k_ref, color="black", lw=2.0, label="reference")
        eq = ref.get("equilibria") or []
        ax.plot(eq, np.zeros(len(eq)), "o", mfc="none", mec="black", ms=10, label="reference stable equilibria")
    colors = dict(zip(section.methods, _colors(len(section.methods)), strict=True))
    labelled: set[str] = set()
    for rec in recs:
        res, method = rec["result"], rec["row"]["method"]
        model = _model(res["terms"], res.get("px_roots"))
        k = physics.elastic(model, res["coefficients"], z)
        label = method if method not in labelled else None
        labelled.add(method)
        ax.plot(z, k, color=colors[method], lw=0.8, alpha=0.8, label=label)
        stable = (res.get("equilibria") or {}).get("stable", [])
        ax.plot(stable, np.zeros(len(stable)), "x", color=colors[method], ms=7)
        if k_ref is not None:
            axes[1].plot(z, k - k_ref, color=colors[method], lw=0.8, alpha=0.8)
    ax.axhline(0.0, color="0.6", lw=0.5)
    ax.set_ylabel("K(z) (N)")
    ax.set_title(f"{section.dataset} / {section.model}: elastic restoring force, equilibria (x: identified)")
    ax.legend(fontsize=8)
    if k_ref is not None:
        axes[1].axhline(0.0, color="0.6", lw=0.5)
        axes[1].set_ylabel("identified - reference (N)")
        axes[1].set_xlabel("z (m)")
    else:
        ax.set_xlabel("z (m)")
    stem = _stem(folder, "kz", section.dataset, section.model)
    save_figure(fig, stem)
    return Figure(
        "Elastic restoring force K(z)",
        stem,
        "Identified K(z) of every successful run (one line per repetition) against the reference; "
        "circles: reference stable equilibria, crosses: identified ones.",
    )


def _stats(frame: pd.DataFrame, column: str, methods: list[str]) -> tuple[list[float], list[float], list[float]]:
    med, lo, hi = [], [], []
    for m in methods:
        sub = frame[(frame["method"] == m) & (frame["status"] == "ok")]
        x = pd.to_numeric(sub[column], errors="coerce").to_numpy(dtype=float) if column in sub else np.array([])
        x = x[np.isfinite(x)]
        if x.size:
            med.append(float(np.median(x)))
            lo.append(float(np.median(x) - x.min()))
            hi.append(float(x.max() - np.median(x)))
        else:
            med.append(np.nan)
            lo.append(0.0)
            hi.append(0.0)
    return med, lo, hi


def _bars_figure(section: Section, folder: Path) -> Figure | None:
    frame = section.frame
    methods = [m for m in section.methods if (frame["method"] == m).any()]
    panels = [("eps_percent", "eps, estimation data"), ("eps_holdout_percent", "eps, held-out data")]
    panels = [p for p in panels if p[0] in frame.columns]
    has_eq = "eq_error_max_pct" in frame.columns or "eq_error_pct:s1" in frame.columns
    fig, axes = new_figure(1, 2 if has_eq else 1, width=9.0 if has_eq else 5.5, height=3.8)
    ax_eps = axes[0] if has_eq else axes
    x = np.arange(len(methods))
    width = 0.8 / max(1, len(panels))
    for i, (col, label) in enumerate(panels):
        med, lo, hi = _stats(frame, col, methods)
        ax_eps.bar(x + (i - (len(panels) - 1) / 2) * width, med, width, yerr=[lo, hi], capsize=4, label=label)
    ax_eps.set_xticks(x, methods)
    ax_eps.set_ylabel("eps (Eq. 26) %")
    ax_eps.set_title("residual of the restoring force")
    ax_eps.legend(fontsize=8)
    if has_eq:
        eq_cols = sorted(c for c in frame.columns if c.startswith("eq_error_pct:"))
        width = 0.8 / max(1, len(eq_cols))
        for i, col in enumerate(eq_cols):
            med, lo, hi = _stats(frame, col, methods)
            label = f"stable equilibrium {col.split(':')[1]}"
            axes[1].bar(x + (i - (len(eq_cols) - 1) / 2) * width, med, width, yerr=[lo, hi], capsize=4, label=label)
        for j, m in enumerate(methods):
            ok = frame[(frame["method"] == m) & (frame["status"] == "ok")]
            if "eq_missing" in ok and pd.to_numeric(ok["eq_missing"], errors="coerce").fillna(0).max() > 0:
                axes[1].annotate("missed a well", (x[j], 0), ha="center", va="bottom", color="red", fontsize=8)
        axes[1].set_xticks(x, methods)
        axes[1].set_ylabel("|equilibrium error| %")
        axes[1].set_title("stable equilibria")
        axes[1].legend(fontsize=8)
    stem = _stem(folder, "bars", section.dataset, section.model)
    save_figure(fig, stem)
    return Figure(
        "Residual and equilibrium errors per method",
        stem,
        "Bars: median over repetitions; whiskers: minimum to maximum.",
    )


def _rms_figure(section: Section, folder: Path) -> Figure | None:
    """Grouped bars of each term's RMS contribution to R per method (paper Fig. 22)."""
    frame = section.frame
    terms = section.terms_with("rms:")
    methods = [m for m in section.methods if (frame["method"] == m).any()]
    if not terms or not methods:
        return None
    fig, ax = new_figure(width=max(6.0, 1.1 * len(terms) + 2.0), height=3.8)
    x = np.arange(len(terms))
    width = 0.8 / len(methods)
    for i, method in enumerate(methods):
        med = [_stats(frame, f"rms:{t}", [method])[0][0] for t in terms]
        ax.bar(x + (i - (len(methods) - 1) / 2) * width, med, width, label=method)
    ax.set_yscale("log")
    ax.set_xticks(x, terms, rotation=30, ha="right", fontsize=8)
    ax.set_ylabel("RMS contribution (N)")
    ax.set_title(f"{section.dataset} / {section.model}: terms of the identified restoring force")
    ax.legend(fontsize=8)
    stem = _stem(folder, "rms", section.dataset, section.model)
    save_figure(fig, stem)
    return Figure(
        "RMS contribution of each term",
        stem,
        "RMS of theta_i g_i(z, v) over the record, median over repetitions (paper Fig. 22); log scale.",
    )


def _slices_figure(section: Section, method: str, tag: str, arrays: dict, folder: Path) -> Figure | None:
    """Measured damping force near each slice position against the identified D(z0, v) (Fig. 21 b-d)."""
    count = 0
    while f"slice{count}:z0" in arrays:
        count += 1
    if not count:
        return None
    fig, axes = new_figure(1, count, width=3.2 * count + 0.6, height=3.4, squeeze=False)
    for k in range(count):
        ax = axes[0, k]
        z0 = float(np.asarray(arrays[f"slice{k}:z0"]))
        ax.plot(arrays[f"slice{k}:v"], arrays[f"slice{k}:measured"], ".", color="0.6", ms=2, label="measured")
        ax.plot(arrays[f"slice{k}:v_grid"], arrays[f"slice{k}:model"], color="C0", lw=1.5, label="identified")
        ax.set_title(f"z near {z0:+.3g} m", fontsize=9)
        ax.set_xlabel("v (m/s)")
    axes[0, 0].set_ylabel("damping force D (N)")
    axes[0, 0].legend(fontsize=8)
    stem = _stem(folder, "slices", section.dataset, section.model, method)
    save_figure(fig, stem)
    return Figure(
        f"Damping force slices, {method}",
        stem,
        f"Measured R_e - K(z) of the samples near each position (grey) against the identified D(z0, v) ({tag}); "
        "paper Fig. 21 b-d.",
    )


def _array_figures(section: Section, method: str, rec: dict[str, Any], arrays: dict, folder: Path) -> list[Figure]:
    out = []
    tag = f"{method}, {rec['run_id']}"
    slices = _slices_figure(section, method, tag, arrays, folder)
    if slices:
        out.append(slices)
    if "singular_values" in arrays:
        sv = np.asarray(arrays["singular_values"], dtype=float).ravel()
        fig, ax = new_figure(width=6.0, height=3.6)
        ax.semilogy(np.arange(1, sv.size + 1), sv, "o-", ms=3)
        ax.set_xlabel("index")
        ax.set_ylabel("singular value")
        ax.set_title(f"singular values ({tag})")
        stem = _stem(folder, "sv", section.dataset, section.model, method)
        save_figure(fig, stem)
        out.append(Figure(f"Singular values, {method}", stem, "Subspace singular values (paper Fig. 9/12)."))
    if "frf" in arrays and "frf_frequency_hz" in arrays:
        freq = np.asarray(arrays["frf_frequency_hz"], dtype=float).ravel()
        h = np.asarray(arrays["frf"]).ravel()
        fig, axes = new_figure(2, 1, width=6.5, height=5.0, sharex=True)
        axes[0].semilogy(freq, np.abs(h))
        axes[0].set_ylabel("|H| (m/N)")
        axes[0].set_title(f"underlying-linear FRF ({tag})")
        axes[1].plot(freq, np.degrees(np.unwrap(np.angle(h))))
        axes[1].set_ylabel("phase (deg)")
        axes[1].set_xlabel("frequency (Hz)")
        stem = _stem(folder, "frf", section.dataset, section.model, method)
        save_figure(fig, stem)
        out.append(Figure(f"Underlying-linear FRF, {method}", stem, "Receptance (paper Fig. 10/15)."))
    spectra = sorted(k for k in arrays if k.startswith("coef_spectrum:"))
    if spectra and "coef_frequency_hz" in arrays:
        freq = np.asarray(arrays["coef_frequency_hz"], dtype=float).ravel()
        fig, axes = new_figure(len(spectra), 2, width=8.0, height=2.2 * len(spectra) + 0.6, squeeze=False)
        for i, key in enumerate(spectra):
            term = key.split(":", 1)[1]
            c = np.asarray(arrays[key]).ravel()
            axes[i, 0].plot(freq, c.real)
            axes[i, 1].plot(freq, c.imag)
            value = rec["result"]["coefficients"].get(term)
            if value is not None:
                axes[i, 0].axhline(value, color="black", ls="--", lw=0.8)
            axes[i, 0].set_ylabel(term)
        axes[0, 0].set_title("real part")
        axes[0, 1].set_title("imaginary part")
        axes[-1, 0].set_xlabel("frequency (Hz)")
        axes[-1, 1].set_xlabel("frequency (Hz)")
        stem = _stem(folder, "coef", section.dataset, section.model, method)
        save_figure(fig, stem)
        out.append(
            Figure(
                f"Coefficient spectra, {method}",
                stem,
                f"Frequency-dependent coefficient estimates of {tag}; dashed: the identified value (Fig. 11/13).",
            )
        )
    return out
