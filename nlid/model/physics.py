"""Physics of an oscillator model: K(z), D(z, v), U(z), equilibria, modes.

All functions take a :class:`~nlid.model.terms.Model` and its coefficients
(``{canonical term: value}`` or a vector in model order). Coefficients are the
coefficients of the terms of the restoring force
``R(z, v) = K(z) + D(z, v) = f - m z''`` (Eq. 5, 6, 25).

* ``K(z)``: the stiffness family (terms without v, the constant included), Eq. 6.
* ``D(z, v)``: the damping family, Eq. 14 / 24.
* ``U(z) = integral_0^z K``: the potential, Eq. 7.
* Equilibria: roots of ``K``; stable where ``K' > 0`` (Fig. 4).
* Linear natural frequency at a stable equilibrium: ``sqrt(K'(z*) / m)``, Eq. 8
  (with memory terms, ``K'`` includes their small-amplitude stiffness).
* Damping ratio there: ``c(z*) / (2 m w_n)`` with ``c(z*) = dD/dv(z*, 0)``
  from the terms that are linear in v at rest (``v``, ``z^2*v``,
  ``v*|px(z)|``, ``tanh(v/c)``...); Coulomb-like terms have no linearisation
  and are left out. When ``v`` is the only such term this is Eq. 22.

How a model meets data (the force balance, epsilon of Eq. 26, free runs) is
in :mod:`nlid.estimation.balance` and :mod:`nlid.scoring`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import InputError
from .terms import Model

__all__ = [
    "Coefficients",
    "Equilibria",
    "Modal",
    "elastic",
    "damping",
    "restoring",
    "potential",
    "equilibria",
    "stiffness_roots",
    "linear_damping",
    "modal",
    "dict_or_vector",
    "rms_contributions",
]

Coefficients = Mapping[str, float] | np.ndarray | Sequence[float]


def elastic(model: Model, coefficients: Coefficients, z: np.ndarray) -> np.ndarray:
    """The elastic restoring force ``K(z)`` (Eq. 6): the stiffness-family terms."""
    return model.evaluate_terms(dict_or_vector(model, coefficients), z, family="stiffness")


def damping(model: Model, coefficients: Coefficients, z: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The damping force ``D(z, v)`` (Eq. 14, 24): the velocity-dependent terms."""
    return model.evaluate_terms(dict_or_vector(model, coefficients), z, v, family="damping")


def restoring(model: Model, coefficients: Coefficients, z: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The restoring force ``R(z, v) = K(z) + D(z, v)`` (Eq. 25), plus memory terms integrated along ``z``."""
    return model.evaluate_terms(dict_or_vector(model, coefficients), z, v)


def dict_or_vector(model: Model, coefficients: Coefficients) -> np.ndarray:
    """Coefficients as a vector in model order."""
    if isinstance(coefficients, Mapping):
        return model.vector(dict(coefficients))
    return model.vector(coefficients)


def potential(model: Model, coefficients: Coefficients, z: np.ndarray) -> np.ndarray:
    """The potential ``U(z) = int_0^z K(s) ds`` (Eq. 7), by 32-point Gauss-Legendre."""
    z = np.asarray(z, dtype=float)
    nodes, weights = np.polynomial.legendre.leggauss(32)
    s = 0.5 * (nodes[None, :] + 1.0) * z.reshape(-1, 1)
    k = elastic(model, coefficients, s.ravel()).reshape(s.shape)
    return (0.5 * z.reshape(-1) * (k @ weights)).reshape(z.shape)


def _stiffness_polynomial(model: Model, theta: np.ndarray, with_constant: bool = True) -> np.ndarray | None:
    """Coefficients (highest power first) of K if it is a polynomial, else None."""
    coeffs: dict[int, float] = {}
    for term, value in zip(model.terms, theta, strict=True):
        if term.family != "stiffness":
            continue
        power = term.polynomial_power
        if power is None:
            return None
        if power == 0 and not with_constant:
            continue
        coeffs[power] = coeffs.get(power, 0.0) + float(value)
    if not coeffs:
        return np.zeros(1)
    deg = max(coeffs)
    return np.array([coeffs.get(k, 0.0) for k in range(deg, -1, -1)])


def _derivative(fun, z: np.ndarray) -> np.ndarray:
    h = 1e-6 * np.maximum(np.abs(z), 1e-3)
    return (fun(z + h) - fun(z - h)) / (2.0 * h)


@dataclass(frozen=True)
class Equilibria:
    """Equilibrium positions (m), sorted ascending."""

    stable: tuple[float, ...]
    unstable: tuple[float, ...]

    @property
    def all(self) -> tuple[float, ...]:
        """Every equilibrium, sorted."""
        return tuple(sorted(self.stable + self.unstable))

    def to_dict(self) -> dict[str, list[float]]:
        """``{"stable": [...], "unstable": [...]}``."""
        return {"stable": list(self.stable), "unstable": list(self.unstable)}

    @classmethod
    def from_dict(cls, data: Mapping[str, Sequence[float]]) -> Equilibria:
        """Inverse of :meth:`to_dict`."""
        return cls(
            stable=tuple(sorted(float(x) for x in data.get("stable", ()))),
            unstable=tuple(sorted(float(x) for x in data.get("unstable", ()))),
        )


def _real_roots(poly: np.ndarray) -> np.ndarray:
    poly = np.trim_zeros(np.asarray(poly, dtype=float), "f")
    if poly.size <= 1:
        return np.zeros(0)
    roots = np.roots(poly)
    scale = max(1.0, float(np.max(np.abs(roots))))
    real = roots[np.abs(roots.imag) <= 1e-7 * scale].real
    return np.sort(real)


def _numeric_roots(fun, lo: float, hi: float, n: int = 4001) -> np.ndarray:
    from scipy.optimize import brentq

    grid = np.linspace(lo, hi, n)
    values = fun(grid)
    roots = []
    for i in np.flatnonzero(np.signbit(values[:-1]) != np.signbit(values[1:])):
        roots.append(brentq(lambda x: float(fun(np.array([x]))[0]), grid[i], grid[i + 1], xtol=1e-14))
    return np.array(roots)


def equilibria(
    model: Model,
    coefficients: Coefficients,
    z_range: Sequence[float] | None = None,
) -> Equilibria:
    """Roots of ``K(z)`` classified by the sign of ``K'`` (Sec. 2.1, Fig. 4).

    Parameters
    ----------
    model, coefficients
        The identified (or true) model.
    z_range
        ``(z_min, z_max)`` of the data. Polynomial stiffness is solved exactly
        and roots farther than one range-width outside it are dropped (they are
        artefacts of extrapolating a fit); other stiffness laws are solved
        numerically on the range widened by half its width on each side, and
        then ``z_range`` is required.
    """
    theta = dict_or_vector(model, coefficients)
    poly = _stiffness_polynomial(model, theta)

    def k_of(z: np.ndarray) -> np.ndarray:
        return elastic(model, theta, z)

    if poly is not None:
        roots = _real_roots(poly)
        slopes = np.polyval(np.polyder(poly), roots) if roots.size else roots
        if z_range is not None:
            lo, hi = float(min(z_range)), float(max(z_range))
            width = hi - lo
            keep = (roots >= lo - width) & (roots <= hi + width)
            roots, slopes = roots[keep], slopes[keep]
    else:
        if z_range is None:
            raise InputError("equilibria of a non-polynomial stiffness need the data range z_range")
        lo, hi = float(min(z_range)), float(max(z_range))
        width = hi - lo
        roots = _numeric_roots(k_of, lo - 0.5 * width, hi + 0.5 * width)
        slopes = _derivative(k_of, roots) if roots.size else roots
    stable = tuple(float(r) for r, s in zip(roots, slopes, strict=True) if s > 0)
    unstable = tuple(float(r) for r, s in zip(roots, slopes, strict=True) if s <= 0)
    return Equilibria(stable=stable, unstable=unstable)


def stiffness_roots(
    model: Model, coefficients: Coefficients, z_range: Sequence[float] | None = None
) -> tuple[float, float]:
    """Roots ``z^- < 0 < z^+`` of ``p_zeta`` (Eq. 4) for ``px(z)`` (Eq. 9-11).

    ``p_zeta`` is the stiffness without the constant (gravity excluded) and
    without terms that themselves use ``px``; ``z^-`` and ``z^+`` are its real
    roots nearest to zero on either side.

    Raises
    ------
    InputError
        If the stiffness has no root on one side of zero (not a double well).
    """
    theta = dict_or_vector(model, coefficients)
    keep = [i for i, t in enumerate(model.terms) if t.family == "stiffness" and not t.is_constant and not t.uses_px]
    if not keep:
        raise InputError("px(z) needs stiffness terms to take its roots from")
    sub = Model(tuple(model.terms[i] for i in keep))
    sub_theta = theta[keep]
    poly = _stiffness_polynomial(sub, sub_theta, with_constant=False)
    if poly is not None:
        roots = _real_roots(poly)
    else:
        lo, hi = (-1.0, 1.0) if z_range is None else (float(min(z_range)), float(max(z_range)))
        width = hi - lo
        roots = _numeric_roots(lambda z: elastic(sub, sub_theta, z), lo - width, hi + width)
    scale = max(1e-12, float(np.max(np.abs(roots)))) if roots.size else 1.0
    neg = roots[roots < -1e-9 * scale]
    pos = roots[roots > 1e-9 * scale]
    if neg.size == 0 or pos.size == 0:
        raise InputError(
            "px(z) needs the stiffness to have a root on each side of zero (a double well); "
            f"the roots are {', '.join(f'{r:.4g}' for r in roots) or 'none'}"
        )
    return float(neg.max()), float(pos.min())


@dataclass(frozen=True)
class Modal:
    """Linearised modal parameters at one stable equilibrium (Eq. 8, 22).

    Attributes
    ----------
    equilibrium
        The equilibrium position (m).
    fn_hz
        Natural frequency (Hz).
    zeta
        Damping ratio (fraction, not percent).
    stiffness
        ``K'(z*)`` (N/m).
    damping
        Linearised viscous coefficient ``dD/dv(z*, 0)`` (N s/m).
    source
        How they were obtained (empty: Eq. 8 and 22 on the identified
        ``K`` and ``D``; a method that measures them itself says how).
    details
        Further figures a method reports (e.g. NSI's ``zeta_from_uls``).
    """

    equilibrium: float
    fn_hz: float
    zeta: float
    stiffness: float = float("nan")
    damping: float = float("nan")
    source: str = ""
    details: Mapping[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """Plain dictionary; ``details`` are flattened into it."""
        out: dict[str, Any] = {
            "equilibrium": self.equilibrium,
            "fn_hz": self.fn_hz,
            "zeta": self.zeta,
            "stiffness": self.stiffness,
            "damping": self.damping,
        }
        if self.source:
            out["source"] = self.source
        out.update({k: v for k, v in self.details.items() if k not in out})
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Modal:
        """Inverse of :meth:`to_dict`: known keys become fields, the others ``details``.

        Raises
        ------
        InputError
            If ``equilibrium``, ``fn_hz`` or ``zeta`` is missing or not a number.
        """
        if isinstance(data, Modal):
            return data
        try:
            core = {k: float(data[k]) for k in ("equilibrium", "fn_hz", "zeta")}
        except (KeyError, TypeError, ValueError):
            raise InputError(
                f"modal parameters need numbers 'equilibrium', 'fn_hz' and 'zeta', got {dict(data)!r}"
            ) from None
        extra = {k: data[k] for k in ("stiffness", "damping") if data.get(k) is not None}
        details = {k: v for k, v in data.items() if k not in (*core, "stiffness", "damping", "source")}
        return cls(
            **core,
            stiffness=float(extra.get("stiffness", float("nan"))),
            damping=float(extra.get("damping", float("nan"))),
            source=str(data.get("source") or ""),
            details=details,
        )


def linear_damping(model: Model, coefficients: Coefficients, z: float) -> float:
    """``dD/dv`` at ``(z, v = 0)`` from the terms that are linear in v at rest."""
    theta = dict_or_vector(model, coefficients)
    total = 0.0
    zz = np.array([float(z)])
    for term, value in zip(model.terms, theta, strict=True):
        kind, factor = term.slope_at_rest()
        if kind != "linear":
            continue
        part = Model((term.position_part(),), model.px_roots)
        total += float(value) * factor * float(part.evaluate(zz)[0, 0])
    return total


def modal(
    model: Model,
    coefficients: Coefficients,
    mass: float | None,
    points: Sequence[float] | None = None,
    z_range: Sequence[float] | None = None,
) -> list[Modal]:
    """Modal parameters at each stable equilibrium (or at given points).

    Parameters
    ----------
    model, coefficients
        The model.
    mass
        Mass in kg; ``None`` gives an empty list (frequencies need the mass).
    points
        Positions to linearise at; default: the stable equilibria.
    z_range
        Passed to :func:`equilibria`.
    """
    if mass is None:
        return []
    theta = dict_or_vector(model, coefficients)
    if points is None:
        points = equilibria(model, theta, z_range).stable
    out = []
    # memory terms add their small-amplitude stiffness (dw/dz at w = 0) around any rest position
    k_memory = sum(float(value) * term.memory_slope for term, value in zip(model.terms, theta, strict=True))
    for z0 in points:
        k = float(_derivative(lambda z: elastic(model, theta, z), np.array([float(z0)]))[0]) + k_memory
        c = linear_damping(model, theta, z0)
        if k <= 0:
            continue
        wn = np.sqrt(k / mass)
        out.append(Modal(float(z0), float(wn / (2 * np.pi)), float(c / (2 * mass * wn)), k, c))
    return out


def rms_contributions(
    model: Model, coefficients: Coefficients, z: np.ndarray, v: np.ndarray | None
) -> dict[str, float]:
    """RMS of each term's contribution ``theta_i g_i`` to ``R`` (paper Fig. 22)."""
    theta = dict_or_vector(model, coefficients)
    G = model.evaluate(z, v)
    return {name: float(np.sqrt(np.mean((G[:, i] * theta[i]) ** 2))) for i, name in enumerate(model.names)}
