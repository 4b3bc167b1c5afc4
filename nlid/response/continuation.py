"""Pseudo-arclength continuation of ``r(u, p) = 0`` in one parameter, with folds and branch points.

The curve ``y = (u, p)`` is followed by steps along its tangent (the null
vector of ``[dr/du, dr/dp]``, kept pointing the same way): a predictor
``y + h t`` and Newton's corrector on ``r(y) = 0`` together with
``t . (y - y_pred) = 0``, in scaled variables (``u / u_scale``,
``p / p_scale``, ``r / r_scale``). The step ``h`` adapts: it grows after a
corrector that converged in a few iterations, shrinks after a slow one, and
is halved after a failure or a turn of the tangent by more than
:data:`MAX_TURN`; below ``h_min`` the continuation stops and says so.

At every accepted point it records whether a *fold* (turning point: ``dp/ds``
changes sign) or a *branch point* (the determinant of the augmented Jacobian
``[dr/dy; t]`` changes sign while ``dp/ds`` does not) lies behind. A fold is
refined by a secant search on the arclength for ``dp/ds = 0`` and inserted as
a point of the curve.

It stops, with the reason, when the parameter leaves its range (the last
point is put on the bound), after ``max_points``, when the step falls below
``h_min``, or when the unknowns grow beyond ``limit`` times their scale.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

__all__ = ["Continuation", "Branch", "Event", "MAX_TURN"]

#: Largest angle (rad) between consecutive tangents in scaled variables.
MAX_TURN = 0.35

Problem = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray, object]]


@dataclass(frozen=True)
class Event:
    """A special point found between two points of a branch.

    Attributes
    ----------
    kind
        ``"fold"`` (a turning point: the jump of a sweep), ``"branch"`` (a branch point),
        ``"flip"`` (period doubling) or ``"torus"`` (Neimark-Sacker: a complex pair of multipliers).
    index
        The point of the branch it is at (a fold is inserted there) or just after.
    y
        The unknowns and the parameter there.
    """

    kind: str
    index: int
    y: np.ndarray


@dataclass
class Branch:
    """The points of a continuation and what happened along it."""

    y: list[np.ndarray] = field(default_factory=list)
    tangents: list[np.ndarray] = field(default_factory=list)
    aux: list[object] = field(default_factory=list)
    folds: list[int] = field(default_factory=list)
    events: list[Event] = field(default_factory=list)
    stopped: str = ""
    newton: int = 0
    rejected: int = 0


class Continuation:
    """Follow a curve ``r(u, p) = 0`` (module docstring).

    Parameters
    ----------
    problem
        ``y -> (r, J, aux)`` with ``J = [dr/du, dr/dp]`` (``m x (m + 1)``) and anything the caller wants
        kept with the point.
    scale
        Scale of each unknown and of the parameter (``m + 1``).
    r_scale
        Scale of the residual.
    bounds
        ``(low, high)`` of the parameter.
    h0, h_min, h_max
        First, least and largest step (scaled arclength).
    max_points
        Most points.
    limit
        Stop when a scaled unknown exceeds this.
    tol
        Newton's tolerance on the scaled residual.
    stop
        ``y -> reason or None``: stops the continuation after a point (e.g. an amplitude reached).
    """

    def __init__(
        self,
        problem: Problem,
        scale: np.ndarray,
        r_scale: float,
        bounds: tuple[float, float],
        *,
        h0: float = 0.02,
        h_min: float = 1e-6,
        h_max: float = 0.05,
        max_points: int = 2000,
        limit: float = 1e3,
        tol: float = 1e-9,
        stop: Callable[[np.ndarray], str | None] | None = None,
    ):
        self.problem = problem
        self.scale = np.asarray(scale, dtype=float)
        self.r_scale = float(r_scale)
        self.bounds = (float(min(bounds)), float(max(bounds)))
        self.h0, self.h_min, self.h_max = float(h0), float(h_min), float(h_max)
        self.max_points = int(max_points)
        self.limit = float(limit)
        self.tol = float(tol)
        self.stop = stop
        self.calls = 0

    # ------------------------------------------------------------------ pieces
    def _eval(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, object]:
        self.calls += 1
        r, J, aux = self.problem(y)
        return r / self.r_scale, J * (self.scale[None, :] / self.r_scale), aux

    def _tangent(self, J: np.ndarray, previous: np.ndarray | None) -> np.ndarray:
        """The unit null vector of the scaled ``J``, oriented along ``previous`` (or towards a growing parameter)."""
        m = J.shape[0]
        guide = previous if previous is not None else np.r_[np.zeros(m), 1.0]
        A = np.vstack([J, guide])
        rhs = np.zeros(m + 1)
        rhs[-1] = 1.0
        try:
            t = np.linalg.solve(A, rhs)
        except np.linalg.LinAlgError:
            _, _, vt = np.linalg.svd(J)
            t = vt[-1]
        t /= np.linalg.norm(t)
        return t if t @ guide >= 0 else -t

    def _correct(self, ys: np.ndarray, t: np.ndarray, fix: int | None = None, iters: int = 10):
        """Newton from the scaled ``ys``: with the arclength condition (``fix=None``) or with unknown ``fix`` held.

        Along the curve (``fix=None``) a corrector whose residual grows twice in a row is given up at once.
        """
        anchor = ys.copy()
        growing = 0
        last = np.inf
        for k in range(iters):
            r, J, aux = self._eval(ys * self.scale)
            m = J.shape[0]
            size = float(np.max(np.abs(r)))
            growing = growing + 1 if size > last else 0
            if growing >= 2 and fix is None:  # diverging: give up early, the caller shortens the step
                return None, k + 1
            last = size
            if fix is None:
                A = np.vstack([J, t])
                rhs = -np.r_[r, t @ (ys - anchor)]
            else:
                row = np.zeros(m + 1)
                row[fix] = 1.0
                A = np.vstack([J, row])
                rhs = -np.r_[r, ys[fix] - anchor[fix]]
            if not np.all(np.isfinite(A)) or not np.all(np.isfinite(rhs)):
                return None, k + 1
            try:
                dy = np.linalg.solve(A, rhs)
            except np.linalg.LinAlgError:
                return None, k + 1
            ys = ys + dy
            if np.max(np.abs(dy)) < 1e-8 and np.max(np.abs(r)) < 1e2 * self.tol or np.max(np.abs(dy)) < 1e-13:
                # quadratic convergence: the residual at the new point is of the order of dy^2; the Jacobian
                # and aux of the last evaluation (dy away) serve the tangent and the stability
                return (ys, r, J, aux), k + 1
        r, J, aux = self._eval(ys * self.scale)
        if np.max(np.abs(r)) < self.tol:
            return (ys, r, J, aux), iters
        return None, iters

    def solve_at(self, y: np.ndarray, fix: int = -1) -> tuple | None:
        """Newton with unknown ``fix`` (default: the parameter) held at its value in ``y``: ``(y, r, J, aux)``
        scaled, or ``None``."""
        ys = np.asarray(y, dtype=float) / self.scale
        out, _ = self._correct(ys, np.zeros_like(ys), fix=int(fix) % ys.size, iters=30)
        return out

    # ------------------------------------------------------------------ the march
    def run(self, start: tuple, direction: float = 1.0, guide: np.ndarray | None = None) -> Branch:
        """Continue from a solved point (:meth:`solve_at`), the parameter first moving in ``direction``
        (or along ``guide``, a vector of the unknowns and the parameter)."""
        ys, _, J, aux = start
        branch = Branch()
        m = J.shape[0]
        if guide is None:
            guide = np.r_[np.zeros(m), float(np.sign(direction) or 1.0)]
        t = self._tangent(J, guide)
        det = self._det(J, t)
        self._keep(branch, ys, t, aux)
        h = self.h0
        lo, hi = self.bounds[0] / self.scale[-1], self.bounds[1] / self.scale[-1]
        while True:
            if len(branch.y) >= self.max_points:
                branch.stopped = f"stopped after {self.max_points} points (max_points)"
                return branch
            if h < self.h_min:
                p = ys[-1] * self.scale[-1]
                branch.stopped = f"the step fell below its minimum at parameter {p:.6g}: the corrector did not converge"
                return branch
            pred = ys + h * t
            if pred[-1] > hi or pred[-1] < lo:
                edge = hi if pred[-1] > hi else lo
                out = self._to_bound(ys, t, edge)
                if out is not None:
                    ye, _, Je, auxe = out
                    te = self._tangent(Je, t)
                    self._check_events(branch, ys, t, det, ye, te, self._det(Je, te))
                    self._keep(branch, ye, te, auxe)
                    branch.stopped = "reached the end of the range" if edge == hi else "turned back to the start"
                    return branch
                h *= 0.5
                branch.rejected += 1
                continue
            out, iters = self._correct(pred, t)
            branch.newton += iters
            if out is None:
                h *= 0.5
                branch.rejected += 1
                continue
            yn, _, Jn, auxn = out
            tn = self._tangent(Jn, t)
            if tn @ t < np.cos(MAX_TURN) and h > 4 * self.h_min:
                h *= 0.5
                branch.rejected += 1
                continue
            if np.max(np.abs(yn[:-1])) > self.limit:
                where = yn[-1] * self.scale[-1]
                branch.stopped = f"the response grew beyond {self.limit:g} times its scale (at parameter {where:.6g})"
                return branch
            detn = self._det(Jn, tn)
            self._check_events(branch, ys, t, det, yn, tn, detn, h)
            self._keep(branch, yn, tn, auxn)
            reason = self.stop(yn * self.scale) if self.stop is not None else None
            if reason:
                branch.stopped = reason
                return branch
            ys, t, det = yn, tn, detn
            h = min(self.h_max, h * (1.6 if iters <= 3 else (1.0 if iters <= 6 else 0.6)))

    def _keep(self, branch: Branch, ys: np.ndarray, t: np.ndarray, aux: object) -> None:
        branch.y.append(ys * self.scale)
        branch.tangents.append(t)
        branch.aux.append(aux)

    def _det(self, J: np.ndarray, t: np.ndarray) -> float:
        sign, _ = np.linalg.slogdet(np.vstack([J, t]))
        return float(sign)

    def _to_bound(self, ys: np.ndarray, t: np.ndarray, edge: float):
        """The point of the curve whose parameter is ``edge`` (from ``ys`` along ``t``), scaled, or ``None``."""
        if abs(t[-1]) < 1e-12:
            return None
        guess = ys + (edge - ys[-1]) / t[-1] * t
        guess[-1] = edge
        out, _ = self._correct(guess, t, fix=ys.size - 1)
        return out

    def _check_events(self, branch, ys, t, det, yn, tn, detn, h: float | None = None) -> None:
        fold = np.sign(t[-1]) != np.sign(tn[-1]) and t[-1] != 0 and tn[-1] != 0
        if fold and h is not None:
            found = self._refine_fold(ys, t, h)
            if found is not None:
                yf, tf, auxf = found
                branch.folds.append(len(branch.y))
                branch.events.append(Event("fold", len(branch.y), yf * self.scale))
                self._keep(branch, yf, tf, auxf)
                return
        if fold:
            branch.events.append(Event("fold", len(branch.y), 0.5 * (ys + yn) * self.scale))
        elif det != detn and det != 0 and detn != 0:
            branch.events.append(Event("branch", len(branch.y), 0.5 * (ys + yn) * self.scale))

    def _refine_fold(self, ys: np.ndarray, t: np.ndarray, h: float):
        """The fold between ``ys`` and the point at arclength ``h``: secant on ``dp/ds`` (scaled, or ``None``)."""
        a, fa = 0.0, t[-1]
        b = h
        out, _ = self._correct(ys + b * t, t)
        if out is None:
            return None
        fb = self._tangent(out[2], t)[-1]
        best = None
        for _ in range(12):
            if fb == fa:
                break
            c = b - fb * (b - a) / (fb - fa)
            if not (min(a, b) - 0.5 * h < c < max(a, b) + 0.5 * h):
                c = 0.5 * (a + b)
            out, _ = self._correct(ys + c * t, t)
            if out is None:
                return best
            tc = self._tangent(out[2], t)
            best = (out[0], tc, out[3])
            if abs(tc[-1]) < 1e-9:
                break
            a, fa, b, fb = b, fb, c, tc[-1]
        return best
