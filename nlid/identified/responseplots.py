"""Response figures of one identified model: its free run on a record, its linearised FRF per stable equilibrium.

Used by :meth:`nlid.identified.model.IdentifiedModel.plot_freerun` and
:meth:`~nlid.identified.model.IdentifiedModel.plot_frf`, which pass themselves (read
through :class:`nlid.identified.plots.PlottedFit`). As in :mod:`nlid.identified.plots`,
without ``ax`` a new :class:`matplotlib.figure.Figure` is made (no ``pyplot``)
and the main axes are returned.
"""

from __future__ import annotations

import textwrap
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..base.dimensions import unit_of
from ..base.formatting import sig
from ..contract.identifier import FigureArray, standard_figure_arrays
from ..data.record import Record
from ..errors import InputError, NlidError
from ..model import physics
from ..report.plotting import new_figure
from ..scoring import TransientRule, free_run_response
from .plots import PlottedFit
from .tables import record_units

__all__ = ["plot_freerun", "plot_frf", "declared_arrays", "linearised_frf"]

#: Frequencies of a drawn FRF.
FRF_POINTS = 2000


def _legend(ax: Any, title: str = "", width: int = 60, *, own: bool = False) -> None:
    """The legend, never over the curves (a free run or an FRF fills its axes: matplotlib's "best" still covers it).

    ``own``: the figure is this function's own, so the legend goes below its axes (constrained layout makes room);
    else it stands to the right of the user's axes.
    """
    title = "\n".join(textwrap.wrap(title, width)) or None
    if own:
        handles, labels = ax.get_legend_handles_labels()
        ax.figure.legend(
            handles,
            labels,
            loc="outside lower center",
            ncols=1 if max((len(x) for x in labels), default=0) > 45 else min(len(handles), 2),
            fontsize="small",
            title=title,
            title_fontsize="small",
        )
    else:
        ax.legend(
            loc="upper left",
            bbox_to_anchor=(1.02, 1.0),
            borderaxespad=0.0,
            fontsize="small",
            title=title,
            title_fontsize="small",
        )


def plot_freerun(
    fit: PlottedFit,
    record: Record,
    *,
    rule: TransientRule | str | Mapping[str, Any] | None = None,
    ax: Any = None,
) -> Any:
    """The measured displacement against the model's free run on the record's force, with the error.

    The free run is the one :func:`nlid.scoring.free_run_error` scores (:func:`nlid.scoring.free_run_response`)
    under the transient ``rule`` (default: the record's, :func:`nlid.scoring.default_rule`); the rule as applied
    titles the legend, the figures (NRMSE, fit) or why there are none the axes. Samples the rule does not score
    (an initialisation window) are shaded. Without ``ax``: two panels sharing the time axis, the displacements
    above and the error ``z_sim - z`` below; with ``ax``: one panel, the error the band between the two curves.

    Returns
    -------
    matplotlib.axes.Axes
        The axes of the displacements.
    """
    if fit.mass is None:
        raise InputError("a free run needs the mass: the model has none (give mass= when identifying)")
    run = free_run_response(fit, record, rule)
    t = record.t
    own = ax is None
    if own:
        _, (ax, below) = new_figure(2, 1, width=7.5, height=5.8, sharex=True, height_ratios=[2, 1])
    else:
        below = None
    if run.first > 0:
        span = (t[0], t[run.first])
        ax.axvspan(*span, color="0.88", lw=0, zorder=0, label=f"not scored: initialisation ({run.first} samples)")
        if below is not None:
            below.axvspan(*span, color="0.88", lw=0, zorder=0)
    ax.plot(t, run.z, color="0.15", lw=1.0, label="measured z")
    if run.z_sim is not None:
        ax.plot(t, run.z_sim, color="C1", lw=1.0, label="free run z_sim")
        if below is None:
            ax.fill_between(t, run.z, run.z_sim, color="C3", alpha=0.35, lw=0, label="error z_sim - z")
        else:
            below.plot(t, run.z_sim - run.z, color="C3", lw=0.8, label="z_sim - z")
    err = run.error
    if err.computed:
        what = f"NRMSE {sig(err.nrmse_percent, 3)} %, fit {sig(err.fit_percent, 3)} % over {err.scored_samples} samples"
    else:
        what = err.note
    ax.set_title(f"{fit.method}: free run ({what})", fontsize="medium", wrap=True)
    force, length = record_units(fit)
    ax.set_ylabel(f"z ({length})")
    _legend(ax, f"transient rule: {err.rule}" if err.rule else "", 90 if own else 40, own=own)
    last = ax if below is None else below
    last.set_xlabel("t (s)")
    if below is not None:
        below.axhline(0.0, color="0.5", lw=0.6)
        below.set_ylabel(f"z_sim - z ({length})")
    return ax


def declared_arrays(method: str, arrays: Mapping[str, Any]) -> tuple[FigureArray, ...]:
    """The arrays of a result that its method declares for figures (:meth:`nlid.plugin.Identifier.figure_arrays`).

    A method no longer installed is read with the keys :class:`nlid.plugin.Estimate` documents. Only
    declared arrays present with their frequency axis are returned.
    """
    from ..contract.registry import registry_for

    try:
        cls = registry_for(method).get(method)
    except NlidError:
        cls = None
    declare = getattr(cls, "figure_arrays", None)
    declared = declare(arrays) if callable(declare) else standard_figure_arrays(arrays)
    return tuple(a for a in declared if a.values in arrays and a.frequency in arrays)


def linearised_frf(modal: physics.Modal, mass: float, freq_hz: np.ndarray) -> np.ndarray:
    """Receptance ``1 / (k - m w^2 + i c w)`` (m/N) of the linearisation ``modal`` (its ``stiffness``, ``damping``)."""
    w = 2.0 * np.pi * np.asarray(freq_hz, dtype=float)
    c = modal.damping if np.isfinite(modal.damping) else 0.0
    return 1.0 / (modal.stiffness - mass * w**2 + 1j * c * w)


def _frf_axes(ax: Any, phase: bool) -> tuple[Any, Any]:
    if ax is None:
        if not phase:
            return new_figure(width=7.0, height=3.8)[1], None
        _, axes = new_figure(2, 1, width=7.0, height=5.6, sharex=True, height_ratios=[2, 1])
        return axes[0], axes[1]
    if isinstance(ax, Sequence | np.ndarray):
        axes = list(np.ravel(ax))
        if len(axes) != 2:
            raise InputError(f"ax must be one Axes (magnitude) or two (magnitude, phase), got {len(axes)}")
        return axes[0], axes[1]
    return ax, None


def plot_frf(
    fit: PlottedFit,
    *,
    ax: Any = None,
    freq: Sequence[float] | np.ndarray | None = None,
    phase: bool = True,
    identified: bool = True,
) -> Any:
    """The receptance of the model linearised at each stable equilibrium, magnitude and phase against Hz.

    At each stable equilibrium ``z*`` of ``K(z)``, ``H(w) = 1 / (k - m w^2 + i c w)`` with ``k = K'(z*)`` and
    ``c = dD/dv(z*, 0)`` (the modal parameters of :func:`nlid.model.physics.modal`, Eq. 8 and 22): one curve per
    equilibrium, its natural frequency dotted. A method that identifies an FRF of its own (NSI's
    underlying-linear system, declared through :meth:`nlid.plugin.Identifier.figure_arrays`) has it drawn
    too (``identified=False``: not).

    Parameters
    ----------
    ax
        One Axes (the magnitude only) or two (magnitude, phase); default: a new figure with both
        (``phase=False``: the magnitude only).
    freq
        Frequencies (Hz) to draw at, or ``(f_min, f_max)``; default: up to three times the highest natural
        frequency (and the method's own FRF's range).

    Returns
    -------
    matplotlib.axes.Axes
        The axes of the magnitude.
    """
    if fit.mass is None:
        raise InputError("an FRF needs the mass: the model has none (give mass= when identifying)")
    stable = list(fit.equilibria.stable) if fit.equilibria is not None else []
    modes = [
        m
        for m in physics.modal(fit.model, fit.theta, float(fit.mass), points=stable)
        if np.isfinite(m.stiffness) and m.stiffness > 0
    ]
    own = []
    if identified:
        arrays = getattr(fit, "arrays", None) or {}
        for declared in declared_arrays(fit.method, arrays):
            if declared.kind == "frf":
                f = np.asarray(arrays[declared.frequency], dtype=float).ravel()
                own.append((declared, f, np.asarray(arrays[declared.values]).ravel()))
    if not modes and not own:
        raise InputError("the model has no stable equilibrium to linearise around (and no FRF of its own)")
    if freq is None:
        f_max = max([3.0 * m.fn_hz for m in modes] + [float(f.max()) for _, f, _ in own])
        grid = np.linspace(f_max / FRF_POINTS, f_max, FRF_POINTS)
    else:
        grid = np.asarray(freq, dtype=float).ravel()
        if grid.size == 2:
            grid = np.linspace(grid[0], grid[1], FRF_POINTS)
        if grid.size < 2 or not np.all(np.isfinite(grid)) or np.any(grid < 0):
            raise InputError("freq must be frequencies in Hz (at least two, finite, not negative) or (f_min, f_max)")
    figure_own = ax is None
    mag, ph = _frf_axes(ax, phase)
    k_tilde = (getattr(fit, "diagnostics", None) or {}).get("k_tilde")
    force, length = record_units(fit)
    for i, (declared, f, h) in enumerate(own):
        label = f"{fit.method}: identified underlying-linear system"
        if k_tilde is not None:
            label += f" with k~1 = {sig(float(k_tilde), 3)} {unit_of((force, 1), (length, -1))} added"
        if declared.label:
            label += f" ({declared.label})"
        mag.semilogy(f, np.abs(h), color=f"C{len(modes) + i}", lw=1.6, alpha=0.8, label=label)
        if ph is not None:
            ph.plot(f, np.degrees(np.unwrap(np.angle(h))), color=f"C{len(modes) + i}", lw=1.6, alpha=0.8)
    for i, m in enumerate(modes):
        h = linearised_frf(m, float(fit.mass), grid)
        label = f"linearised at z* = {sig(m.equilibrium, 3)} {length}: fn {sig(m.fn_hz, 3)} Hz, zeta {sig(m.zeta, 2)}"
        mag.semilogy(grid, np.abs(h), "--" if own else "-", color=f"C{i}", lw=1.4, label=label)
        if ph is not None:
            ph.plot(grid, np.degrees(np.unwrap(np.angle(h))), "--" if own else "-", color=f"C{i}", lw=1.4)
        for a in (mag, ph):
            if a is not None:
                a.axvline(m.fn_hz, color=f"C{i}", lw=0.6, ls=":")
    mag.set_ylabel(f"|H| ({unit_of((length, 1), (force, -1))})")
    mag.set_title(f"{fit.method}: receptance linearised at each stable equilibrium", fontsize="medium")
    _legend(mag, own=figure_own)
    if ph is not None:
        ph.set_ylabel("phase (deg)")
        ph.set_xlabel("frequency (Hz)")
    else:
        mag.set_xlabel("frequency (Hz)")
    return mag
