"""The fitted model the response is computed from, whatever object it came as.

:func:`as_fitted` reads an :class:`nlid.IdentifiedModel` (its ``model``,
``theta``, ``mass``, ``equilibria`` and ``z_range``), an
:class:`nlid.identified.structure.IdentifiedStructure` (its ``structure``, ``equilibria`` and
``z_range``) or a bare :class:`nlid.model.structure.StructuralModel` by what they hold,
not by their class: the identified models call this package from their own
methods, so it must not import them back.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..errors import InputError
from ..model.structure import StructuralModel
from ..model.terms import Model
from .system import HarmonicSystem

__all__ = ["Fitted", "as_fitted"]


@dataclass(frozen=True, eq=False)
class Fitted:
    """A one-DOF model (``model``, ``theta``, ``mass``) or a structure (``structure``), with what is known of it."""

    model: Model | None = None
    theta: np.ndarray | None = None
    mass: float | None = None
    structure: StructuralModel | None = None
    equilibria: Any = None
    z_range: Any = None
    source: Any = None

    @property
    def one_dof(self) -> bool:
        """True for a one-DOF model."""
        return self.structure is None

    @property
    def n(self) -> int:
        """Number of DOFs."""
        return 1 if self.structure is None else self.structure.n_dofs

    def system(self) -> HarmonicSystem:
        """The equations the harmonic balance solves."""
        if self.structure is None:
            return HarmonicSystem.from_model(self.model, self.theta, self.mass)
        return HarmonicSystem.from_structure(self.structure)

    def with_theta(self, theta: np.ndarray) -> Fitted:
        """The same one-DOF model with other coefficients (a posterior draw); equilibria recomputed."""
        if self.structure is not None:
            raise InputError("posterior draws of a structure's coefficients are not supported by the response band")
        return replace(self, theta=np.asarray(theta, dtype=float), equilibria=None)

    def stable_unstable(self) -> tuple[list[np.ndarray], list[np.ndarray]]:
        """The stable and unstable equilibria (vectors of ``n``)."""
        eq = self.equilibria
        if self.structure is None:
            if eq is None:
                from ..model import physics

                eq = physics.equilibria(self.model, self.theta, self.z_range)
            return [np.array([z]) for z in eq.stable], [np.array([z]) for z in eq.unstable]
        if eq is None and self.z_range is not None:
            eq = self.structure.equilibria(self.z_range)
        if eq is None:
            system = self.system()
            z = _newton_rest(system)
            if z is None:
                return [], []
            k = system.stiffness(z)
            return ([z], []) if bool(np.all(np.linalg.eigvalsh(0.5 * (k + k.T)) > 0)) else ([], [z])
        return [np.array(p, dtype=float) for p in eq.stable], [np.array(p, dtype=float) for p in eq.unstable]

    def conservative(self) -> Fitted:
        """Without damping: no velocity-dependent or memory term, ``C = 0`` (for backbone checks)."""
        if self.structure is None:
            keep = [i for i, t in enumerate(self.model.terms) if t.family == "stiffness"]
            model = Model(tuple(self.model.terms[i] for i in keep), self.model.px_roots)
            return replace(self, model=model, theta=np.asarray(self.theta)[keep])
        from ..model.elements import ElementSet

        s = self.structure
        keep = [e for e in s.elements if e.family == "stiffness"]
        spec = ElementSet(tuple(keep), s.elements.n_dofs, s.elements.static, s.elements.px_roots)
        theta = dict(s.coefficients)
        return replace(
            self,
            structure=StructuralModel(
                s.M, np.zeros_like(s.C), s.K, spec, {e.name: theta[e.name] for e in keep}, s.static
            ),
        )


def _newton_rest(system: HarmonicSystem) -> np.ndarray | None:
    """The equilibrium Newton's method reaches from ``z = 0`` (``None`` if it does not converge)."""
    z = np.zeros(system.n)
    for _ in range(100):
        try:
            dz = np.linalg.solve(system.stiffness(z), -system.elastic(z))
        except np.linalg.LinAlgError:
            return None
        z = z + dz
        if np.max(np.abs(dz)) <= 1e-14 * max(1.0, float(np.max(np.abs(z)))):
            return z
    return None


def as_fitted(obj: Any) -> Fitted:
    """Read a fitted model (module docstring).

    Raises
    ------
    InputError
        Another kind of object, or a one-DOF model without its mass.
    """
    if isinstance(obj, Fitted):
        return obj
    if isinstance(obj, StructuralModel):
        return Fitted(structure=obj, source=obj)
    structure = getattr(obj, "structure", None)
    if isinstance(structure, StructuralModel):
        return Fitted(
            structure=structure,
            equilibria=getattr(obj, "equilibria", None),
            z_range=getattr(obj, "z_range", None),
            source=obj,
        )
    model = getattr(obj, "model", None)
    if isinstance(model, Model) and hasattr(obj, "theta") and hasattr(obj, "mass"):
        if obj.mass is None:
            raise InputError("the response needs the mass: the model has none (give mass= when identifying)")
        return Fitted(
            model=model,
            theta=np.asarray(obj.theta, dtype=float),
            mass=float(obj.mass),
            equilibria=getattr(obj, "equilibria", None),
            z_range=getattr(obj, "z_range", None),
            source=obj,
        )
    raise InputError(
        f"model must be an IdentifiedModel, an IdentifiedStructure or a StructuralModel, got {type(obj).__name__}"
    )
