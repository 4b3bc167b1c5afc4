"""Figures of a posterior: corner plot, trace plot, damping-force bands (paper Fig. 21 b-d).

Drawn with matplotlib's object-oriented API through :mod:`nlid.report.plotting`
(no pyplot); the corner plot is written here rather than taken from a
dependency. The functions take the posterior (:class:`~nlid.bayes.Posterior`)
and its bands (:class:`~nlid.bayes.DampingBand`) by their attributes: this
module imports nothing of :mod:`nlid.bayes`, which imports it to save figures.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from ..base.dimensions import unit_of
from ..report.plotting import new_figure

__all__ = ["corner_figure", "trace_figure", "damping_figure"]


def corner_figure(posterior: Any, bins: int = 40, truth: dict[str, float] | None = None):
    """Histograms of each coefficient (diagonal) and 2-D densities of each pair (below).

    Dashed lines: the 5 and 95 % quantiles; the orange mark is the
    identifier's estimate and black lines the truth: ``truth`` when given,
    else the reference values the record carried (``posterior.reference``,
    ``record.meta["reference"]``); ``truth={}`` draws none.

    The truth is always in view. The estimate is brought into view when it
    lies within :data:`ESTIMATE_REACH` of the posterior's own span beyond it
    (the posterior then keeps at least a third of the axis); one farther off
    (a large bias correction: Silverbox's was 2 700 sd before issue 35) is
    drawn at the edge of the axes, pointing out: an arrow with its value on
    the diagonal, a triangle below it.
    """
    from matplotlib.ticker import MaxNLocator

    samples = posterior.samples
    names = posterior.names
    if truth is None:
        truth = dict(getattr(posterior, "reference", None) or {})
    truth = {n: float(truth[n]) for n in names if n in truth and np.isfinite(truth[n])}
    d = len(names)
    size = max(3.0, 2.2 * d)
    fig, axes = new_figure(d, d, width=size, height=size, squeeze=False)
    lo, hi = np.quantile(samples, [0.001, 0.999], axis=0)
    # the truth stays in view, however far it is from the samples
    for i, name in enumerate(names):
        if name in truth:
            lo[i], hi[i] = min(lo[i], truth[name]), max(hi[i], truth[name])
    start = np.array([float(posterior.start[n]) for n in names])
    # the estimate too when it is near; a far one is drawn at the edge (off[i]: -1 below, +1 above the axis)
    span = np.where(hi > lo, hi - lo, np.maximum(np.abs(hi), 1.0))
    near = np.isfinite(start) & (start >= lo - ESTIMATE_REACH * span) & (start <= hi + ESTIMATE_REACH * span)
    lo = np.where(near, np.minimum(lo, start), lo)
    hi = np.where(near, np.maximum(hi, start), hi)
    span = hi - lo
    lo, hi = lo - 0.05 * span, hi + 0.05 * span
    off = np.where(start < lo, -1, np.where(start > hi, 1, 0))
    shown = np.clip(start, lo, hi)
    for i in range(d):
        for j in range(d):
            ax = axes[i, j]
            if j > i:
                ax.set_visible(False)
                continue
            if i == j:
                ax.hist(
                    samples[:, i], bins=bins, range=(lo[i], hi[i]), color="tab:blue", histtype="stepfilled", alpha=0.6
                )
                for q in np.quantile(samples[:, i], [0.05, 0.95]):
                    ax.axvline(q, color="tab:blue", ls="--", lw=1)
                if off[i]:
                    _edge_arrow(ax, shown[i], off[i], start[i])
                else:
                    ax.axvline(start[i], color="tab:orange", lw=1.5)
                if names[i] in truth:
                    ax.axvline(truth[names[i]], color="k", lw=1.2, gid="truth")
                ax.set_yticks([])
                ax.set_xlim(lo[i], hi[i])
            else:
                extent = [[lo[j], hi[j]], [lo[i], hi[i]]]
                h, xe, ye = np.histogram2d(samples[:, j], samples[:, i], bins=bins, range=extent)
                ax.pcolormesh(xe, ye, h.T, cmap="Blues", shading="flat")
                if off[i] or off[j]:  # a triangle on the edge pointing to where the estimate is
                    marker = {1: ">", -1: "<"}[off[j]] if off[j] else {1: "^", -1: "v"}[off[i]]
                    ax.plot(shown[j], shown[i], marker, color="tab:orange", ms=6, clip_on=False, gid="estimate-off")
                else:
                    ax.plot(start[j], start[i], "o", color="tab:orange", ms=4)
                if names[i] in truth and names[j] in truth:
                    ax.axvline(truth[names[j]], color="k", lw=0.8, gid="truth")
                    ax.axhline(truth[names[i]], color="k", lw=0.8, gid="truth")
                ax.set_xlim(lo[j], hi[j])
                ax.set_ylim(lo[i], hi[i])
            if i == d - 1:
                ax.set_xlabel(_label(posterior, names[j], size / d))
                ax.xaxis.set_major_locator(MaxNLocator(4))
                ax.tick_params(axis="x", labelrotation=45)
                for tick in ax.get_xticklabels():  # rotated about their right end: none reaches past the figure
                    tick.set_horizontalalignment("right")
                    tick.set_rotation_mode("anchor")
            else:
                ax.set_xticklabels([])
            if j == 0 and i > 0:
                ax.set_ylabel(_label(posterior, names[i], size / d))
            elif j > 0:
                ax.set_yticklabels([])
    estimate = "orange: identifier's estimate" + (", off the axes where it points" if np.any(off) else "")
    title = f"posterior ({estimate}; dashed: 5 / 95 %" + ("; black: truth)" if truth else ")")
    fig.suptitle(_wrapped(title, size, FONT_PT), fontsize=FONT_PT)
    fig.get_layout_engine().set(w_pad=0.08, h_pad=0.08)  # inches: room for the outermost tick labels
    return fig


#: How far beyond the posterior's span (in spans) the identifier's estimate is still brought into the corner
#: plot's view; beyond, it is drawn at the edge pointing out.
ESTIMATE_REACH = 1.0


def _edge_arrow(ax: Any, edge: float, side: int, value: float) -> None:
    """An orange arrow at the ``edge`` of the diagonal panel ``ax``, pointing out (``side`` +1: right), the value."""
    ax.annotate(
        f"estimate\n{value:.4g}",
        xy=(edge, 0.85),
        xycoords=("data", "axes fraction"),
        xytext=(-20 * side, 0),
        textcoords="offset points",
        ha="right" if side > 0 else "left",
        va="center",
        fontsize="small",
        color="tab:orange",
        bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.85},  # readable over the bars
        arrowprops={"arrowstyle": "->", "color": "tab:orange", "lw": 1.5, "shrinkA": 0, "shrinkB": 0},
        gid="estimate-off",
    )


def _label(posterior: Any, name: str, width_in: float) -> str:
    """``name (unit)``, the unit on a second line when the two do not fit one panel's width."""
    unit = posterior.unit(name) if hasattr(posterior, "unit") else ""
    if not unit:
        return name
    one = f"{name} ({unit})"
    return one if len(one) * 0.6 * LABEL_PT / 72.0 <= 0.95 * width_in else f"{name}\n({unit})"


#: Font size of the axis labels (points): matplotlib's default.
LABEL_PT = 10.0


#: Font size of the figure titles (points).
FONT_PT = 10.0


def _wrapped(text: str, width_in: float, font_pt: float) -> str:
    """``text`` broken into lines that fit ``width_in`` inches at ``font_pt`` (a wide glyph: 0.6 em)."""
    import textwrap

    chars = max(12, int(0.9 * width_in * 72.0 / (0.6 * font_pt)))
    return "\n".join(textwrap.wrap(text, chars))


def trace_figure(posterior: Any, max_walkers: int = 32):
    """Every walker's path for each coefficient; the grey span is the discarded burn-in."""
    chain = posterior.chains.chain
    names = posterior.names
    d = len(names)
    fig, axes = new_figure(d, 1, width=7.0, height=1.6 * d + 0.8, squeeze=False, sharex=True)
    steps = np.arange(chain.shape[0])
    shown = min(max_walkers, chain.shape[1])
    for i, name in enumerate(names):
        ax = axes[i, 0]
        ax.plot(steps, chain[:, :shown, i], color="k", alpha=0.15, lw=0.5)
        ax.axvspan(0, posterior.chains.burn, color="0.85", zorder=0)
        ax.set_ylabel(name)
    axes[-1, 0].set_xlabel("step")
    fig.suptitle(
        f"traces ({shown} of {chain.shape[1]} walkers); tau = "
        + ", ".join(f"{t:.0f}" for t in posterior.chains.tau)
        + f" steps; acceptance {posterior.chains.acceptance:.2f}"
    )
    return fig


def damping_figure(bands: Sequence[Any], band_hz: float | None = None, units: tuple[str, str] = ("N", "m")):
    """The measured damping force on each slice with the posterior's 5-95 % band (paper Fig. 21 b-d).

    Top row: the data and the posterior band of ``D(z0, v)`` (median line,
    5 and 95 % quantiles as lines bounding the shaded band, drawn above the
    data). The band is usually far narrower than the scatter of the data, so
    the bottom row shows it on its own scale: the 5 and 95 % quantiles minus
    the median, in N. With a filtered force balance (``band_hz``) the data are
    the in-band damping force: at high speed, where ``D`` has content above
    the band, they fall short of the curve ``D(z0, v)`` even for the true
    model. ``units``: the record's force and displacement units (``("V", "V")`` for a record in volts).
    """
    force, length = units
    n = len(bands)
    width_in = max(5.0, 4.0 * n)  # one slice: wide enough for its axis labels, the title wraps to it
    fig, axes = new_figure(2, n, width=width_in, height=6.0, squeeze=False, sharex="col", height_ratios=[2.2, 1])
    for k, band in enumerate(bands):
        ax, width = axes[0, k], axes[1, k]
        ax.plot(band.v, band.measured, ".", color="0.75", ms=2, zorder=1, label="data: R_e - K(z)")
        ax.fill_between(
            band.v_grid, band.q05, band.q95, color="tab:orange", alpha=0.5, zorder=3, label="posterior 5-95 %"
        )
        for q in (band.q05, band.q95):
            ax.plot(band.v_grid, q, color="tab:red", lw=0.8, zorder=4)
        ax.plot(band.v_grid, band.q50, color="tab:blue", lw=1.2, zorder=5, label="posterior median")
        ax.set_title(f"z = {band.z0:.4g} {length} (+/- {band.half_width:.2g} {length})")
        width.fill_between(band.v_grid, band.q05 - band.q50, band.q95 - band.q50, color="tab:orange", alpha=0.5)
        width.plot(band.v_grid, band.q05 - band.q50, color="tab:red", lw=0.8)
        width.plot(band.v_grid, band.q95 - band.q50, color="tab:red", lw=0.8)
        width.axhline(0.0, color="tab:blue", lw=1.0)
        width.set_xlabel(f"v ({unit_of((length, 1), ('s', -1))})")
    axes[0, 0].set_ylabel(f"damping force D ({force})")
    axes[1, 0].set_ylabel(f"5 and 95 % minus median ({force})")
    lines = ["posterior band of the damping force (bottom: its width on its own scale)"]
    if band_hz is not None:
        lines.append(f"data: restoring force minus stiffness, both below {band_hz:.3g} Hz (in-band D)")
    fig.suptitle("\n".join(_wrapped(line, width_in, FONT_PT) for line in lines), fontsize=FONT_PT)
    axes[0, 0].legend(loc="best", fontsize="small")
    return fig
