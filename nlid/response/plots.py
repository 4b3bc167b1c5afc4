"""The response figure: amplitude against frequency, stable and unstable branches, jumps, backbone, band, measurements.

As every figure of nlid: matplotlib's object-oriented API on the axes given
(``ax=``) or on a new :class:`matplotlib.figure.Figure` (no ``pyplot``), and the
axes are returned.

* stable branches are solid lines, unstable ones dashed (thin, lighter);
* folds are marked with a triangle, and the jump a slow sweep makes there with
  a dotted arrow to where it lands (up-sweep and down-sweep);
* the cross-well stretches of a double well's curves are overdrawn with dots;
* backbones are dash-dotted, in grey;
* the band over posterior draws is shaded, its unresolved frequencies hatched;
* measured points are open circles.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from ..report.plotting import new_figure

if TYPE_CHECKING:  # pragma: no cover
    from .result import FrequencyResponse

__all__ = ["plot_response"]


def _segments(mask: np.ndarray) -> list[slice]:
    """Runs of ``True`` in ``mask`` as slices, each widened by one point to join its neighbours."""
    out = []
    k = 0
    n = mask.size
    while k < n:
        if mask[k]:
            j = k
            while j < n and mask[j]:
                j += 1
            out.append(slice(max(k - 1, 0), min(j + 1, n)))
            k = j
        else:
            k += 1
    return out


def _values(curve, quantity: str, d: int) -> np.ndarray:
    if quantity == "amplitude":
        return curve.amplitude(d + 1)
    if quantity == "peak":
        return curve.peak(d + 1)
    raise ValueError(f"quantity must be 'amplitude' or 'peak', got {quantity!r}")


def plot_response(
    response: FrequencyResponse, ax: Any = None, *, dof: int | str | None = None, quantity: str = "amplitude"
) -> Any:
    """Draw a :class:`~nlid.response.result.FrequencyResponse` (module docstring); returns the axes.

    Parameters
    ----------
    response
        What to draw.
    ax
        Axes to draw on (default: a new figure).
    dof
        The DOF (number or name); default the forced one.
    quantity
        ``"amplitude"`` (first harmonic, what a stepped-sine test measures) or ``"peak"`` (``max |z - c_0|``).
    """
    if ax is None:
        _, ax = new_figure(width=7.0, height=4.4)
    d = response._lead if dof is None else (response.dofs.index(dof) if isinstance(dof, str) else int(dof) - 1)
    forces = response.forces or tuple(dict.fromkeys(float(c.force[0]) for c in response.curves))
    colours = {F: f"C{k % 10}" for k, F in enumerate(forces)}
    shown: set[float] = set()
    for curve in response.curves:
        colour = colours.get(float(curve.force[0]), "C0")
        x = curve.frequency_hz if curve.parameter == "frequency" else curve.force
        y = _values(curve, quantity, d)
        label = None
        if float(curve.force[0]) not in shown:
            label = (
                f"F = {curve.force[0]:.3g} N" if curve.parameter == "frequency" else f"{curve.frequency_hz[0]:.4g} Hz"
            )
            shown.add(float(curve.force[0]))
        for s in _segments(curve.stable):
            ax.plot(x[s], y[s], "-", color=colour, lw=1.6, label=label)
            label = None
        for s in _segments(~curve.stable):
            ax.plot(x[s], y[s], "--", color=colour, lw=1.0, alpha=0.7)
        cross = np.array([m == "cross-well" for m in curve.labels])
        if cross.any():
            ax.plot(x[cross], y[cross], ".", color=colour, ms=3)
        for e in curve.folds:
            ax.plot(x[e.index], y[e.index], "v", color=colour, ms=6)
        if curve.parameter == "frequency":
            _jumps(ax, curve, y, colour)
    if any(c.labels and "cross-well" in c.labels for c in response.curves):
        ax.plot([], [], "k.", ms=3, label="cross-well")
    for b in response.backbones:
        yb = b.amplitude(d + 1) if quantity == "amplitude" else b.peak(d + 1)
        ax.plot(
            b.frequency_hz,
            yb,
            "-.",
            color="0.45",
            lw=1.0,
            label="backbone" if b.label == "backbone" else f"backbone, {b.label}",
        )
    if response.uncertainty is not None:
        response.uncertainty.draw(ax, d, colours)
    if response.measured is not None:
        response.measured.draw(ax, d)
    ax.plot([], [], "--", color="0.3", lw=1.0, label="unstable (Hill)")
    if any(c.folds for c in response.curves):
        ax.plot([], [], "v", color="0.3", label="fold (turning point)")
    lo, hi = response.band_hz
    if hi > lo:
        ax.set_xlim(lo, hi)
    ax.set_xlabel("frequency (Hz)" if response.curves[0].parameter == "frequency" else "force amplitude (N)")
    what = "first-harmonic amplitude" if quantity == "amplitude" else "peak |z - mean|"
    ax.set_ylabel(f"{what} of {response.dofs[d]} (m)")
    ax.legend(fontsize="small")
    ax.grid(True, alpha=0.3)
    return ax


def _jumps(ax: Any, curve, y: np.ndarray, colour: str) -> None:
    """Dotted arrows where a slow sweep leaves the curve at a fold and lands on the curve further on."""
    f = curve.frequency_hz
    for direction in ("up", "down"):
        idx = curve.sweep(direction)
        for a, b in zip(idx[:-1], idx[1:], strict=True):
            if abs(int(b) - int(a)) <= 1:
                continue
            # the landing amplitude at the fold's frequency, between b and its neighbour towards a
            c = b - 1 if b > a else b + 1
            lo, hi = sorted((f[c], f[b]))
            land = (
                y[b]
                if hi == lo or not lo <= f[a] <= hi
                else float(
                    np.interp(
                        f[a], [f[c], f[b]][:: 1 if f[c] < f[b] else -1], [y[c], y[b]][:: 1 if f[c] < f[b] else -1]
                    )
                )
            )
            ax.annotate(
                "",
                xy=(f[a], land),
                xytext=(f[a], y[a]),
                arrowprops={"arrowstyle": "->", "color": colour, "ls": ":", "lw": 1.0},
            )
