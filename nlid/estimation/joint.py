"""The one joint least squares of a structure's force balance over every DOF: ``f - M a = K z + C z' + s + B G theta``.

With the mass matrix known, the restoring force of every DOF is linear in the
unknowns: the symmetric stiffness and damping matrices of the underlying
linear system (``n (n + 1) / 2`` entries each, which span a linear spring and
damper on every connection), the constant force per DOF (when the element
set has one) and one coefficient per element, shared by the two DOFs it
connects (:meth:`~nlid.model.elements.Element.b`); with the mass unknown, its lumped
entries are unknowns too (:func:`~nlid.estimation.structure_regression.linear_design`).

:func:`joint_least_squares` is the estimator every structure path uses: ``rfs``
(through :func:`nlid.plugin.joint_least_squares`), :func:`fit_linear_elements`
and ``discover`` on a structure (:mod:`nlid.discovery.structure`).

Data
    The balance samples of :func:`~nlid.estimation.structure_regression.structure_regression_data`:
    measured channels as they are; otherwise every channel through the one
    zero-phase filter at ``fc``, each element's regressor evaluated on the
    motion in the wider band ``REGRESSOR_BAND_FACTOR * fc`` *before* the
    low-pass, and a zero-order-held force given the hold's response. (An
    earlier copy evaluated the elements on the motion already low-passed at
    ``fc`` and the force without its hold: on a 3-DOF chain whose displacements
    alone were recorded with 0.5-1 % noise, ``fc`` fell to about 100 Hz and the
    cubic came out 25-27 % low, the friction 70-81 %, with the true model
    declared; ``benchmarks/accuracy_mdof_friction.py``. The motion above ``fc``
    puts part of a nonlinear element's force into the band; that part is
    missed when the element is evaluated on the low-passed motion.)
Weighting
    The DOFs' equations have different scales (a driven DOF carries the
    force). A first, unweighted solution gives each DOF's residual RMS; the
    solution weights each DOF's equations by its inverse (feasible weighted
    least squares, :func:`~nlid.estimation.structure_regression.dof_weights`), so that each DOF
    counts by its own noise. Standard errors are the batch-means sandwich
    errors of the weighted problem (:func:`nlid.estimation.regression.least_squares`), the
    DOFs' equations interleaved sample by sample.

:class:`NormalEquations` holds the same problem as sufficient statistics: the
Gram matrix of the basis ``[z, z', 1, G]`` and its products with
``R_e = f - M a`` per DOF, so that ``discover`` can add a few columns (a
candidate element, a probe, built by
:meth:`~nlid.estimation.structure_regression.StructureRegressionData.regressors`) at the cost of
their products with the basis; with the same data and the same weights it
solves the same least squares as :func:`joint_least_squares` (a test checks it).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import IdentificationError, InputError
from ..model.elements import ElementSet
from ..model.structure import StructuralModel, structure_mass
from .regression import least_squares
from .structure_regression import (
    LinearDesign,
    StructureRegressionData,
    dof_weights,
    linear_design,
    structure_regression_data,
)

__all__ = ["NormalEquations", "JointFit", "Extra", "JointSolution", "joint_least_squares", "fit_linear_elements"]


@dataclass(frozen=True)
class Extra:
    """Columns added to the basis: ``(N, m)`` regressors acting on one connection (connectivity ``b``)."""

    columns: np.ndarray
    b: np.ndarray


@dataclass(frozen=True)
class JointFit:
    """A solution of the normal equations (unweighted residual sums per DOF).

    Attributes
    ----------
    K, C
        Symmetric stiffness and damping matrices.
    static
        Constant force per DOF (zeros when the element set has none).
    theta
        Coefficient of each element, in element order.
    extra
        Coefficients of the added columns.
    p
        Every unknown, in the order of the normal equations.
    rss
        ``sum (R_e - R_hat)^2`` per DOF on the part it was fitted on.
    """

    K: np.ndarray
    C: np.ndarray
    static: np.ndarray
    theta: np.ndarray
    extra: np.ndarray
    p: np.ndarray
    rss: np.ndarray


@dataclass(frozen=True)
class JointSolution:
    """What :func:`joint_least_squares` returns.

    Attributes
    ----------
    theta, K, C, M, s
        Element coefficients, matrices (``M`` ``None`` when it was given) and static force per DOF (or ``None``).
    fit
        The :class:`nlid.estimation.regression.LeastSquaresFit` of the weighted problem.
    design
        The :class:`~nlid.estimation.structure_regression.LinearDesign`.
    weights
        The weight of each DOF's equations (1 / its first-pass residual RMS, the largest 1).
    """

    theta: np.ndarray
    K: np.ndarray
    C: np.ndarray
    M: np.ndarray | None
    s: np.ndarray | None
    fit: Any
    design: LinearDesign
    weights: np.ndarray

    def model(self, elements: ElementSet, mass: np.ndarray | None = None) -> StructuralModel:
        """The identified structure (``mass``: the given mass matrix when it was not estimated)."""
        M = self.M if self.M is not None else mass
        if M is None:
            raise InputError("the mass matrix was given to the fit: pass it as mass=")
        return StructuralModel(M, self.C, self.K, elements, self.theta, self.s)


def joint_least_squares(
    data: StructureRegressionData,
    elements: ElementSet,
    mass: np.ndarray | None,
    *,
    step: int = 1,
    correlation: float = 1.0,
    context: str = "",
) -> JointSolution:
    """The joint least squares of every DOF's force balance (module docstring) on prepared balance samples.

    Parameters
    ----------
    data
        The balance samples (:func:`~nlid.estimation.structure_regression.structure_regression_data`), their ``G`` the
        regressors of ``elements``.
    elements
        The elements.
    mass
        The mass matrix (kg), or ``None``: the lumped masses are estimated.
    step
        Keep every ``step``-th sample.
    correlation
        Samples over which the equation error stays correlated (sets the batch length of the standard
        errors; multiplied by the number of DOFs, whose equations are interleaved).
    context
        Prefix of the messages (``"rfs: "``).

    Raises
    ------
    IdentificationError
        Too few equations, no force, a rank-deficient problem (e.g. a mass matrix that cannot be estimated
        because no DOF is driven), or an estimated mass that is not positive.
    """
    design = linear_design(data, elements, mass=mass, step=step)
    n = data.n_dofs
    X, y = design.X, design.y
    if y.size <= X.shape[1]:
        raise IdentificationError(
            f"{context}{y.size} equations for {X.shape[1]} unknowns: the record is too short for the model"
            + ("; lower 'decimate'" if step > 1 else "")
        )
    if not np.any(y):
        raise IdentificationError(f"{context}no force acts on the structure; its mass and stiffness cannot be scaled")
    first = least_squares(X, y, design.names, correlation_length=correlation * n, context=context)
    weights = dof_weights(first.residual, y, n)
    w = np.tile(weights, X.shape[0] // n)
    fit = least_squares(X * w[:, None], y * w, design.names, correlation_length=correlation * n, context=context)
    parts = design.split(fit.coefficients)
    if parts["M"] is not None and not np.all(np.diag(parts["M"]) > 0):
        bad = [f"{m:.4g}" for m in np.diag(parts["M"])]
        raise IdentificationError(
            f"{context}the estimated masses are not all positive ({', '.join(bad)} kg); give mass= "
            "(a structure needs a driven DOF connected to every other for its mass to be estimated)"
        )
    return JointSolution(parts["theta"], parts["K"], parts["C"], parts["M"], parts["s"], fit, design, weights)


class NormalEquations:
    """Sufficient statistics of the joint least squares on one part of a record (module docstring).

    Parameters
    ----------
    data
        The balance samples (:func:`~nlid.estimation.structure_regression.structure_regression_data`), their ``G`` the
        regressors of ``elements``.
    M
        Mass matrix (kg).
    elements
        The declared elements.
    """

    def __init__(self, data: StructureRegressionData, M: np.ndarray, elements: ElementSet) -> None:
        n = elements.n_dofs
        if data.G.shape[1] != len(elements):
            raise InputError(f"the data hold {data.G.shape[1]} element regressors for {len(elements)} elements")
        self.n, self.elements, self.samples = n, elements, int(data.z.shape[0])
        self.data = data
        self.y = data.f - data.a @ np.asarray(M).T
        parts = [data.z, data.v]
        if elements.static:
            parts.append(np.ones((self.samples, 1)))
        if len(elements):
            parts.append(data.G)
        self.basis = np.column_stack(parts)
        self.gram = self.basis.T @ self.basis
        self.cross = self.basis.T @ self.y
        self.yy = np.sum(self.y**2, axis=0)

    @classmethod
    def combine(cls, a: NormalEquations, b: NormalEquations) -> NormalEquations:
        """The statistics of two parts together (the basis samples are not kept)."""
        out = cls.__new__(cls)
        out.n, out.elements, out.samples = a.n, a.elements, a.samples + b.samples
        out.data = out.y = out.basis = None  # type: ignore[assignment]
        out.gram, out.cross, out.yy = a.gram + b.gram, a.cross + b.cross, a.yy + b.yy
        return out

    # ------------------------------------------------------------------ the parameter map
    @property
    def linear_count(self) -> int:
        """Entries of the symmetric K and C."""
        return self.n * (self.n + 1) // 2

    def _selections(self, extras: Sequence[Extra]) -> list[np.ndarray]:
        """``S_i`` of every DOF: the row block ``i`` of the design is ``[basis, extras] @ S_i``."""
        key = tuple((x.columns.shape[1], tuple(x.b)) for x in extras)
        memo = self.__dict__.setdefault("_selection_memo", {})
        if key not in memo:
            memo[key] = self._build_selections(extras)
        return memo[key]

    def _build_selections(self, extras: Sequence[Extra]) -> list[np.ndarray]:
        n, E = self.n, len(self.elements)
        static = 1 if self.elements.static else 0
        m = [x.columns.shape[1] for x in extras]
        width = 2 * n + static + E + sum(m)
        lin = self.linear_count
        P = 2 * lin + (n if static else 0) + E + sum(m)
        pairs = [(k, j) for k in range(n) for j in range(k, n)]
        B = self.elements.B if E else np.zeros((n, 0))
        out = []
        for i in range(n):
            S = np.zeros((width, P))
            for p, (k, j) in enumerate(pairs):
                for block, offset in ((0, 0), (n, lin)):  # z then v columns; K then C parameters
                    if i == k:
                        S[block + j, offset + p] += 1.0
                    if i == j and k != j:
                        S[block + k, offset + p] += 1.0
            col, par = 2 * n, 2 * lin
            if static:
                S[col, par + i] = 1.0
                col, par = col + 1, par + n
            for e in range(E):
                S[col + e, par + e] = B[i, e]
            col, par = col + E, par + E
            for x, count in zip(extras, m, strict=True):
                for c in range(count):
                    S[col + c, par + c] = x.b[i]
                col, par = col + count, par + count
            out.append(S)
        return out

    def augmented(self, extras: Sequence[Extra], columns: Sequence[np.ndarray] | None = None) -> tuple:
        """``(gram, cross)`` of the basis with the extra columns appended.

        ``columns`` are the extras' samples on this part (default: ``extras[k].columns``, evaluated on this part).
        """
        if not extras:
            return self.gram, self.cross
        given = list(columns) if columns is not None else [x.columns for x in extras]
        cached = getattr(self, "_cache", None)  # the same columns are scored several times in a row
        same = cached is not None and len(cached[0]) == len(given)
        if same and all(a is b for a, b in zip(cached[0], given, strict=True)):
            return cached[1]
        H = np.column_stack(given)
        if self.basis is None:
            raise InputError("combined normal equations cannot take new columns; add them to each part")
        top = self.basis.T @ H
        gram = np.block([[self.gram, top], [top.T, H.T @ H]])
        cross = np.vstack([self.cross, H.T @ self.y])
        self._cache = (given, (gram, cross))
        return gram, cross

    def assemble(self, weights: np.ndarray, extras: Sequence[Extra] = (), columns=None) -> tuple:
        """``(A, h, S, gram, cross)``: the weighted normal equations ``A p = h`` and the per-DOF pieces."""
        gram, cross = self.augmented(extras, columns)
        S = self._selections(extras)
        A = sum(w * s.T @ gram @ s for w, s in zip(weights, S, strict=True))
        h = sum(w * s.T @ cross[:, i] for i, (w, s) in enumerate(zip(weights, S, strict=True)))
        return A, h, S, gram, cross

    def rss(self, p: np.ndarray, extras: Sequence[Extra] = (), columns=None) -> np.ndarray:
        """``sum (R_e - design p)^2`` per DOF on this part for parameters ``p``."""
        gram, cross = self.augmented(extras, columns)
        S = self._selections(extras)
        out = np.empty(self.n)
        for i, s in enumerate(S):
            q = s @ p
            out[i] = self.yy[i] - 2.0 * q @ cross[:, i] + q @ gram @ q
        return np.maximum(out, 0.0)

    def solve(self, weights: np.ndarray, extras: Sequence[Extra] = (), columns=None) -> JointFit:
        """The weighted least-squares solution (columns scaled; a rank-deficient design is solved by lstsq)."""
        A, h, _, _, _ = self.assemble(weights, extras, columns)
        d = np.sqrt(np.abs(np.diag(A)))
        d[d == 0] = 1.0
        scaled = A / np.outer(d, d)
        q, *_ = np.linalg.lstsq(scaled, h / d, rcond=1e-13)
        p = q / d
        if not np.all(np.isfinite(p)):
            raise IdentificationError("the joint least squares of the structure gave values that are not finite")
        return self.unpack(p, extras, self.rss(p, extras, columns))

    def unpack(self, p: np.ndarray, extras: Sequence[Extra], rss: np.ndarray) -> JointFit:
        n, lin = self.n, self.linear_count
        K, C = np.zeros((n, n)), np.zeros((n, n))
        pairs = [(a, b) for a in range(n) for b in range(a, n)]
        for idx, (k, j) in enumerate(pairs):
            K[k, j] = K[j, k] = p[idx]
            C[k, j] = C[j, k] = p[lin + idx]
        at = 2 * lin
        static = np.zeros(n)
        if self.elements.static:
            static = p[at : at + n].copy()
            at += n
        E = len(self.elements)
        theta = p[at : at + E].copy()
        return JointFit(K, C, static, theta, p[at + E :].copy(), p, rss)


def fit_linear_elements(
    record,
    elements: ElementSet | str,
    mass=None,
    *,
    cutoff: float | None = None,
) -> StructuralModel:
    """Fit ``K``, ``C``, the static force and the elements' coefficients by :func:`joint_least_squares`.

    Parameters
    ----------
    record
        An indexed :class:`~nlid.data.record.Record`.
    elements
        The elements (``"z5^3, tanh(v3/0.001)"`` or an :class:`ElementSet`).
    mass
        Mass matrix (kg; a vector is lumped, or text); default the record's
        (:func:`~nlid.model.structure.structure_mass`).
    cutoff
        The balance filter's cut-off (Hz) for estimated channels.

    Returns
    -------
    StructuralModel

    Raises
    ------
    InputError
        No mass matrix, bad elements.
    IdentificationError
        As :func:`joint_least_squares`.
    """
    M = structure_mass(mass, record)
    if M is None:
        raise InputError(
            "the joint least squares needs the mass matrix: give mass= (kg; a vector for a lumped mass) or the "
            "record's meta['mass']"
        )
    if isinstance(elements, str):
        elements = ElementSet.from_spec(elements, record.n_dofs)
    data = structure_regression_data(record, elements, cutoff=cutoff)
    return joint_least_squares(data, elements, M).model(elements, M)
