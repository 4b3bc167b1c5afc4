"""Where a person looks for a missing effect: the residual against z, v, the (z, v) plane and frequency.

The residual ``r = R_e - R_hat`` of a model (:class:`~nlid.discovery.result.ResidualView`)
is summarised by binned means, whose confidence bands use the *effective*
number of samples in each bin: the residual of a force balance formed in a
filtered band is correlated over ``tau_int`` samples, so a bin of ``n``
samples carries about ``n / tau_int`` independent ones. A band that excludes
zero over a range of ``z`` (or ``v``) is a systematic effect the model lacks:
an odd step at ``v = 0`` is dry friction, an S-shape in ``z`` a missing cubic
spring, a constant shift an offset.

Figures use :mod:`nlid.report.plotting` (object-oriented matplotlib, no pyplot). The
functions read the views and the result by their attributes: this module
imports nothing from :mod:`nlid.discovery.result` or the report, which use it.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from scipy import signal

from ..base.dimensions import unit_of
from ..report.plotting import new_figure
from .probes import Remaining, describe_remaining

__all__ = ["binned_mean", "binned_mean_2d", "residual_figure", "progress_figure", "remaining_figure", "CONFIDENCE_Z"]

#: Two-sided 95 % normal quantile of the confidence bands.
CONFIDENCE_Z = 1.959964
#: Fewest samples a bin needs to be drawn.
MIN_BIN_SAMPLES = 10
_SCATTER_POINTS = 4000


def binned_mean(
    x: np.ndarray, r: np.ndarray, tau: float = 1.0, bins: int = 20
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Mean of ``r`` in quantile bins of ``x`` with a 95 % confidence half-width.

    Parameters
    ----------
    x, r
        Abscissa and residual samples.
    tau
        Integrated autocorrelation time of ``r`` in samples: each bin's
        standard error is ``sd / sqrt(n / tau)``.
    bins
        Number of bins (equal counts, between the 0.5 % and 99.5 % quantiles).

    Returns
    -------
    centers, mean, half_width, counts : numpy.ndarray
        Bins with fewer than :data:`MIN_BIN_SAMPLES` samples are NaN.
    """
    x = np.asarray(x, dtype=float)
    r = np.asarray(r, dtype=float)
    edges = np.unique(np.quantile(x, np.linspace(0.005, 0.995, bins + 1)))
    idx = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, edges.size - 2)
    inside = (x >= edges[0]) & (x <= edges[-1])
    k = edges.size - 1
    counts = np.bincount(idx[inside], minlength=k).astype(float)
    sums = np.bincount(idx[inside], weights=r[inside], minlength=k)
    squares = np.bincount(idx[inside], weights=r[inside] ** 2, minlength=k)
    centers = np.bincount(idx[inside], weights=x[inside], minlength=k)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = sums / counts
        var = np.maximum(squares / counts - mean**2, 0.0) * counts / np.maximum(counts - 1, 1)
        half = CONFIDENCE_Z * np.sqrt(var / np.maximum(counts / max(tau, 1.0), 1.0))
        centers = centers / counts
    few = counts < MIN_BIN_SAMPLES
    for arr in (mean, half, centers):
        arr[few] = np.nan
    return centers, mean, half, counts


def binned_mean_2d(
    x: np.ndarray, y: np.ndarray, r: np.ndarray, bins: int = 24
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mean of ``r`` on a regular grid over ``(x, y)`` (0.5-99.5 % quantile ranges).

    Returns
    -------
    x_edges, y_edges, mean : numpy.ndarray
        ``mean[i, j]`` is NaN where a cell holds fewer than
        :data:`MIN_BIN_SAMPLES` samples.
    """
    x_edges = np.linspace(*np.quantile(x, [0.005, 0.995]), bins + 1)
    y_edges = np.linspace(*np.quantile(y, [0.005, 0.995]), bins + 1)
    counts, _, _ = np.histogram2d(x, y, [x_edges, y_edges])
    sums, _, _ = np.histogram2d(x, y, [x_edges, y_edges], weights=r)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = sums / counts
    mean[counts < MIN_BIN_SAMPLES] = np.nan
    return x_edges, y_edges, mean


def _units(units: dict[str, str] | None) -> tuple[str, str, str]:
    units = units or {}
    f = units.get("f", "N")
    z = units.get("z", "m")
    v = unit_of((z, 1), ("s", -1))
    return f, z, v


def _binned_band(ax, x, r, tau, color, alpha, label, *, band_label=None, zero=True):
    """Binned mean of ``r`` against ``x`` with its 95 % band (and the zero line); returns ``(centres, mean, half)``."""
    c, m, h, _ = binned_mean(x, r, tau)
    ax.fill_between(c, m - h, m + h, color=color, alpha=alpha, label=band_label)
    ax.plot(c, m, "-o", ms=3, color=color, label=label)
    if zero:
        ax.axhline(0.0, color="k", lw=0.8)
    return c, m, h


def residual_figure(view: Any, units: dict[str, str] | None = None, title: str | None = None):
    """Four panels: ``r`` against ``z`` and ``v`` (binned means, 95 % bands), over the (z, v) plane, and its PSD.

    Parameters
    ----------
    view
        The residual of one model.
    units
        ``{"f": ..., "z": ...}`` for the axis labels (default N and m).
    title
        Figure title (default ``view.label``).

    Returns
    -------
    matplotlib.figure.Figure
    """
    fu, zu, vu = _units(units)
    fig, axes = new_figure(2, 2, width=10.0, height=7.5)
    rng = np.random.default_rng(0)
    pick = rng.choice(view.r.size, size=min(_SCATTER_POINTS, view.r.size), replace=False)
    for ax, x, name, unit in ((axes[0, 0], view.z, "z", zu), (axes[0, 1], view.v, "v", vu)):
        ax.plot(x[pick], view.r[pick], ".", ms=1.5, color="0.75", rasterized=True, label="samples")
        c, m, h = _binned_band(
            ax, x, view.r, view.tau_samples, "C0", 0.3, "binned mean", band_label="95 % band (effective samples)"
        )
        spread = np.nanmax(np.abs(np.concatenate([m - h, m + h]))) if np.isfinite(m).any() else 1.0
        scatter = np.quantile(np.abs(view.r), 0.99)
        ax.set_ylim(-1.2 * max(spread, scatter), 1.2 * max(spread, scatter))
        ax.set_xlabel(f"{name} ({unit})")
        ax.set_ylabel(f"residual r ({fu})")
    axes[0, 0].legend(loc="best", fontsize=7)
    ax = axes[1, 0]
    xe, ye, mean = binned_mean_2d(view.z, view.v, view.r)
    limit = np.nanquantile(np.abs(mean), 0.98) if np.isfinite(mean).any() else 1.0
    mesh = ax.pcolormesh(xe, ye, mean.T, cmap="RdBu_r", vmin=-limit, vmax=limit, shading="flat")
    fig.colorbar(mesh, ax=ax, label=f"mean residual ({fu})")
    ax.set_xlabel(f"z ({zu})")
    ax.set_ylabel(f"v ({vu})")
    ax.set_title("binned mean over the (z, v) plane", fontsize=9)
    ax = axes[1, 1]
    nper = int(min(view.r.size, 4096))
    freq, p_r = signal.welch(view.r, fs=view.fs, nperseg=nper)
    _, p_re = signal.welch(view.restoring, fs=view.fs, nperseg=nper)
    top = view.fs / 2 if view.band_hz is None else min(view.fs / 2, 1.5 * view.band_hz)
    shown = freq <= top
    ax.semilogy(freq[shown], p_re[shown], color="0.6", lw=0.8, label="restoring force R_e = f - m a")
    ax.semilogy(freq[shown], p_r[shown], color="C3", lw=0.9, label="residual r")
    if view.band_hz is not None:
        ax.axvline(view.band_hz, color="k", ls=":", lw=0.8, label=f"equation band {view.band_hz:.3g} Hz")
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel(f"PSD ({fu}^2/Hz)")
    ax.legend(loc="best", fontsize=7)
    fig.suptitle(
        (title or view.label) + f"   (tau_int = {view.tau_samples:.3g} samples, N_eff = {view.n_eff:.4g})",
        fontsize=10,
    )
    return fig


def progress_figure(result: Any, labels: Sequence[str] | None = None):
    """Epsilon (Eq. 26) and the force residual, estimation and held-out, for each model of the loop."""
    states = result.states
    labels = list(labels) if labels else ["declared"] + [f"+ {s.effect}" for s in result.steps]
    x = np.arange(len(states))
    fig, ax = new_figure(1, 1, width=max(4.5, 1.4 * len(states) + 2.5), height=3.6)
    series = (
        ("eps", "epsilon, estimation", "C0", "-o"),
        ("eps_holdout", "epsilon, held-out", "C0", "--s"),
        ("force_residual", "force residual, estimation", "C1", "-o"),
        ("force_residual_holdout", "force residual, held-out", "C1", "--s"),
    )
    for key, label, color, style in series:
        ax.plot(x, [getattr(s.scores, key) for s in states], style, color=color, label=label)
    ax.set_xticks(x, labels, rotation=20, ha="right", fontsize=8)
    ax.set_ylabel("residual (%)")
    ax.set_ylim(bottom=0)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7)
    return fig


def remaining_figure(view: Any, remaining: Remaining, units: dict[str, str] | None = None):
    """What remains in a model's residual: against z by direction of motion (loops show memory), against v,
    and how much each probe predicts.

    Parameters
    ----------
    view
        The residual of the model (estimation record).
    remaining
        What the probes found (:func:`nlid.discovery.probes.probe_residual`).
    units
        ``{"f": ..., "z": ...}`` for the axis labels.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fu, zu, vu = _units(units)
    fig, axes = new_figure(1, 3, width=13.0, height=4.0)
    ax = axes[0]
    for mask, label, color in ((view.v > 0, "moving up (v > 0)", "C3"), (view.v < 0, "moving down (v < 0)", "C0")):
        if mask.sum() < 2 * MIN_BIN_SAMPLES:
            continue
        _binned_band(ax, view.z[mask], view.r[mask], view.tau_samples, color, 0.25, label, zero=False)
    ax.axhline(0.0, color="k", lw=0.8)
    ax.set_xlabel(f"z ({zu})")
    ax.set_ylabel(f"residual ({fu})")
    ax.set_title("against z, by direction (two branches: memory)", fontsize=9)
    ax.legend(fontsize=7)
    ax = axes[1]
    _binned_band(ax, view.v, view.r, view.tau_samples, "C1", 0.3, "binned mean, 95 % band")
    ax.set_xlabel(f"v ({vu})")
    ax.set_ylabel(f"residual ({fu})")
    ax.set_title("against v", fontsize=9)
    ax.legend(fontsize=7)
    ax = axes[2]
    names = list(remaining.probes)
    values = [100 * remaining.probes[n].explained for n in names]
    colors = ["C3" if remaining.probes[n].structured else "0.6" for n in names]
    ax.barh(names, values, color=colors)
    ax.axvline(100 * remaining.threshold, color="k", ls=":", lw=1, label=f"threshold {100 * remaining.threshold:g} %")
    ax.axvline(0.0, color="k", lw=0.8)
    ax.set_xlabel("held-out residual variance predicted (%)")
    ax.set_title("remaining-structure probes (cross-fitted)", fontsize=9)
    ax.set_xlim(left=min(-5.0, min(values) if values else 0.0))
    ax.legend(fontsize=7)
    text = describe_remaining(remaining)
    fig.suptitle(f"{view.label}: " + (text if len(text) < 140 else text[:137] + "..."), fontsize=9)
    return fig
