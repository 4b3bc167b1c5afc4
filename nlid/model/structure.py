"""A structure: an underlying linear system (M, C, K) plus localised nonlinear elements.

The equations of motion of :class:`StructuralModel` are

    M z'' + C z' + K z + s + sum_e b_e theta_e g_e(x_e, x_e') = f(t)

with ``z`` the ``n`` displacements, ``s`` a constant force per DOF (static
loads such as gravity: the counterpart of the one-DOF term ``1``), and each
element ``e`` a term of the one-DOF language on the relative coordinate of its
connection, ``x_e = b_e^T z`` (:mod:`nlid.model.elements`). The restoring force
is ``R(z, z') = f - M z''`` per DOF, as for one DOF.

The physics (:mod:`nlid.model.statics`, :mod:`nlid.model.modes`): the static
equilibria (several stable ones for a double-well element), the linearised
modes at each stable equilibrium, and the FRF matrix of the linearised
system. The simulator is :mod:`nlid.simulation.structure`.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ..base.frozen import FrozenDict
from ..base.validate import ESTIMATE, parse_mass
from ..errors import InputError
from .elements import Element, ElementSet
from .physics import linear_damping
from .terms import Model

if TYPE_CHECKING:  # pragma: no cover
    from ..data.record import Record
    from .modes import StructureModes
    from .statics import StructureEquilibria

__all__ = ["StructuralModel", "as_matrix", "structure_mass"]


def as_matrix(value: Any, n: int | None, name: str, *, positive: bool = False) -> np.ndarray:
    """``value`` as a read-only ``(n, n)`` float matrix: a matrix, a vector (its diagonal) or a number (one DOF).

    Raises
    ------
    InputError
        A wrong shape, a value that is not finite, or (``positive``) a matrix
        that is not symmetric positive definite.
    """
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a matrix of numbers, got {type(value).__name__}") from None
    if arr.ndim == 0:
        arr = arr.reshape(1, 1)
    elif arr.ndim == 1:
        arr = np.diag(arr)
    if arr.ndim != 2 or arr.shape[0] != arr.shape[1] or (n is not None and arr.shape[0] != n):
        want = "a square matrix" if n is None else f"an {n}x{n} matrix (or its diagonal)"
        raise InputError(f"{name} must be {want}, got shape {np.shape(value)}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{name} has a value that is not finite")
    if positive:
        sym = 0.5 * (arr + arr.T)
        if not np.allclose(arr, sym, rtol=1e-9, atol=1e-12 * float(np.abs(arr).max() or 1.0)):
            raise InputError(f"{name} must be symmetric")
        try:
            np.linalg.cholesky(sym)
        except np.linalg.LinAlgError:
            raise InputError(f"{name} must be positive definite") from None
        arr = sym
    arr.setflags(write=False)
    return arr


def structure_mass(mass: Any, record: Record, *, name: str = "mass=") -> np.ndarray | None:
    """The mass matrix a structure is fitted with: the one read by every structure path (identify, discover).

    Parameters
    ----------
    mass
        A matrix (kg; array-like, a vector is lumped) or its text (:func:`nlid.base.validate.parse_mass`: a
        literal, ``diag(...)``, a CSV/JSON/.npy file); ``None``: the record's own (``meta['mass']``, the
        ``.meta.json`` sidecar of a file); ``"estimate"``: none, the method estimates the masses.
    record
        The record (its number of DOFs and its metadata).
    name
        How messages name ``mass``.

    Returns
    -------
    numpy.ndarray or None
        A read-only ``(n, n)`` symmetric positive-definite matrix, or ``None`` (estimate).

    Raises
    ------
    InputError
        One line naming ``name``: unreadable text, a shape other than the record's DOFs, a matrix that is
        not symmetric or not positive definite.
    """
    if mass is None:
        return record.mass
    if isinstance(mass, str) or hasattr(mass, "__fspath__"):
        mass = parse_mass(mass, name=name)
    if isinstance(mass, str) and mass == ESTIMATE:
        return None
    return as_matrix(mass, record.n_dofs, name, positive=True)


@dataclass(frozen=True, eq=False)
class StructuralModel:
    """An underlying linear system plus localised nonlinear elements, with their coefficients.

    Parameters
    ----------
    M
        Mass matrix (kg), symmetric positive definite; a vector is a lumped
        (diagonal) mass matrix, a number one DOF.
    C, K
        Damping (N s/m) and stiffness (N/m) matrices of the underlying linear system.
    elements
        The nonlinear elements: an :class:`~nlid.model.elements.ElementSet`,
        a spec such as ``"(z1-z2)^3, sign(v2-v1)"`` or a list of terms.
    coefficients
        The coefficient of every element (any spelling; a term written in
        the reversed orientation has its sign converted), or a vector in
        element order.
    static
        Constant force per DOF in ``R`` (N), e.g. ``m_k g`` for gravity; default zeros.

    Raises
    ------
    InputError
        Matrices of the wrong shape or not finite, a mass matrix that is not
        symmetric positive definite, coefficients missing or extra.
    """

    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    elements: ElementSet | str | Iterable[str | Element] = ()
    coefficients: Mapping[str, float] | Sequence[float] | np.ndarray = field(default_factory=dict)
    static: np.ndarray | Sequence[float] | None = None

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        M = as_matrix(self.M, None, "M", positive=True)
        n = M.shape[0]
        set_(self, "M", M)
        set_(self, "C", as_matrix(self.C, n, "C"))
        set_(self, "K", as_matrix(self.K, n, "K"))
        elements = self.elements
        if not isinstance(elements, ElementSet):
            elements = ElementSet.from_spec(elements, n)
        elif elements.n_dofs != n:
            raise InputError(f"the elements are on {elements.n_dofs} DOFs but M is {n}x{n}")
        set_(self, "elements", elements)
        coefficients = self.coefficients
        if isinstance(coefficients, Mapping):
            theta = elements.vector(coefficients)
            given = {elements.locate(k)[0] for k in coefficients}
            missing = [e.name for k, e in enumerate(elements) if k not in given]
            if missing:
                raise InputError(f"no coefficient is given for {', '.join(missing)}")
        else:
            theta = elements.vector(coefficients)
        if not np.all(np.isfinite(theta)):
            raise InputError("an element's coefficient is not finite")
        set_(self, "coefficients", FrozenDict(elements.as_dict(theta)))
        static = np.zeros(n) if self.static is None else np.array(self.static, dtype=float).reshape(-1)
        if static.shape != (n,) or not np.all(np.isfinite(static)):
            raise InputError(f"static must be {n} finite forces (one per DOF), got {np.shape(self.static)}")
        static.setflags(write=False)
        set_(self, "static", static)

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_oscillator(
        cls, model: Model, coefficients: Mapping[str, float] | np.ndarray, mass: float
    ) -> StructuralModel:
        """The one-DOF oscillator ``m z'' + R(z, z') = f`` as a structure of one DOF.

        The terms ``z``, ``v`` and ``1`` become ``K``, ``C`` and the static
        force; every other term an element to the ground (``z^3`` -> ``z1^3``).
        """
        theta = model.vector(dict(coefficients) if isinstance(coefficients, Mapping) else coefficients)
        k = c = s = 0.0
        elements, values = [], []
        for term, value in zip(model.terms, theta, strict=True):
            if term.name == "z":
                k = float(value)
            elif term.name == "v":
                c = float(value)
            elif term.is_constant:
                s = float(value)
            else:
                elements.append(Element(term, 1, 0))
                values.append(float(value))
        roots = {(1, 0): model.px_roots} if model.px_roots is not None else None
        spec = ElementSet(tuple(elements), 1, True, FrozenDict(roots or {}))
        return cls(
            M=[[float(mass)]],
            C=[[c]],
            K=[[k]],
            elements=spec,
            coefficients=spec.as_dict([values[elements.index(e)] for e in spec]),
            static=[s],
        )

    # ------------------------------------------------------------------ views
    @property
    def n_dofs(self) -> int:
        """Number of degrees of freedom."""
        return int(self.M.shape[0])

    @property
    def theta(self) -> np.ndarray:
        """The element coefficients as a vector in element order."""
        return self.elements.vector(dict(self.coefficients))

    def coefficient(self, term: str) -> float:
        """The coefficient of an element written in any spelling (its sign follows the orientation written)."""
        k, sign = self.elements.locate(term)
        return sign * float(self.theta[k])

    def __repr__(self) -> str:
        elements = ", ".join(self.elements.names) or "no elements"
        return f"<StructuralModel: {self.n_dofs} DOFs; {elements}>"

    # ------------------------------------------------------------------ forces
    def _states(self, z: np.ndarray, v: np.ndarray | None) -> tuple[np.ndarray, np.ndarray | None]:
        n = self.n_dofs
        zz = np.asarray(z, dtype=float).reshape(-1, n)
        vv = None if v is None else np.asarray(v, dtype=float).reshape(-1, n)
        return zz, vv

    def element_forces(self, z: np.ndarray, v: np.ndarray | None = None) -> np.ndarray:
        """``theta_e g_e(x_e, x_e')`` of every element on samples ``(N, n)``: shape ``(N, n_elements)``.

        Memory elements are integrated along their relative displacement from ``w = 0``.
        """
        zz, vv = self._states(z, v)
        if vv is None and any(e.term.depends_on_v for e in self.elements):
            vv = np.zeros_like(zz)
        return self.elements.evaluate(zz, vv) * self.theta

    def restoring(self, z: np.ndarray, v: np.ndarray) -> np.ndarray:
        """``R(z, z') = K z + C z' + s + sum_e b_e theta_e g_e``: shape ``(N, n)`` (N per DOF)."""
        zz, vv = self._states(z, v)
        out = zz @ self.K.T + vv @ self.C.T + self.static
        if len(self.elements):
            out += self.element_forces(zz, vv) @ self.elements.B.T
        return out

    def elastic(self, z: np.ndarray) -> np.ndarray:
        """The static restoring force ``K z + s + sum_e b_e theta_e k_e(x_e)`` (stiffness elements), ``(N, n)``."""
        zz, _ = self._states(z, None)
        out = zz @ self.K.T + self.static
        keep = [k for k, e in enumerate(self.elements) if e.family == "stiffness"]
        if keep:
            x, _ = self.elements.relative(zz)
            B = self.elements.B
            theta = self.theta
            for k in keep:
                e = self.elements.elements[k]
                out += np.outer(theta[k] * e.evaluate(x[:, k], None, self.elements.roots_of(e)), B[:, k])
        return out

    def tangent_stiffness(self, z0: Sequence[float]) -> np.ndarray:
        """``dR/dz`` at rest at ``z0``: ``K + sum_e b_e b_e^T theta_e k_e'(x_e)`` (memory: the initial slope)."""
        z0 = np.asarray(z0, dtype=float).reshape(self.n_dofs)
        out = np.array(self.K, dtype=float)
        theta = self.theta
        for k, e in enumerate(self.elements):
            b = e.b(self.n_dofs)
            if e.family == "memory":
                slope = e.term.memory_slope
            elif e.family == "stiffness":
                x = float(b @ z0)
                h = 1e-6 * max(abs(x), 1e-3)
                roots = self.elements.roots_of(e)
                ends = e.evaluate(np.array([x + h, x - h]), None, roots)
                slope = float(ends[0] - ends[1]) / (2 * h)
            else:
                continue
            out += theta[k] * slope * np.outer(b, b)
        return out

    def tangent_damping(self, z0: Sequence[float]) -> np.ndarray:
        """``dR/dz'`` at rest at ``z0``: ``C`` plus the elements that are linear in the velocity at rest."""
        z0 = np.asarray(z0, dtype=float).reshape(self.n_dofs)
        out = np.array(self.C, dtype=float)
        theta = self.theta
        for k, e in enumerate(self.elements):
            if e.family != "damping":
                continue
            b = e.b(self.n_dofs)
            roots = self.elements.roots_of(e)
            c = linear_damping(Model((e.term,), roots), np.array([theta[k]]), float(b @ z0))
            out += c * np.outer(b, b)
        return out

    # ------------------------------------------------------------------ physics
    def equilibria(self, z_range: Any = None) -> StructureEquilibria:
        """The static equilibria (:func:`nlid.model.statics.equilibria`), stable and unstable."""
        from .statics import equilibria

        return equilibria(self, z_range)

    def modes(self, z_range: Any = None, points: Sequence[Sequence[float]] | None = None) -> tuple[StructureModes, ...]:
        """Linearised modes at each stable equilibrium (or at ``points``) (:func:`nlid.model.modes.modes`)."""
        from .modes import modes

        if points is None:
            points = self.equilibria(z_range).stable
        return tuple(modes(self, p) for p in points)

    def frf(self, frequency_hz: Sequence[float], at: Sequence[float] | None = None) -> np.ndarray:
        """Receptance matrix ``H(f) = (K_lin - w^2 M + i w C_lin)^-1`` (m/N), shape ``(F, n, n)``.

        Parameters
        ----------
        frequency_hz
            Frequencies (Hz).
        at
            The rest position to linearise at; default the origin (the underlying linear system: ``K``, ``C``).
        """
        from .modes import receptance

        if at is None:
            return receptance(self.M, self.C, self.K, frequency_hz)
        return receptance(self.M, self.tangent_damping(at), self.tangent_stiffness(at), frequency_hz)

    # ------------------------------------------------------------------ plain data
    def to_dict(self) -> dict[str, Any]:
        """Plain, JSON-serialisable: matrices as nested lists, the elements and their coefficients."""
        spec = self.elements.to_dict()
        return {
            "M": self.M.tolist(),
            "C": self.C.tolist(),
            "K": self.K.tolist(),
            "static": self.static.tolist(),
            "elements": spec["elements"],
            "px_roots": spec["px_roots"],
            "coefficients": dict(self.coefficients),
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> StructuralModel:
        """Inverse of :meth:`to_dict`.

        Raises
        ------
        InputError
            A missing matrix or inconsistent elements and coefficients.
        """
        try:
            M, C, K = data["M"], data["C"], data["K"]
        except (KeyError, TypeError):
            raise InputError("a structural model needs 'M', 'C' and 'K'") from None
        n = np.asarray(M, dtype=float).shape[0] if np.ndim(M) else 1
        spec = {"n_dofs": n, "elements": data.get("elements") or [], "px_roots": data.get("px_roots")}
        elements = ElementSet.from_dict(spec)
        return cls(M, C, K, elements, dict(data.get("coefficients") or {}), data.get("static"))
