"""One basis function of the restoring force, in normal form.

Every term is a product of, at most, one *part* per variable and some special
factors:

* a part ``|x|^p * sign(x)^s`` for each of ``x = z`` (displacement),
  ``x = v`` (velocity) and ``x = px(z)`` (the normalised normal-force
  polynomial of Eq. 10-11); ``p >= 0`` is an integer and ``s`` is 0 or 1;
* special factors ``exp(-|x|/c)``, ``exp(-(x/c)^2)`` and ``tanh(x/c)`` with a
  positive scale ``c`` (velocity-weakening / smoothed friction laws), and the
  non-smooth springs ``gap(x, d)`` (``sign(x) max(|x| - d, 0)``: a stiffness
  that engages beyond a clearance ``d >= 0`` on either side) and
  ``stop(x, d)`` (one-sided: ``max(x - d, 0)`` for ``d >= 0``,
  ``min(x - d, 0)`` for ``d < 0``).

A term may instead be a *memory* term, standing alone: ``bouc_wen(a, b)`` or
``dahl(rho)``, a hysteretic state integrated along the displacement's path
(:mod:`nlid.model.terms.memory`). Its family is ``"memory"``: it belongs neither to
``K(z)`` nor to ``D(z, v)``.

The numbers inside a term (scales, clearances, memory parameters) are its
*shape parameters* (:attr:`Term.shapes`, :meth:`Term.with_shapes`): fixed in
a model, but a method may search or fit them (``nlid discover`` on a grid,
the output-error identifier by optimisation).

Two spellings that denote the same function a.e. (``v*|v|`` and
``sign(v)*|v|^2``, ``z*|z|`` and ``|z|*z``) have the same normal form and so
the same canonical name. The canonical spelling of a part is

========  =====================  ============================
``s``     ``p`` odd              ``p`` even
========  =====================  ============================
1         ``x`` / ``x^p``        ``sign(x)`` (p=0), ``x*|x|`` (p=2), ``x*|x|^(p-1)``
0         ``|x|`` / ``|x|^p``    ``x^p`` (nothing for p=0)
========  =====================  ============================

so the power-law friction family ``sign(v)*|v|^j`` of Eq. 24 prints as
``sign(v)``, ``v``, ``v*|v|``, ``v^3`` for j = 0..3. Parts are written in
the order z, v, px, then special factors.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Literal

import numpy as np

from ...base.dimensions import coefficient_unit

__all__ = ["Term", "Part", "Special", "VARIABLES"]

Var = Literal["z", "v", "px"]
#: Variables a part may refer to, in canonical order.
VARIABLES: tuple[Var, ...] = ("z", "v", "px")
_SPELLING = {"z": "z", "v": "v", "px": "px(z)"}
Part = tuple[int, int]  # (power p >= 0, sign parity s in {0, 1})
#: (kind, variable, scale, multiplicity); kind is "exp1", "exp2", "tanh", "gap" or "stop".
Special = tuple[str, str, float, int]
#: Special factors whose value carries the unit of their variable (piecewise-linear springs).
_LINEAR_KINDS = ("gap", "stop")
#: (law, parameters) of a memory term.
Memory = tuple[str, tuple[float, ...]]
MAX_POWER = 15


def _fmt_number(c: float) -> str:
    text = format(c, ".6g")
    return text


def _part_name(var: str, part: Part) -> str:
    p, s = part
    x = _SPELLING[var]
    if p == 0:
        return f"sign({x})" if s else ""
    if p % 2 == s:  # odd power with sign, or even power without: a plain power
        return x if p == 1 else f"{x}^{p}"
    if s == 0:  # odd power without sign
        return f"|{x}|" if p == 1 else f"|{x}|^{p}"
    # even power with sign
    return f"{x}*|{x}|" if p == 2 else f"{x}*|{x}|^{p - 1}"


def _special_name(special: Special) -> str:
    kind, var, scale, mult = special
    c = _fmt_number(scale)
    if kind == "exp1":
        body = f"exp(-|{var}|/{c})"
    elif kind == "exp2":
        body = f"exp(-({var}/{c})^2)"
    elif kind in _LINEAR_KINDS:
        body = f"{kind}({var}, {c})"
    else:
        body = f"tanh({var}/{c})"
    return body if mult == 1 else f"{body}^{mult}"


def _signed_power(x: np.ndarray, part: Part, cache: dict) -> np.ndarray | None:
    """``|x|^p sign(x)^s`` with the elementary pieces cached by the caller."""
    p, s = part
    if p == 0 and s == 0:
        return None
    key = (id(x), p, s)
    if key in cache:
        return cache[key]
    if p % 2 == s:
        if p <= 2:
            out = x if p == 1 else x**p
        else:
            # numpy's power of an array with negative entries is a scalar pow per element (~25x slower than
            # its vectorised loop on a non-negative base): the same function through |x|
            ax = np.abs(x) ** p
            out = ax if s == 0 else np.copysign(ax, x)
    elif s == 0:
        out = np.abs(x) if p == 1 else np.abs(x) ** p
    else:
        sx = np.sign(x)
        out = sx if p == 0 else sx * np.abs(x) ** p
    cache[key] = out
    return out


@dataclass(frozen=True)
class Term:
    """A basis function ``g(z, v)`` of the restoring force in normal form.

    Build terms with :func:`nlid.model.terms.parse_term`; the constructor is for
    internal use and does not validate combinations.

    Attributes
    ----------
    z, v, px
        The ``(p, s)`` part of each variable.
    special
        Sorted tuple of special factors.
    """

    z: Part = (0, 0)
    v: Part = (0, 0)
    px: Part = (0, 0)
    special: tuple[Special, ...] = ()
    memory: Memory | None = None

    # ------------------------------------------------------------------ naming
    @property
    def name(self) -> str:
        """The canonical spelling."""
        if self.memory is not None:
            law, params = self.memory
            return f"{law}({', '.join(_fmt_number(x) for x in params)})"
        pieces = [_part_name(var, getattr(self, var)) for var in VARIABLES]
        pieces += [_special_name(s) for s in self.special]
        pieces = [p for p in pieces if p]
        return "*".join(pieces) if pieces else "1"

    def __str__(self) -> str:
        return self.name

    def __repr__(self) -> str:
        return f"Term({self.name!r})"

    # ------------------------------------------------------------------ classification
    @property
    def depends_on_v(self) -> bool:
        """True if the term depends on the velocity."""
        return self.v != (0, 0) or any(s[1] == "v" for s in self.special)

    @property
    def dissipative(self) -> bool:
        """True if the term is a friction or damping law, ``g(z, v) v >= 0`` (it dissipates if its coefficient > 0).

        Decided from the normal form: the term depends on the velocity, has no memory and no gap or stop
        factor, and its sign is the sign of ``v`` (an odd number of ``sign(v)`` and ``tanh(v/c)`` factors,
        ``v``, ``v*|v|``, ``v^3``...) times a factor that is never negative (``|z|^p``, ``z^2``, ``|px(z)|``,
        ``exp(...)``). ``sign(v)``, ``v*|v|``, ``v^3``, ``sign(v)*exp(-(v/c)^2)``, ``z^2*v`` and
        ``sign(v)*|px(z)|`` are; ``v^2``, ``|v|`` and ``z*v`` are not. On a structure's connection the
        element's power is ``theta g(x, x') x'``, so the same sign decides whether it feeds energy in.
        """
        if self.memory is not None or not self.depends_on_v:
            return False
        parity = {"z": self.z[1], "v": self.v[1], "px": self.px[1]}
        for kind, var, _, mult in self.special:
            if kind in ("gap", "stop"):
                return False
            if kind == "tanh":
                parity[var] += int(mult)
        return parity["v"] % 2 == 1 and parity["z"] % 2 == 0 and parity["px"] % 2 == 0

    @property
    def uses_px(self) -> bool:
        """True if the term contains ``px(z)`` (needs the roots z^±)."""
        return self.px != (0, 0)

    @property
    def family(self) -> str:
        """``"damping"`` if the term depends on velocity, ``"memory"`` for a memory term, else ``"stiffness"``.

        The constant ``1`` (a static load such as gravity) belongs to the
        elastic part ``K(z)`` as in Eq. 6, hence to the stiffness family.
        """
        if self.memory is not None:
            return "memory"
        return "damping" if self.depends_on_v else "stiffness"

    @property
    def is_memory(self) -> bool:
        """True for a memory (hysteretic) term, whose value depends on the path of ``z``."""
        return self.memory is not None

    @property
    def shapes(self) -> tuple[float, ...]:
        """The term's shape parameters: the scale of each special factor, or a memory law's parameters."""
        if self.memory is not None:
            return tuple(self.memory[1])
        return tuple(scale for _, _, scale, _ in self.special)

    @property
    def shape_names(self) -> tuple[str, ...]:
        """A name for each shape parameter (``c`` for scales, ``d`` for clearances, the memory law's own)."""
        if self.memory is not None:
            from .memory import KINDS

            return KINDS[self.memory[0]][0]
        return tuple("d" if kind in _LINEAR_KINDS else "c" for kind, _, _, _ in self.special)

    def with_shapes(self, values: tuple[float, ...] | list[float]) -> Term:
        """The same term with new shape parameters (in the order of :attr:`shapes`).

        Raises
        ------
        ValueError
            Wrong number of values, or a value the factor does not admit
            (scales and Dahl's ``rho`` must be positive, ``gap`` clearances
            non-negative, every value finite).
        """
        values = tuple(float(x) for x in values)
        if len(values) != len(self.shapes):
            raise ValueError(f"term {self.name!r} has {len(self.shapes)} shape parameters, got {len(values)}")
        if not all(np.isfinite(values)):
            raise ValueError(f"shape parameters of {self.name!r} must be finite, got {values}")
        if self.memory is not None:
            if self.memory[0] == "dahl" and not values[0] > 0:
                raise ValueError(f"dahl's rho must be positive, got {values[0]}")
            return Term(memory=(self.memory[0], values))
        special = []
        for (kind, var, _, mult), value in zip(self.special, values, strict=True):
            if kind in ("exp1", "exp2", "tanh") and not value > 0:
                raise ValueError(f"the scale of {kind} must be positive, got {value}")
            if kind == "gap" and value < 0:
                raise ValueError(f"a gap's clearance must not be negative, got {value}")
            special.append((kind, var, float(format(value, ".6g")), mult))
        return Term(z=self.z, v=self.v, px=self.px, special=tuple(sorted(special)))

    @property
    def is_constant(self) -> bool:
        """True for the term ``1``."""
        return self == Term()

    @property
    def polynomial_power(self) -> int | None:
        """``k`` if the term is exactly ``z^k`` (``k >= 0``), else ``None``."""
        if self.v != (0, 0) or self.px != (0, 0) or self.special or self.memory is not None:
            return None
        p, s = self.z
        return p if p % 2 == s else None

    def _dimensions(self) -> tuple[int, int]:
        """(power of m, power of 1/s) of the term's value."""
        if self.memory is not None:
            from .memory import KINDS

            return (1 if KINDS[self.memory[0]][1] == "m" else 0), 0
        meters = self.z[0] + self.v[0]
        seconds = self.v[0]
        for kind, var, _, mult in self.special:
            if kind in _LINEAR_KINDS:
                meters += mult
                seconds += mult if var == "v" else 0
        return meters, seconds

    @property
    def unit(self) -> str:
        """SI unit of the term's value, e.g. ``"m^3"`` or ``"m^2/s^2"``."""
        meters, seconds = self._dimensions()
        if meters == 0:
            return "1"
        num = "m" if meters == 1 else f"m^{meters}"
        if seconds == 0:
            return num
        return num + ("/s" if seconds == 1 else f"/s^{seconds}")

    @property
    def coefficient_unit(self) -> str:
        """SI unit of the term's coefficient in ``R`` (newtons per term unit)."""
        return self.coefficient_unit_in()

    def coefficient_unit_in(self, force: str = "N", length: str = "m") -> str:
        """The unit of the term's coefficient for a record whose force is in ``force`` and displacement in ``length``.

        ``force`` per unit of the term, simplified (:func:`nlid.base.dimensions.coefficient_unit`):
        ``N*s^2/m^2`` for ``v*|v|`` in SI, ``s^2/V`` for a record in volts (the Silverbox circuit).
        """
        meters, seconds = self._dimensions()
        return coefficient_unit(meters, seconds, force, length)

    def sort_key(self) -> tuple:
        """Key for the canonical order of terms in a model.

        Stiffness before damping; within a family by power of the leading
        variable, then position-dependent (px, special) terms last.
        """
        lead = self.v if self.depends_on_v else self.z
        other = self.z if self.depends_on_v else self.v
        complex_ = self.px != (0, 0) or bool(self.special)
        family = 2 if self.memory is not None else int(self.depends_on_v)
        return (family, complex_, lead, other, self.px, self.special, self.memory or ("", ()))

    # ------------------------------------------------------------------ evaluation
    def evaluate(
        self,
        z: np.ndarray,
        v: np.ndarray | None = None,
        px: np.ndarray | None = None,
        cache: dict | None = None,
    ) -> np.ndarray:
        """Evaluate the term on samples of ``z`` (and ``v``, ``px(z)`` if used).

        Parameters
        ----------
        z, v
            Displacement and velocity arrays of equal shape.
        px
            ``px(z)`` evaluated on ``z`` (see :meth:`nlid.model.terms.Model.px`).
        cache
            Optional dictionary shared between terms to reuse powers.

        A memory term is integrated along ``z`` taken as consecutive samples
        of the motion (:mod:`nlid.model.terms.memory`), starting from ``w = 0``.
        """
        if self.memory is not None:
            from .memory import path

            return path(self.memory[0], self.memory[1], np.asarray(z, dtype=float).ravel()).reshape(np.shape(z))
        cache = {} if cache is None else cache
        values: Mapping[str, np.ndarray | None] = {"z": z, "v": v, "px": px}
        out: np.ndarray | None = None
        for var in VARIABLES:
            part = getattr(self, var)
            if part == (0, 0):
                continue
            x = values[var]
            if x is None:
                raise ValueError(f"term {self.name!r} needs {_SPELLING[var]}")
            piece = _signed_power(x, part, cache)
            out = piece if out is None else out * piece
        for kind, var, scale, mult in self.special:
            x = values[var]
            if x is None:
                raise ValueError(f"term {self.name!r} needs {var}")
            if kind == "exp1":
                piece = np.exp(-np.abs(x) * (mult / scale))
            elif kind == "exp2":
                piece = np.exp(-mult * (x / scale) ** 2)
            elif kind == "gap":
                piece = (np.sign(x) * np.maximum(np.abs(x) - scale, 0.0)) ** mult
            elif kind == "stop":
                piece = (np.maximum(x - scale, 0.0) if scale >= 0 else np.minimum(x - scale, 0.0)) ** mult
            else:
                piece = np.tanh(x / scale) ** mult
            out = piece if out is None else out * piece
        if out is None:
            return np.ones_like(np.asarray(z, dtype=float))
        if out is z or out is v or out is px:
            out = np.array(out, dtype=float)
        return out

    def slope_at_rest(self) -> tuple[str, float]:
        """How the term behaves for small velocity at fixed position.

        Returns
        -------
        kind : str
            ``"static"`` (does not depend on v), ``"linear"`` (``g ~ Z(z) v * k``),
            ``"flat"`` (vanishes faster than v) or ``"nonsmooth"`` (Coulomb-like,
            no derivative at v = 0).
        factor : float
            For ``"linear"``, the constant ``k`` such that
            ``dg/dv(z, 0) = k * g_z(z)`` where ``g_z`` is the term's z/px part.
        """
        if not self.depends_on_v:
            return "static", 0.0  # memory terms too: they depend on the path of z only
        p, s = self.v
        factor = 1.0
        for kind, var, scale, mult in self.special:
            if var != "v":
                continue
            if kind == "tanh":
                p += mult
                s = (s + mult) % 2
                factor /= scale**mult
            elif kind == "exp1":
                pass  # exp(-|v|/c) -> 1, its correction is O(|v|)
        if p == 0:
            return "nonsmooth", 0.0
        if p == 1:
            return ("linear", factor) if s == 1 else ("nonsmooth", 0.0)
        return "flat", 0.0

    @property
    def memory_slope(self) -> float:
        """For a memory term, ``dw/dz`` at ``w = 0`` (its small-amplitude stiffness per unit coefficient); else 0."""
        if self.memory is None:
            return 0.0
        from .memory import initial_slope

        return initial_slope(*self.memory)

    def position_part(self) -> Term:
        """The term with every velocity factor removed (the ``g_z`` above)."""
        special = tuple(s for s in self.special if s[1] != "v")
        return Term(z=self.z, px=self.px, special=special)
