"""One joint least squares of a structure's force balance over every DOF: ``f - M a = K z + C z' + s + B G theta``.

With the mass matrix known, the restoring force of every DOF is linear in the
unknowns: the symmetric stiffness and damping matrices of the underlying
linear system (``n (n + 1) / 2`` entries each, which span a linear spring and
damper on every connection), the constant force per DOF (when the element
set has one) and one coefficient per element, shared by the two DOFs it
connects (:meth:`~nlid.mdof.Element.b`). All DOFs are fitted at once, each
DOF's rows weighted by ``1 / sigma_k^2`` (``sigma_k``: a residual scale per
DOF, default 1 N, so that a DOF whose balance is noisier does not dominate).

The fit is formed from sufficient statistics (:class:`NormalEquations`): the
Gram matrix of the *basis* ``[z, z', 1, g_e(x_e, x_e')]`` and its products with
``R_e = f - M a``, so that a few columns can be added (a candidate element,
a probe) at the cost of their products with the basis, and the sums of two
parts of a record are the statistics of both (:meth:`NormalEquations.__add__`).
:func:`fit_linear_elements` is the one-call form on a record.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import IdentificationError, InputError
from .balance import Balance, balance
from .elements import ElementSet
from .model import StructuralModel, as_matrix

__all__ = ["NormalEquations", "JointFit", "Extra", "fit_linear_elements"]


@dataclass(frozen=True)
class Extra:
    """Columns added to the basis: ``(N, m)`` regressors acting on one connection (connectivity ``b``)."""

    columns: np.ndarray
    b: np.ndarray


@dataclass(frozen=True)
class JointFit:
    """The solution of the joint least squares (unweighted residual sums per DOF).

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


class NormalEquations:
    """Sufficient statistics of the joint least squares on one part of a record (module docstring).

    Parameters
    ----------
    data
        The balance samples (:func:`nlid.mdof.balance.balance`).
    M
        Mass matrix (kg).
    elements
        The declared elements.
    """

    def __init__(self, data: Balance, M: np.ndarray, elements: ElementSet) -> None:
        n = elements.n_dofs
        self.n, self.elements, self.samples = n, elements, int(data.z.shape[0])
        self.z, self.v = data.z, data.v
        self.y = data.f - data.a @ np.asarray(M).T
        parts = [data.z, data.v]
        if elements.static:
            parts.append(np.ones((self.samples, 1)))
        if len(elements):
            parts.append(elements.evaluate(data.z, data.v))
        self.basis = np.column_stack(parts)
        self.gram = self.basis.T @ self.basis
        self.cross = self.basis.T @ self.y
        self.yy = np.sum(self.y**2, axis=0)

    @classmethod
    def combine(cls, a: NormalEquations, b: NormalEquations) -> NormalEquations:
        """The statistics of two parts together (the basis samples are not kept)."""
        out = cls.__new__(cls)
        out.n, out.elements, out.samples = a.n, a.elements, a.samples + b.samples
        out.z = out.v = out.y = out.basis = None  # type: ignore[assignment]
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
    weights: Sequence[float] | None = None,
) -> StructuralModel:
    """Fit ``K``, ``C``, the static force and the elements' coefficients by one joint least squares.

    Parameters
    ----------
    record
        A :class:`~nlid.mdof.StructureRecord`.
    elements
        The elements (``"z5^3, tanh(v3/0.001)"`` or an :class:`ElementSet`).
    mass
        Mass matrix (kg; a vector is lumped); default ``record.mass``.
    cutoff
        The balance filter's cut-off (Hz) for estimated channels.
    weights
        Weight of each DOF's equations (default 1 each).

    Returns
    -------
    StructuralModel

    Raises
    ------
    InputError
        No mass matrix, bad elements or weights.
    """
    n = record.n_dofs
    if mass is None:
        mass = record.mass
    if mass is None:
        raise InputError("the joint least squares needs the mass matrix: give mass= (kg; a vector for a lumped mass)")
    M = as_matrix(mass, n, "mass=", positive=True)
    if isinstance(elements, str):
        elements = ElementSet.from_spec(elements, n)
    w = np.ones(n) if weights is None else np.asarray(weights, dtype=float)
    if w.shape != (n,) or not np.all(np.isfinite(w)) or np.any(w <= 0):
        raise InputError(f"weights must be {n} positive numbers, got {weights!r}")
    fit = NormalEquations(balance(record, cutoff=cutoff), M, elements).solve(w)
    return StructuralModel(M, fit.C, fit.K, elements, fit.theta, fit.static if elements.static else None)
