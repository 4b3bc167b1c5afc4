"""What the harmonic balance solves: ``M z'' + C z' + K z + s + sum_c b_c f_c(b_c^T z, b_c^T z') = f(t)``.

One form for one DOF and for structures (``n >= 1``): the linear part ``M``,
``C``, ``K`` and the static force ``s``, plus a :class:`Group` of terms per
connection ``b_c`` (a DOF to the ground, or two DOFs), each with its
coefficients: the terms of the one-DOF language evaluated on the connection's
relative coordinate. A memory term (Bouc-Wen, Dahl) is a group of its own,
since it carries a state.

A one-DOF model (:class:`nlid.IdentifiedModel`) becomes ``n = 1``: the terms
``z``, ``v`` and ``1`` are ``K``, ``C`` and ``s``; every other term is on the
connection to the ground. A structure (:class:`nlid.model.structure.StructuralModel`)
brings its matrices and its elements grouped by connection.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np

from ..errors import InputError
from ..model.terms import Model, Term, px_coefficients
from ..model.terms.slopes import switches

__all__ = ["Group", "HarmonicSystem"]

PXC = tuple[float, float, float, float]


def _smoothed(term: Term, scale: float) -> Term:
    """``term`` with a bare ``sign(v)`` factor replaced by ``tanh(v / scale)``."""
    if term.memory is not None or term.v != (0, 1):
        return term
    special = tuple(sorted((*term.special, ("tanh", "v", float(scale), 1))))
    return Term(z=term.z, v=(0, 0), px=term.px, special=special)


@dataclass(frozen=True)
class Group:
    """The terms on one connection, with their coefficients.

    Attributes
    ----------
    b
        The connectivity vector (``+1`` at DOF ``i``, ``-1`` at DOF ``j``).
    terms
        The one-DOF terms evaluated on ``x = b^T z`` and ``x' = b^T z'``.
    theta
        Their coefficients (N per unit of the term).
    pxc
        The coefficients of the connection's ``px(x)``, when a term uses it.
    label
        How the connection is written (``"z"``, ``"z1-z2"``, ``"z3"``).
    """

    b: np.ndarray
    terms: tuple[Term, ...]
    theta: np.ndarray
    pxc: PXC | None = None
    label: str = "z"

    @property
    def memory(self) -> bool:
        """True for a group holding one memory term."""
        return any(t.is_memory for t in self.terms)

    @property
    def uses_velocity(self) -> bool:
        """True if a term depends on the velocity."""
        return any(t.depends_on_v for t in self.terms)

    @property
    def switches(self) -> list[tuple[str, float, bool]]:
        """Where the group's force is not smooth (:func:`nlid.model.terms.slopes.switches`), each level once.

        A ``tanh(x/c)`` factor is smooth, but steep when ``c`` is small against the motion: its
        centre and ``+-c``, ``+-3c`` are added as breaks, so that the quadrature resolves it.
        """
        seen: dict[tuple[str, float], bool] = {}
        for t in self.terms:
            found = list(switches(t, self.pxc))
            for kind, var, scale, _ in t.special:
                if kind == "tanh":
                    found += [(var, level, False) for level in (0.0, scale, -scale, 3 * scale, -3 * scale)]
            for var, level, jumps in found:
                key = (var, level)
                seen[key] = seen.get(key, False) or jumps
        return [(var, level, jumps) for (var, level), jumps in seen.items()]


@dataclass(frozen=True)
class HarmonicSystem:
    """The equations of motion the harmonic balance solves (module docstring).

    Attributes
    ----------
    M, C, K
        Mass, damping and stiffness matrices of the linear part.
    static
        Constant force per DOF in ``R`` (N).
    groups
        The nonlinear terms, by connection.
    dofs
        The name of each DOF (``"z"`` for one DOF, ``"z1"``, ``"z2"``... otherwise).
    """

    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    static: np.ndarray
    groups: tuple[Group, ...]
    dofs: tuple[str, ...]

    @property
    def n(self) -> int:
        """Number of degrees of freedom."""
        return int(self.M.shape[0])

    @property
    def uses_memory(self) -> bool:
        """True if a group carries a memory term."""
        return any(g.memory for g in self.groups)

    @property
    def smooth(self) -> bool:
        """True if no term has a kink or a jump (the uniform rule is then spectrally accurate)."""
        return not any(g.switches for g in self.groups if not g.memory)

    @property
    def jumps(self) -> bool:
        """True if a term jumps (a Coulomb-like sign factor)."""
        return any(j for g in self.groups if not g.memory for _, _, j in g.switches)

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_model(cls, model: Model, theta: np.ndarray | Mapping[str, float], mass: float) -> HarmonicSystem:
        """A one-DOF model ``m z'' + R = f``: ``z``, ``v``, ``1`` to ``K``, ``C``, ``s``; the rest to the ground."""
        theta = model.vector(dict(theta) if isinstance(theta, Mapping) else theta)
        k = c = s = 0.0
        plain: list[tuple[Term, float]] = []
        memory: list[tuple[Term, float]] = []
        for term, value in zip(model.terms, theta, strict=True):
            if term.name == "z":
                k += float(value)
            elif term.name == "v":
                c += float(value)
            elif term.is_constant:
                s += float(value)
            elif term.is_memory:
                memory.append((term, float(value)))
            else:
                plain.append((term, float(value)))
        pxc = px_coefficients(*model.px_roots) if model.uses_px and model.px_roots is not None else None
        if model.uses_px and pxc is None:
            raise InputError("the model uses px(z) but its roots are not set")
        b = np.ones(1)
        groups = []
        if plain:
            groups.append(Group(b, tuple(t for t, _ in plain), np.array([x for _, x in plain]), pxc, "z"))
        groups += [Group(b, (t,), np.array([x]), None, "z") for t, x in memory]
        one = lambda x: np.array([[float(x)]])  # noqa: E731
        return cls(one(mass), one(c), one(k), np.array([s]), tuple(groups), ("z",))

    @classmethod
    def from_structure(cls, structure) -> HarmonicSystem:
        """A :class:`nlid.model.structure.StructuralModel`: its matrices, and its elements grouped by connection."""
        elements = structure.elements
        theta = structure.theta
        n = structure.n_dofs
        by_conn: dict[tuple[int, int], list[int]] = {}
        for k, e in enumerate(elements):
            by_conn.setdefault(e.connection, []).append(k)
        groups = []
        for (i, j), idx in by_conn.items():
            e0 = elements.elements[idx[0]]
            b = e0.b(n)
            label = f"z{i}-z{j}" if j else f"z{i}"
            roots = elements.px_roots.get((i, j))
            pxc = px_coefficients(*roots) if roots is not None else None
            plain = [k for k in idx if not elements.elements[k].term.is_memory]
            if plain:
                terms = tuple(elements.elements[k].term for k in plain)
                groups.append(Group(b, terms, np.array([theta[k] for k in plain]), pxc, label))
            for k in idx:
                if elements.elements[k].term.is_memory:
                    groups.append(Group(b, (elements.elements[k].term,), np.array([theta[k]]), None, label))
        dofs = ("z",) if n == 1 else tuple(f"z{k}" for k in range(1, n + 1))
        return cls(
            np.array(structure.M, dtype=float),
            np.array(structure.C, dtype=float),
            np.array(structure.K, dtype=float),
            np.array(structure.static, dtype=float),
            tuple(groups),
            dofs,
        )

    # ------------------------------------------------------------------ derived systems
    def conservative(self) -> HarmonicSystem:
        """Without damping: ``C = 0`` and no velocity-dependent or memory term (the backbone's system)."""
        groups = []
        for g in self.groups:
            if g.memory:
                continue
            keep = [k for k, t in enumerate(g.terms) if not t.depends_on_v]
            if keep:
                groups.append(replace(g, terms=tuple(g.terms[k] for k in keep), theta=g.theta[keep]))
        return replace(self, C=np.zeros_like(self.C), groups=tuple(groups))

    def regularised(self, scale: float) -> HarmonicSystem:
        """Every Coulomb sign of the velocity, ``sign(v)``, replaced by ``tanh(v / scale)`` (``scale`` in m/s)."""
        groups = []
        for g in self.groups:
            terms = tuple(_smoothed(t, scale) for t in g.terms)
            groups.append(replace(g, terms=terms))
        return replace(self, groups=tuple(groups))

    def force_vector(self, at: int | Sequence[float] | np.ndarray | None = None) -> np.ndarray:
        """The unit force pattern: ``at`` a DOF number (1-based), a vector per DOF, or ``None`` (DOF 1)."""
        out = np.zeros(self.n)
        if at is None:
            out[0] = 1.0
            return out
        if isinstance(at, (int, np.integer)) and not isinstance(at, bool):
            if not 1 <= int(at) <= self.n:
                raise InputError(f"dof= must be a DOF number from 1 to {self.n}, got {at}")
            out[int(at) - 1] = 1.0
            return out
        vec = np.asarray(at, dtype=float).reshape(-1)
        if vec.shape != (self.n,) or not np.all(np.isfinite(vec)):
            raise InputError(f"dof= must be a DOF number or {self.n} finite weights, got {at!r}")
        return vec

    def elastic(self, z: np.ndarray) -> np.ndarray:
        """The static restoring force ``K z + s + sum f_c(b_c^T z, 0)`` at displacements ``z`` of shape ``(n,)``."""
        from ..model.terms.slopes import slopes

        out = self.K @ z + self.static
        for g in self.groups:
            if g.memory:
                continue
            x = np.atleast_1d(g.b @ z)
            for t, th in zip(g.terms, g.theta, strict=True):
                if not t.depends_on_v:
                    out = out + g.b * th * slopes(t, x, None, g.pxc)[0][0]
        return out

    def stiffness(self, z: np.ndarray) -> np.ndarray:
        """``dR/dz`` at rest at ``z`` (memory terms by their initial slope)."""
        from ..model.terms.slopes import slopes

        out = np.array(self.K, dtype=float)
        for g in self.groups:
            x = np.atleast_1d(g.b @ z)
            for t, th in zip(g.terms, g.theta, strict=True):
                if t.is_memory:
                    slope = t.memory_slope
                elif t.depends_on_v:
                    continue
                else:
                    slope = slopes(t, x, None, g.pxc)[1][0]
                out = out + th * slope * np.outer(g.b, g.b)
        return out
