"""Static equilibria of a structure: every solution of ``K z + s + sum_e b_e theta_e k_e(x_e) = 0`` in a range.

:func:`equilibria` finds them by multistart Newton: damped Newton iterations
(backtracking on the norm of the residual force, steps limited to half the
range of each DOF) from a grid of starting points over the range of each DOF
plus the linear solution, run together as one batch. Converged points (full
Newton step below ``1e-10`` of each DOF's range and residual force below
``1e-8`` of the force scale) are merged when closer than ``1e-6`` of the
range, and those farther than half the range outside it are dropped (as for
one DOF, :func:`nlid.model.physics.equilibria`). An equilibrium is *stable* when
the symmetric part of the tangent stiffness ``dR/dz`` there is positive
definite (the potential has a minimum); memory elements contribute their
initial slope, damping elements nothing (as for one DOF).

A model without stiffness-family elements has one equilibrium,
``-K^-1 s``, computed directly.
"""

from __future__ import annotations

import contextlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import InputError

if TYPE_CHECKING:  # pragma: no cover
    from .structure import StructuralModel

__all__ = ["StructureEquilibria", "equilibria", "as_ranges", "MAX_STARTS"]

#: About how many starting points the grid has (``m`` per DOF with ``m^n`` near this, 3 to 41 per DOF).
MAX_STARTS = 512
_ITERATIONS = 80


@dataclass(frozen=True)
class StructureEquilibria:
    """Equilibrium positions (m) of a structure, each a tuple of ``n`` displacements, sorted.

    Attributes
    ----------
    stable, unstable
        The equilibria where the tangent stiffness is (is not) positive definite.
    """

    stable: tuple[tuple[float, ...], ...]
    unstable: tuple[tuple[float, ...], ...]

    @property
    def all(self) -> tuple[tuple[float, ...], ...]:
        """Every equilibrium, sorted."""
        return tuple(sorted(self.stable + self.unstable))

    def to_dict(self) -> dict[str, list[list[float]]]:
        """``{"stable": [[z1, z2, ...], ...], "unstable": [...]}``."""
        return {"stable": [list(p) for p in self.stable], "unstable": [list(p) for p in self.unstable]}

    @classmethod
    def from_dict(cls, data: Mapping[str, Sequence[Sequence[float]]]) -> StructureEquilibria:
        """Inverse of :meth:`to_dict`."""
        return cls(
            stable=tuple(sorted(tuple(float(x) for x in p) for p in data.get("stable", ()))),
            unstable=tuple(sorted(tuple(float(x) for x in p) for p in data.get("unstable", ()))),
        )


def as_ranges(z_range: Any, n: int) -> np.ndarray:
    """``(n, 2)`` array of ``(min, max)`` per DOF from a pair (every DOF), a list of pairs, or ``(N, n)`` samples.

    Raises
    ------
    InputError
        A shape that fits none of these, values that are not finite, or an empty range.
    """
    arr = np.asarray(z_range, dtype=float)
    if arr.shape == (2,):
        arr = np.tile(arr, (n, 1))
    elif arr.ndim == 2 and arr.shape[1] == n and arr.shape[0] != 2:
        arr = np.stack([arr.min(axis=0), arr.max(axis=0)], axis=1)
    elif arr.shape == (2, n) and n != 2:
        arr = arr.T
    if arr.shape != (n, 2) or not np.all(np.isfinite(arr)):
        raise InputError(
            f"z_range must be (min, max), one (min, max) per DOF or samples (N, {n}); got shape {arr.shape}"
        )
    arr = np.sort(arr, axis=1)
    if np.any(arr[:, 1] <= arr[:, 0]):
        raise InputError("z_range is empty for a DOF: (min, max) must differ")
    return arr


def _forces(model: StructuralModel, Z: np.ndarray, theta: np.ndarray, stiff: list[int]) -> np.ndarray:
    """The static restoring force at each row of ``Z`` (S, n)."""
    out = Z @ model.K.T + model.static
    if stiff:
        B = model.elements.B
        X = Z @ B
        for k in stiff:
            e = model.elements.elements[k]
            out += np.outer(theta[k] * e.evaluate(X[:, k], None, model.elements.roots_of(e)), B[:, k])
    return out


def _jacobians(model: StructuralModel, Z: np.ndarray, theta: np.ndarray, stiff: list[int]) -> np.ndarray:
    """The tangent stiffness at each row of ``Z``: (S, n, n)."""
    S, n = Z.shape
    out = np.broadcast_to(model.K, (S, n, n)).copy()
    if stiff:
        B = model.elements.B
        X = Z @ B
        for k in stiff:
            e = model.elements.elements[k]
            x = X[:, k]
            h = 1e-6 * np.maximum(np.abs(x), 1e-3)
            roots = model.elements.roots_of(e)
            slope = (e.evaluate(x + h, None, roots) - e.evaluate(x - h, None, roots)) / (2 * h)
            out += (theta[k] * slope)[:, None, None] * np.outer(B[:, k], B[:, k])[None]
    return out


def _starts(ranges: np.ndarray) -> np.ndarray:
    n = ranges.shape[0]
    m = int(np.clip(round(MAX_STARTS ** (1.0 / n)), 3, 41))
    axes = [np.linspace(lo, hi, m) for lo, hi in ranges]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, n)


def _newton(model: StructuralModel, Z: np.ndarray, width: np.ndarray, theta: np.ndarray, stiff: list[int]):
    """Damped Newton from every row of ``Z``: ``(points, converged)``."""
    n = Z.shape[1]
    scale = float(np.abs(model.K).sum(axis=1) @ width + np.abs(model.static).sum()) + 1e-300
    F = _forces(model, Z, theta, stiff)
    converged = np.zeros(len(Z), bool)
    active = np.ones(len(Z), bool)
    ridge = 1e-12 * (float(np.abs(model.K).max()) + 1e-300) * np.eye(n)
    for _ in range(_ITERATIONS):
        idx = np.flatnonzero(active)
        if idx.size == 0:
            break
        J = _jacobians(model, Z[idx], theta, stiff) + ridge
        with np.errstate(all="ignore"):
            step = -np.linalg.solve(J, F[idx][..., None])[..., 0]
        bad = ~np.all(np.isfinite(step), axis=1)
        step[bad] = 0.0
        active[idx[bad]] = False
        done = np.all(np.abs(step) <= 1e-10 * width, axis=1) & (np.linalg.norm(F[idx], axis=1) <= 1e-8 * scale)
        converged[idx[done]] = True
        active[idx[done]] = False
        keep = ~done & ~bad
        idx, step = idx[keep], step[keep]
        if idx.size == 0:
            break
        limit = np.max(np.abs(step) / (0.5 * width), axis=1)
        step = step / np.maximum(limit, 1.0)[:, None]
        norm0 = np.linalg.norm(F[idx], axis=1)
        alpha = np.ones(idx.size)
        pending = np.ones(idx.size, bool)
        for _ in range(30):
            trial = Z[idx[pending]] + alpha[pending, None] * step[pending]
            Ft = _forces(model, trial, theta, stiff)
            better = np.linalg.norm(Ft, axis=1) < norm0[pending]
            rows = np.flatnonzero(pending)
            Z[idx[rows[better]]] = trial[better]
            F[idx[rows[better]]] = Ft[better]
            pending[rows[better]] = False
            if not pending.any():
                break
            alpha[pending] *= 0.5
        active[idx[pending]] = False  # no descent: a minimum of |F| that is not a root
    return Z, converged


def equilibria(model: StructuralModel, z_range: Any = None) -> StructureEquilibria:
    """The static equilibria of a structure, classified by the tangent stiffness (module docstring).

    Parameters
    ----------
    model
        The structure.
    z_range
        Where to look: ``(min, max)`` for every DOF, one pair per DOF, or
        samples ``(N, n)`` (a record's displacements). Needed when the model
        has stiffness elements; equilibria farther than half the range
        outside it are dropped.

    Raises
    ------
    InputError
        ``z_range`` missing for a nonlinear stiffness, or malformed.
    """
    n = model.n_dofs
    theta = model.theta
    stiff = [k for k, e in enumerate(model.elements) if e.family == "stiffness"]
    if not stiff:
        try:
            point = np.linalg.solve(model.K, -model.static)
        except np.linalg.LinAlgError:
            return StructureEquilibria((), ())
        return _classify(model, point[None, :], theta, stiff)
    if z_range is None:
        raise InputError("equilibria of a nonlinear stiffness need the range to search: give z_range")
    ranges = as_ranges(z_range, n)
    width = ranges[:, 1] - ranges[:, 0]
    starts = [_starts(ranges)]
    with contextlib.suppress(np.linalg.LinAlgError):
        starts.append(np.linalg.solve(model.K, -model.static)[None, :])
    Z, ok = _newton(model, np.concatenate(starts), width, theta, stiff)
    Z = Z[ok]
    for _ in range(2):  # polish: the convergence test stops at a step of 1e-10 of the range
        if len(Z):
            with np.errstate(all="ignore"):
                step = np.linalg.solve(_jacobians(model, Z, theta, stiff), _forces(model, Z, theta, stiff)[..., None])
            Z = np.where(np.isfinite(step[..., 0]), Z - step[..., 0], Z)
    Z = np.where(np.abs(Z) <= 1e-12 * width, 0.0, Z)  # a rest position at the origin reads 0, not 1e-37
    inside = np.all((Z >= ranges[:, 0] - 0.5 * width) & (Z <= ranges[:, 1] + 0.5 * width), axis=1)
    Z = Z[inside]
    unique: list[np.ndarray] = []
    for z in Z[np.lexsort(Z.T[::-1])] if len(Z) else Z:
        if not any(np.all(np.abs(z - u) <= 1e-6 * width) for u in unique):
            unique.append(z)
    if not unique:
        return StructureEquilibria((), ())
    return _classify(model, np.array(unique), theta, stiff)


def _classify(model: StructuralModel, Z: np.ndarray, theta: np.ndarray, stiff: list[int]) -> StructureEquilibria:
    J = _jacobians(model, Z, theta, stiff)
    J = J + sum(
        theta[k] * e.term.memory_slope * np.outer(e.b(model.n_dofs), e.b(model.n_dofs))
        for k, e in enumerate(model.elements)
        if e.family == "memory"
    )
    stable, unstable = [], []
    for z, j in zip(Z, J, strict=True):
        eig = np.linalg.eigvalsh(0.5 * (j + j.T))
        point = tuple(float(x) for x in z)
        (stable if eig.min() > 1e-9 * np.abs(eig).max() else unstable).append(point)
    return StructureEquilibria(tuple(sorted(stable)), tuple(sorted(unstable)))
