"""The slopes of a term: its value with its partial derivatives in ``z`` and ``v``, and where it is not smooth.

What a Newton solver on the term language needs (the harmonic balance of
:mod:`nlid.response` builds its exact Jacobian from these): for a term
``g(z, v)`` of :mod:`nlid.model.terms.term` in normal form, :func:`slopes` gives
``g``, ``dg/dz`` and ``dg/dv`` on arrays by the product rule over its factors,

* a part ``|x|^p sign(x)^s`` has the derivative ``p |x|^(p-1) sign(x)^(1-s)``
  (``0`` for ``p = 0``: a sign factor is flat except at ``x = 0``, where it
  jumps);
* ``px(z)`` enters through the chain rule with ``px'(z) = 3 alpha z^2 + 2 beta z + gamma``;
* ``exp(-|x|/c)``, ``exp(-(x/c)^2)``, ``tanh(x/c)``, ``gap(x, d)`` and
  ``stop(x, d)`` by their own derivatives (the last two are 0 inside the clearance).

:func:`switches` lists the points where a term is not smooth, so that a
quadrature can put a break there: ``("z" or "v", level, jumps)`` for each
value of ``z`` or ``v`` at which the term has a kink (``jumps=False``) or a
jump (``jumps=True``: a sign factor ``sign(x)`` with no power of ``x``
beside it, as in Coulomb friction ``sign(v)`` or ``sign(v)*|px(z)|``). A
factor of ``px(z)`` breaks where ``px`` has a real root. Memory terms have no
slopes here (their state follows the path: :mod:`nlid.model.terms.memory`).
"""

from __future__ import annotations

import numpy as np

from .term import Term

__all__ = ["slopes", "switches", "px_slope"]

Array = np.ndarray


def _part(x: Array, p: int, s: int) -> tuple[Array, Array]:
    """``|x|^p sign(x)^s`` and its derivative in ``x`` (0 where a pure sign factor jumps)."""
    if p == 0:
        value = np.sign(x) if s else np.ones_like(x)
        return value, np.zeros_like(x)
    ax = np.abs(x)
    lower = ax ** (p - 1) if p > 1 else np.ones_like(x)
    value = lower * ax
    if s:
        value = value * np.sign(x)
    slope = p * lower
    if not s:  # d|x|^p/dx = p |x|^(p-1) sign(x)
        slope = slope * np.sign(x)
    if p % 2 == s:  # a plain power: exact without the sign products (x^3, x)
        value = x**p
    return value, slope


def _special(kind: str, x: Array, scale: float, mult: int) -> tuple[Array, Array]:
    """A special factor (``exp1``, ``exp2``, ``tanh``, ``gap``, ``stop``) and its derivative in its variable."""
    if kind == "exp1":
        value = np.exp(-np.abs(x) * (mult / scale))
        return value, -(mult / scale) * np.sign(x) * value
    if kind == "exp2":
        value = np.exp(-mult * (x / scale) ** 2)
        return value, -2.0 * mult * x / scale**2 * value
    if kind == "tanh":
        t = np.tanh(x / scale)
        return t**mult, mult * t ** (mult - 1) * (1.0 - t * t) / scale
    if kind == "gap":
        y = np.sign(x) * np.maximum(np.abs(x) - scale, 0.0)
        dy = (np.abs(x) > scale).astype(float)
    else:  # stop
        y = np.maximum(x - scale, 0.0) if scale >= 0 else np.minimum(x - scale, 0.0)
        dy = ((x > scale) if scale >= 0 else (x < scale)).astype(float)
    return y**mult, mult * y ** (mult - 1) * dy if mult > 1 else dy


def px_slope(pxc: tuple[float, float, float, float], z: Array) -> tuple[Array, Array]:
    """``px(z)`` and ``px'(z)`` from its coefficients ``(alpha, beta, gamma, delta)``."""
    a, b, c, d = pxc
    return ((a * z + b) * z + c) * z + d, (3.0 * a * z + 2.0 * b) * z + c


def slopes(
    term: Term,
    z: Array,
    v: Array | None = None,
    pxc: tuple[float, float, float, float] | None = None,
    cache: dict | None = None,
) -> tuple[Array, Array, Array]:
    """``g``, ``dg/dz`` and ``dg/dv`` of a term on samples (arrays of one shape).

    Parameters
    ----------
    term
        A term that is not a memory term.
    z, v
        Displacement and velocity samples (``v`` only if the term uses it).
    pxc
        The coefficients ``(alpha, beta, gamma, delta)`` of ``px(z)``
        (:func:`nlid.model.terms.px_coefficients`), if the term uses it.
    cache
        A dictionary shared by terms evaluated on the same samples: ``px(z)`` and the parts are computed once.

    Raises
    ------
    ValueError
        A memory term, or a variable the term needs that is not given.
    """
    if term.memory is not None:
        raise ValueError(f"term {term.name!r} is a memory term: its state follows the path of z, not a slope")
    z = np.asarray(z, dtype=float)
    cache = {} if cache is None else cache
    factors: list[tuple[Array, Array, str]] = []  # (value, derivative, "z" or "v")

    def part(name: str, x: Array, p: tuple[int, int]) -> tuple[Array, Array]:
        key = (name, p)
        if key not in cache:
            cache[key] = _part(x, *p)
        return cache[key]

    if term.z != (0, 0):
        factors.append((*part("z", z, term.z), "z"))
    if term.v != (0, 0):
        if v is None:
            raise ValueError(f"term {term.name!r} needs v")
        factors.append((*part("v", np.asarray(v, dtype=float), term.v), "v"))
    if term.px != (0, 0):
        if pxc is None:
            raise ValueError(f"term {term.name!r} needs the coefficients of px(z)")
        if "px" not in cache:
            cache["px"] = px_slope(pxc, z)
        px, dpx = cache["px"]
        value, slope = part("px", px, term.px)
        factors.append((value, slope * dpx, "z"))
    for kind, var, scale, mult in term.special:
        x = z if var == "z" else v
        if x is None:
            raise ValueError(f"term {term.name!r} needs {var}")
        factors.append((*_special(kind, np.asarray(x, dtype=float), scale, mult), var))
    ones = np.ones_like(z)
    value = ones
    dz = np.zeros_like(z)
    dv = np.zeros_like(z)
    for i, (_, slope, var) in enumerate(factors):
        others = ones
        for j, (val, _, _) in enumerate(factors):
            if j != i:
                others = others * val
        if var == "z":
            dz = dz + slope * others
        else:
            dv = dv + slope * others
    for val, _, _ in factors:
        value = value * val
    return value, dz, dv


def _part_switch(part: tuple[int, int]) -> str | None:
    """``"jump"``, ``"kink"`` or ``None`` (smooth) for a part ``(p, s)`` at ``x = 0``."""
    p, s = part
    if part == (0, 0) or p % 2 == s:
        return None
    return "jump" if p == 0 else "kink"


def switches(term: Term, pxc: tuple[float, float, float, float] | None = None) -> list[tuple[str, float, bool]]:
    """The values of ``z`` and ``v`` where the term is not smooth: ``(variable, level, jumps)``.

    See the module docstring. A ``px(z)`` part breaks at each real root of
    ``px`` (the cubic's roots, found with :func:`numpy.roots`).
    """
    if term.memory is not None:
        return []
    out: list[tuple[str, float, bool]] = []
    for var in ("z", "v"):
        kind = _part_switch(getattr(term, var))
        if kind:
            out.append((var, 0.0, kind == "jump"))
    kind = _part_switch(term.px)
    if kind and pxc is not None:
        roots = np.roots(np.asarray(pxc, dtype=float))
        for r in roots:
            if abs(r.imag) <= 1e-12 * max(1.0, abs(r.real)):
                out.append(("z", float(r.real), kind == "jump"))
    for kind, var, scale, _ in term.special:
        if kind == "exp1":
            out.append((var, 0.0, False))
        elif kind == "gap":
            out += [(var, scale, False), (var, -scale, False)]
        elif kind == "stop":
            out.append((var, scale, False))
    return out
