"""The fits behind discovery on a structure: the parts of the record, their joint least squares, scored columns.

Every fit is the one joint least squares of a structure's force balance (:mod:`nlid.estimation.joint`) on the
balance samples ``rfs`` uses (:func:`nlid.estimation.structure_regression.structure_regression_data`), one cut-off for
every part. A candidate element or a probe is a function of a connection's relative coordinates; its
columns are built on the same footing as the declared elements'
(:meth:`~nlid.estimation.structure_regression.StructureRegressionData.regressors`: evaluated on the motion in the wide
regressor band, then low-passed into the equation band), so that a candidate is judged on what it adds to
``f - M a``, not on a filtering mismatch. Each candidate is scored through :class:`NormalEquations`
(sufficient statistics: refitting with a few more columns costs their products with the basis); a stage's
model is :func:`~nlid.estimation.joint.joint_least_squares` on the selection record (the estimation and
held-out parts together), the estimate ``rfs`` gives with the same elements.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import InputError
from ..estimation.joint import Extra, JointFit, NormalEquations, joint_least_squares
from ..estimation.structure_regression import StructureRegressionData, stack_regression_data
from ..model.elements import Element, ElementSet
from ..model.structure import StructuralModel

__all__ = [
    "Part",
    "Search",
    "relative",
    "connectivity",
    "connection_columns",
    "element_columns",
    "fraction",
    "per_dof",
    "Connection",
]

Connection = tuple[int, int]


@dataclass
class Part:
    """One part of the record: its balance samples (``G``: the current elements) and their normal equations."""

    data: StructureRegressionData
    eq: Any = None
    #: The part's record, when the probes' null is wanted (:func:`nlid.discovery.structure_probes.probe_null`).
    record: Any = None


def relative(data: StructureRegressionData, c: Connection) -> tuple[np.ndarray, np.ndarray]:
    """The relative displacement and velocity of connection ``c`` in the equation band."""
    i, j = c
    x = data.z[:, i - 1] - (data.z[:, j - 1] if j else 0.0)
    xd = data.v[:, i - 1] - (data.v[:, j - 1] if j else 0.0)
    return np.asarray(x, dtype=float), np.asarray(xd, dtype=float)


def connectivity(c: Connection, n: int) -> np.ndarray:
    """``b`` of connection ``c``: ``+1`` at ``i``, ``-1`` at ``j`` (none for the ground)."""
    out = np.zeros(n)
    out[c[0] - 1] = 1.0
    if c[1]:
        out[c[1] - 1] = -1.0
    return out


def connection_columns(
    data: StructureRegressionData, c: Connection, evaluate: Callable[[np.ndarray, np.ndarray], np.ndarray]
) -> np.ndarray:
    """``evaluate(x, x')`` of connection ``c``'s relative coordinates, on the footing of the elements' columns."""
    i, j = c

    def columns(z: np.ndarray, v: np.ndarray) -> np.ndarray:
        x = z[:, i - 1] - (z[:, j - 1] if j else 0.0)
        xd = v[:, i - 1] - (v[:, j - 1] if j else 0.0)
        return evaluate(np.asarray(x, dtype=float), np.asarray(xd, dtype=float))

    return data.regressors(columns)


def element_columns(data: StructureRegressionData, elements: Sequence[Element]) -> np.ndarray:
    """The regressors of elements on one connection (the same one), ``(N, len(elements))``."""
    c = elements[0].connection
    return connection_columns(data, c, lambda x, xd: np.column_stack([e.evaluate(x, xd) for e in elements]))


def fraction(after: np.ndarray, before: np.ndarray, w: np.ndarray, dofs: Sequence[int]) -> float:
    """The weighted fraction of the residual sum of ``dofs`` that ``after`` removes from ``before``."""
    idx = list(dofs)
    b = float(np.sum(w[idx] * before[idx]))
    return float("nan") if b <= 0 else 1.0 - float(np.sum(w[idx] * after[idx])) / b


def per_dof(after_h, before_h, after_e, before_e) -> tuple[float, ...]:
    """The cross-fitted fraction per DOF (mean of both directions)."""
    out = []
    for k in range(len(before_h)):
        a = 1.0 - after_h[k] / before_h[k] if before_h[k] > 0 else float("nan")
        b = 1.0 - after_e[k] / before_e[k] if before_e[k] > 0 else float("nan")
        out.append(0.5 * (a + b))
    return tuple(out)


class Search:
    """The state shared by the rounds of one search: the parts, the mass matrix and the DOFs' weights."""

    def __init__(self, parts: dict[str, Part], M: np.ndarray, rule: Any, n: int, cutoff: float | None = None):
        self.parts, self.M, self.rule, self.n, self.cutoff = parts, M, rule, n, cutoff
        self.weights = np.ones(n)
        self.elements: ElementSet | None = None

    def equations(self, elements: ElementSet) -> None:
        """Make ``elements`` the current model of every part (their regressors and normal equations)."""
        self.elements = elements
        for part in self.parts.values():
            part.data = part.data.with_elements(elements)
            part.eq = NormalEquations(part.data, self.M, elements)

    def reweight(self) -> np.ndarray:
        """Weight each DOF by the inverse of its residual variance under the current model; returns the variances.

        The joint fit is then a feasible generalised least squares: a DOF whose balance the model leaves noisier
        counts less. Called on the declared model and again after each accepted step, so that a DOF whose misfit
        the step removed is not left weighted by the misfit it no longer has.
        """
        fit = self.selection_fit()
        est, ho = self.parts["estimation"], self.parts["holdout"]
        rss = est.eq.rss(fit.p) + ho.eq.rss(fit.p)
        sigma2 = np.maximum(rss / (est.data.z.shape[0] + ho.data.z.shape[0]), 1e-300)
        self.weights = 1.0 / sigma2
        return sigma2

    def cross_scores(self, extras_by_part: Mapping[str, Sequence[Any]] | None) -> dict[str, Any]:
        """Fit on each of estimation/held-out and score on the other: the per-DOF RSS of both directions."""
        est, ho = self.parts["estimation"], self.parts["holdout"]
        w = self.weights
        extras = (extras_by_part or {}).get("extras", ())
        cols = {k: (extras_by_part or {}).get(k) for k in ("estimation", "holdout")}
        fit_e = est.eq.solve(w, extras, cols["estimation"])
        fit_h = ho.eq.solve(w, extras, cols["holdout"])
        return {
            "on_holdout": ho.eq.rss(fit_e.p, extras, cols["holdout"]),
            "on_estimation": est.eq.rss(fit_h.p, extras, cols["estimation"]),
            "in_estimation": fit_e.rss,
            "fit_estimation": fit_e,
            "fit_holdout": fit_h,
        }

    def selection_fit(self, extras: Sequence[Extra] = (), columns: Mapping[str, Any] | None = None) -> JointFit:
        """The fit on estimation + held-out together with the current weights (sum of their normal equations)."""
        est, ho = self.parts["estimation"], self.parts["holdout"]
        cols = columns or {}
        A1, h1, *_ = est.eq.assemble(self.weights, extras, cols.get("estimation"))
        A2, h2, *_ = ho.eq.assemble(self.weights, extras, cols.get("holdout"))
        A, h = A1 + A2, h1 + h2
        d = np.sqrt(np.abs(np.diag(A)))
        d[d == 0] = 1.0
        q, *_ = np.linalg.lstsq(A / np.outer(d, d), h / d, rcond=1e-13)
        p = q / d
        return est.eq.unpack(p, extras, np.zeros(self.n))

    def model(self) -> StructuralModel:
        """The current elements fitted on the selection record by the one joint least squares."""
        elements = self.elements
        if elements is None:
            raise InputError("the search has no model yet: call equations() first")
        data = stack_regression_data([self.parts["estimation"].data, self.parts["holdout"].data])
        return joint_least_squares(data, elements, self.M, context="discover: ").model(elements, self.M)

    def residual(self, part: Part, fit: JointFit, k: int) -> np.ndarray:
        """DOF ``k``'s residual of a normal-equations fit on a part."""
        d = part.data
        pred = d.z @ fit.K[k] + d.v @ fit.C[k] + fit.static[k]
        if len(part.eq.elements):
            pred = pred + d.G @ (part.eq.elements.B[k] * fit.theta)
        return part.eq.y[:, k] - pred
