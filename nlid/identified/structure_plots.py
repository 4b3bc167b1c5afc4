"""Figures of a structure, drawn on axes the caller may give (``ax=``).

Without ``ax`` a new :class:`matplotlib.figure.Figure` is made
(:func:`nlid.report.plotting.new_figure`: no ``pyplot``, nothing opens a window);
every function returns the axes it drew on.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import InputError
from ..report.plotting import new_figure

if TYPE_CHECKING:  # pragma: no cover
    from ..data.record import Record
    from ..model.structure import StructuralModel

__all__ = ["plot_elements", "plot_frf"]


def _axes(ax: Any, count: int, nrows: int, ncols: int, width: float, height: float) -> list[Any]:
    if ax is None:
        _, axes = new_figure(nrows, ncols, width=width, height=height, squeeze=False)
        return list(np.asarray(axes).ravel())[:count]
    axes = list(np.asarray(ax, dtype=object).ravel())
    if len(axes) < count:
        raise InputError(f"ax= needs {count} axes (one per panel), got {len(axes)}")
    return axes[:count]


def plot_elements(
    model: StructuralModel,
    record: Record | None = None,
    ax: Any = None,
    *,
    z_range: Sequence[Sequence[float]] | None = None,
) -> list[Any]:
    """The force of each element, ``theta_e g_e``, against its relative coordinate.

    Stiffness elements are drawn against the relative displacement (at rest),
    damping elements against the relative velocity (at zero relative
    displacement), memory elements along the record's motion (a hysteresis
    loop). With a record, the range is the one the data cover; without, the
    relative ranges implied by ``z_range`` (velocity: up to ``2 pi 10 Hz``
    times the displacement range) and memory elements need the record.

    Parameters
    ----------
    model
        The structure.
    record
        Data giving the ranges (and the path of memory elements).
    ax
        One axes per element (a sequence), or ``None`` for a new figure.
    z_range
        ``(min, max)`` displacement of each DOF, when there is no record.

    Returns
    -------
    list of matplotlib.axes.Axes
    """
    elements = model.elements
    count = len(elements)
    if count == 0:
        raise InputError("the structure has no elements to plot")
    axes = _axes(ax, count, 1, count, 3.2 * count, 3.0)
    theta = model.theta
    if record is not None:
        x_all, xd_all = elements.relative(record.z, record.v if record.v is not None else None)
    elif z_range is not None:
        ranges = np.asarray(z_range, dtype=float)
        corners = np.array(np.meshgrid(*ranges, indexing="ij")).reshape(model.n_dofs, -1).T
        x_all, _ = elements.relative(corners)
        xd_all = None
    else:
        raise InputError("plot_elements needs a record or z_range to know where to draw")
    for k, (e, axis) in enumerate(zip(elements, axes, strict=True)):
        roots = elements.roots_of(e)
        lo, hi = float(x_all[:, k].min()), float(x_all[:, k].max())
        if e.family == "memory":
            if record is None:
                raise InputError(f"{e.name} is a memory element: its loop needs a record")
            x = x_all[:, k]
            axis.plot(x, theta[k] * e.evaluate(x, None, roots), lw=0.6)
            axis.set_xlabel(f"{e.name.split('(')[1].split(',')[0]} (m)")
        elif e.family == "damping":
            if xd_all is not None:
                vlo, vhi = float(xd_all[:, k].min()), float(xd_all[:, k].max())
            else:
                span = 2 * np.pi * 10.0 * max(abs(lo), abs(hi))
                vlo, vhi = -span, span
            xd = np.linspace(vlo, vhi, 401)
            axis.plot(xd, theta[k] * e.evaluate(np.zeros_like(xd), xd, roots))
            axis.set_xlabel(("v" if e.to_ground else "relative velocity") + f" of {e.i}-{e.j or 'ground'} (m/s)")
        else:
            x = np.linspace(lo, hi, 401)
            axis.plot(x, theta[k] * e.evaluate(x, None, roots))
            axis.set_xlabel(("z" if e.to_ground else "relative displacement") + f" of {e.i}-{e.j or 'ground'} (m)")
        axis.set_title(e.name, fontsize="medium")
        axis.set_ylabel("force (N)")
        axis.grid(True, alpha=0.3)
    return axes


def plot_frf(
    model: StructuralModel,
    ax: Any = None,
    *,
    at: Sequence[float] | None = None,
    frequency_hz: Sequence[float] | None = None,
) -> list[Any]:
    """``|H_ij(f)|`` of the receptance matrix, one panel per pair (response ``i``, force ``j``).

    Parameters
    ----------
    model
        The structure: its underlying linear system, or linearised at ``at``.
    ax
        ``n * n`` axes (row-major: response, then force), or ``None`` for a new figure.
    at
        A rest position to linearise at (e.g. a stable equilibrium); default the underlying linear system.
    frequency_hz
        Frequencies; default 0 to twice the highest natural frequency, 2000 points.

    Returns
    -------
    list of matplotlib.axes.Axes
    """
    from ..model.modes import linear_modes

    n = model.n_dofs
    if frequency_hz is None:
        point = [0.0] * n if at is None else list(at)
        K = model.K if at is None else model.tangent_stiffness(point)
        C = model.C if at is None else model.tangent_damping(point)
        top = linear_modes(model.M, C, K, point).undamped_hz
        fmax = 2.0 * float(np.max(top)) if top.size and np.max(top) > 0 else 100.0
        frequency_hz = np.linspace(0.0, fmax, 2000)
    freq = np.asarray(frequency_hz, dtype=float)
    H = model.frf(freq, at)
    axes = _axes(ax, n * n, n, n, 2.6 * n + 1, 2.2 * n + 0.6)
    for i in range(n):
        for j in range(n):
            axis = axes[i * n + j]
            axis.semilogy(freq, np.abs(H[:, i, j]))
            axis.set_title(f"z{i + 1} / f{j + 1}", fontsize="small")
            axis.grid(True, alpha=0.3)
            if i == n - 1:
                axis.set_xlabel("frequency (Hz)")
            if j == 0:
                axis.set_ylabel("|H| (m/N)")
    return axes
