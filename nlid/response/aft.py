"""Alternating frequency-time evaluation of the nonlinear forces, with their exact Jacobians.

For each group of terms on a connection (:class:`~nlid.response.system.Group`)
the relative motion's coefficients ``x`` (displacement) and ``V`` (velocity,
``omega D x``) are turned into samples on a quadrature rule
(:mod:`nlid.response.harmonics`), the force and its partial derivatives are
evaluated there (:func:`nlid.model.terms.slopes.slopes`), and projected back:

    F   = P[g(x(tau), v(tau))]
    Jx  = P[g_z(tau) E(tau)]      (dF/dx)
    Jv  = P[g_v(tau) E(tau)]      (dF/dV)

with ``P`` the projection on the basis. The Jacobian is therefore the AFT of
the terms' own derivatives, not a finite difference of the residual.

Smooth groups use the uniform rule. A group with a kink or a jump (``|v|``,
``sign(v)``, ``|px(z)|``, gaps, stops) uses the composite Gauss rule with a
break at every phase where its motion crosses a switching level, so that each
piece is smooth; where a term *jumps* (a Coulomb sign), moving the crossing
moves the jump, which adds ``(g(tau_b-) - g(tau_b+)) phi(tau_b) dtau_b/dx`` to
the Jacobian (Leibniz's rule), with ``dtau_b/dx = -phi(tau_b) / x'(tau_b)``.
Sign functions are used as they are: no regularisation, as long as the
crossings of the motion are simple (a sticking phase, where the velocity
stays at zero, is not a truncated Fourier series and is not represented).

A memory group is integrated along the path to its periodic state
(:mod:`nlid.response.memory`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model.terms.slopes import slopes
from .harmonics import Harmonics, crossings, default_samples
from .memory import memory_force
from .system import Group, HarmonicSystem

__all__ = ["Evaluator", "GroupForce"]


@dataclass(frozen=True)
class GroupForce:
    """The force of one group and its Jacobians (coefficients of the relative coordinate).

    Attributes
    ----------
    F
        Force coefficients ``(P,)``.
    Jx, Jv
        ``dF/dx`` and ``dF/dV`` ``(P, P)``; ``Jv`` is zero for a group without velocity terms.
    hill
        For a memory group: what Hill's method needs (:func:`nlid.response.memory.hill_blocks`), else ``None``.
    """

    F: np.ndarray
    Jx: np.ndarray
    Jv: np.ndarray
    hill: tuple | None = None


class Evaluator:
    """The nonlinear forces of a :class:`HarmonicSystem` on a basis (module docstring).

    Parameters
    ----------
    system
        The equations.
    basis
        The harmonics.
    samples
        Samples (uniform rule) or intervals (composite rule) per period; default :func:`default_samples`.
    memory_samples
        Samples per period along which a memory state is integrated.
    """

    def __init__(
        self, system: HarmonicSystem, basis: Harmonics, samples: int | None = None, memory_samples: int | None = None
    ):
        self.system = system
        self.basis = basis
        self.samples = int(samples or default_samples(basis.H))
        self.memory_samples = int(memory_samples or default_samples(basis.H, memory=True))
        self.plans = []
        for g in system.groups:
            sw = [] if g.memory else g.switches
            self.plans.append((g, sw, [(t, th, self._jumps(t, g)) for t, th in zip(g.terms, g.theta, strict=True)]))
        self.states: dict[int, float] = {}  # the periodic memory state of each memory group at tau = 0 (warm start)

    @staticmethod
    def _jumps(term, group: Group) -> set[tuple[str, float]]:
        from ..model.terms.slopes import switches

        return {(var, level) for var, level, jumps in switches(term, group.pxc) if jumps}

    # ------------------------------------------------------------------
    def forces(self, X: np.ndarray, omega: float) -> list[GroupForce]:
        """The force of every group for motion coefficients ``X`` of shape ``(n, P)`` at ``omega``."""
        D = self.basis.D
        out = []
        for k, (g, sw, terms) in enumerate(self.plans):
            x = g.b @ X
            V = omega * (D @ x)
            if g.memory:
                F, Jx, hill = memory_force(self, k, g, x, V)
                out.append(GroupForce(F, Jx, np.zeros_like(Jx), hill))
            else:
                out.append(self._plain(g, sw, terms, x, V))
        return out

    def _plain(self, g: Group, sw, terms, x: np.ndarray, V: np.ndarray) -> GroupForce:
        basis = self.basis
        if not sw:
            _, w, E = basis.uniform(self.samples)
            found: list[tuple[str, float, np.ndarray, np.ndarray]] = []
        else:
            found = []
            breaks = []
            for var in ("z", "v"):
                levels = [level for v, level, _ in sw if v == var]
                if not levels:
                    continue
                tau_b, slope_b, which = crossings(basis, x if var == "z" else V, np.array(levels), 2 * self.samples)
                for k, level in enumerate(levels):
                    mine = which == k
                    found.append((var, level, tau_b[mine], slope_b[mine]))
                breaks.append(tau_b)
            _, w, E = basis.composite(self.samples, np.concatenate(breaks) if breaks else np.empty(0))
        xs = E @ x
        vs = E @ V if g.uses_velocity else None
        val = np.zeros_like(xs)
        gz = np.zeros_like(xs)
        gv = np.zeros_like(xs)
        cache: dict = {}
        for t, th, _ in terms:
            a, bz, bv = slopes(t, xs, vs, g.pxc, cache)
            val += th * a
            gz += th * bz
            gv += th * bv
        norms = basis.norms
        F = norms * (E.T @ (w * val))
        Jx = norms[:, None] * (E.T @ ((w * gz)[:, None] * E))
        Jv = norms[:, None] * (E.T @ ((w * gv)[:, None] * E)) if vs is not None else np.zeros((basis.P, basis.P))
        for var, level, tau_b, slope_b in found:
            jumping = [(t, th) for t, th, jumps in terms if (var, level) in jumps]
            if not jumping or tau_b.size == 0:
                continue
            Eb = basis.values(tau_b)
            xb, vb = Eb @ x, Eb @ V
            side = np.sign(slope_b)
            scale = 1e-12 * max(1.0, float(np.max(np.abs(E @ (x if var == "z" else V)))))
            before, after = np.zeros_like(xb), np.zeros_like(xb)
            for t, th in jumping:
                for sgn, acc in ((-1.0, before), (1.0, after)):
                    shifted = level + sgn * side * scale
                    zz = shifted if var == "z" else xb
                    vv = shifted if var == "v" else vb
                    acc += th * slopes(t, np.broadcast_to(zz, xb.shape).copy(), vv + 0 * xb, g.pxc)[0]
            # d tau_b / d coeffs = -phi(tau_b) / slope_b; the jump moves with it
            dtau = -Eb / slope_b[:, None]
            extra = norms[:, None] * ((Eb * (before - after)[:, None]).T @ dtau)
            if var == "z":
                Jx = Jx + extra
            else:
                Jv = Jv + extra
        return GroupForce(F, Jx, Jv)
