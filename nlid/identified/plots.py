"""Figures of one identified model, drawn on axes the caller may give (``ax=``).

Used by the plotting methods of :class:`nlid.identified.model.IdentifiedModel`, which
pass themselves: this module reads a fit through :class:`PlottedFit` and does
not import the identified model.
Without ``ax`` a new :class:`matplotlib.figure.Figure` is made
(:func:`nlid.report.plotting.new_figure`: no ``pyplot``, nothing opens a window);
every function returns the axes it drew on.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from ..base.dimensions import energy_unit, unit_of
from ..data.record import Record
from ..errors import InputError
from ..estimation.balance import regression_data
from ..report.plotting import new_figure
from ..scoring import ModelFit, damping_slice
from .tables import record_units

if TYPE_CHECKING:  # pragma: no cover
    from ..model.physics import Equilibria
    from ..scoring import Residual

__all__ = ["PlottedFit", "plot_stiffness", "plot_surface", "plot_damping_slice", "plot_residual"]

#: Largest number of data points drawn in a scatter (evenly subsampled).
MAX_POINTS = 4000


class PlottedFit(ModelFit, Protocol):
    """What the figures read of a fitted model (:class:`nlid.identified.model.IdentifiedModel` is one)."""

    @property
    def method(self) -> str:
        """The identifier's name (figure titles)."""

    @property
    def z_range(self) -> tuple[float, float] | None:
        """The displacement range of the estimation data (the figures' ``z`` axis)."""

    @property
    def equilibria(self) -> Equilibria | None:
        """The equilibria (marked on ``K(z)``)."""

    def elastic(self, z: np.ndarray) -> np.ndarray:
        """``K(z)`` (N)."""

    def potential(self, z: np.ndarray) -> np.ndarray:
        """``U(z)`` (J)."""

    def damping(self, z: np.ndarray, v: np.ndarray) -> np.ndarray:
        """``D(z, v)`` (N)."""

    def residual(self, record: Record, *, cutoff: float | None = None) -> Residual:
        """The residual ``f - m a - R(z, v)`` on a record."""


def _axes(ax: Any) -> Any:
    if ax is not None:
        return ax
    _, ax = new_figure()
    return ax


def _subsample(n: int) -> np.ndarray:
    return np.linspace(0, n - 1, min(n, MAX_POINTS)).astype(int)


def _z_grid(fit: PlottedFit, points: int = 400) -> np.ndarray:
    if fit.z_range is None:
        raise InputError("the model has no data range (z_range) to draw over")
    lo, hi = fit.z_range
    pad = 0.05 * (hi - lo)
    return np.linspace(lo - pad, hi + pad, points)


def plot_stiffness(fit: PlottedFit, ax: Any = None, *, potential: bool = False) -> Any:
    """``K(z)`` (N) or the potential ``U(z)`` (J, Eq. 7) with the equilibria (filled: stable).

    A model without a spring (no stiffness term that depends on ``z``, e.g. EMPS's ``v, sign(v), 1``) has no
    elastic force to draw: the axes say so, and name its constant term, a static load, instead of drawing it
    as ``K(z)``.
    """
    ax = _axes(ax)
    if not any(t.family == "stiffness" and not t.is_constant for t in fit.model.terms):
        constant = [t.name for t in fit.model.terms if t.family == "stiffness" and t.is_constant]
        note = "no spring in the model: no elastic force K(z)"
        if constant:
            value = fit.theta[fit.model.index(constant[0])]
            note += f"\n(its constant term {constant[0]} = {value:.4g} N is a static load)"
        ax.text(0.5, 0.5, note, transform=ax.transAxes, ha="center", va="center", fontsize="small", gid="no-spring")
        ax.set_xticks([])
        ax.set_yticks([])
        ax.set_title(f"{fit.method}: no elastic force")
        return ax
    z = _z_grid(fit)
    y = fit.potential(z) if potential else fit.elastic(z)
    ax.plot(z, y, color="C0", label="U(z)" if potential else "K(z)")
    ax.axhline(0.0, color="0.6", lw=0.8)
    eq = fit.equilibria
    if eq is not None:
        for zs, filled, label in ((eq.stable, True, "stable"), (eq.unstable, False, "unstable")):
            if not zs:
                continue
            zz = np.asarray(zs)
            yy = fit.potential(zz) if potential else np.zeros_like(zz)
            ax.plot(
                zz, yy, "o", ms=7, mfc="C3" if filled else "white", mec="C3", ls="none", label=f"{label} equilibria"
            )
    force, length = record_units(fit)
    ax.set_xlabel(f"z ({length})")
    ax.set_ylabel(f"U(z) ({energy_unit(force, length)})" if potential else f"K(z) ({force})")
    ax.set_title(f"{fit.method}: {'potential' if potential else 'elastic force'}")
    ax.legend(fontsize="small")
    return ax


def plot_surface(fit: PlottedFit, record: Record, ax: Any = None, *, cutoff: float | None = None) -> Any:
    """The elastic slice of the restoring surface: data ``f - m a - D_hat(z, v)`` against ``z``, and ``K(z)``."""
    ax = _axes(ax)
    res = fit.residual(record, cutoff=cutoff)
    elastic_data = res.restoring - fit.damping(res.z, res.v)
    keep = _subsample(res.z.size)
    ax.plot(res.z[keep], elastic_data[keep], ".", ms=2, color="0.55", alpha=0.6, label="data: f - m a - D(z, v)")
    z = _z_grid(fit)
    ax.plot(z, fit.elastic(z), color="C0", lw=2, label="identified K(z)")
    force, length = record_units(fit)
    ax.set_xlabel(f"z ({length})")
    ax.set_ylabel(f"force ({force})")
    band = "" if res.band_hz is None else f" (band {res.band_hz:.3g} Hz)"
    ax.set_title(f"{fit.method}: restoring surface, elastic slice{band}")
    ax.legend(fontsize="small")
    return ax


def plot_damping_slice(
    fit: PlottedFit, record: Record, z0: float, ax: Any = None, *, cutoff: float | None = None
) -> Any:
    """Damping force near ``z0``: data and the identified ``D(z0, v)`` (paper Fig. 21 b-d)."""
    if fit.mass is None:
        raise InputError("a damping slice needs the mass: the model has none")
    ax = _axes(ax)
    data = regression_data(record, fit.model, cutoff=cutoff)
    sl = damping_slice(data, fit.model, fit.theta, fit.mass, z0)
    keep = _subsample(sl.v.size)
    ax.plot(sl.v[keep], sl.measured[keep], ".", ms=2, color="0.55", alpha=0.6, label="data")
    ax.plot(sl.v_grid, sl.model, color="C1", lw=2, label="identified D(z0, v)")
    force, length = record_units(fit)
    ax.set_xlabel(f"v ({unit_of((length, 1), ('s', -1))})")
    ax.set_ylabel(f"damping force ({force})")
    ax.set_title(f"{fit.method}: |z - {z0:.3g} {length}| <= {sl.half_width:.2g} {length}")
    ax.legend(fontsize="small")
    return ax


def plot_residual(
    fit: PlottedFit, record: Record, against: str = "z", ax: Any = None, *, cutoff: float | None = None
) -> Any:
    """The residual ``f - m a - R_hat`` against ``z`` or ``v``, with its binned mean."""
    if against not in ("z", "v"):
        raise InputError(f"against must be 'z' or 'v', got {against!r}")
    ax = _axes(ax)
    res = fit.residual(record, cutoff=cutoff)
    x = res.z if against == "z" else res.v
    keep = _subsample(x.size)
    ax.plot(x[keep], res.r[keep], ".", ms=2, color="0.55", alpha=0.6, label="residual")
    edges = np.quantile(x, np.linspace(0, 1, 31))
    idx = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, edges.size - 2)
    counts = np.bincount(idx, minlength=edges.size - 1)
    sums = np.bincount(idx, weights=res.r, minlength=edges.size - 1)
    centers = 0.5 * (edges[:-1] + edges[1:])
    good = counts > 0
    ax.plot(centers[good], sums[good] / counts[good], "-", color="C3", lw=2, label="binned mean")
    ax.axhline(0.0, color="0.3", lw=0.8)
    force, length = record_units(fit)
    ax.set_xlabel(f"z ({length})" if against == "z" else f"v ({unit_of((length, 1), ('s', -1))})")
    ax.set_ylabel(f"f - m a - R(z, v) ({force})")
    ax.set_title(f"{fit.method}: residual against {against}")
    ax.legend(fontsize="small")
    return ax
