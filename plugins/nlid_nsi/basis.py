"""The model's terms as the extended inputs of NSI.

NSI splits the restoring force ``R(z, v) = theta_1 + theta_z z + theta_v v +
sum_j theta_j g_j(z, v)`` into the underlying-linear part (Eq. 15: the
constant, ``z`` and ``v``) and the basis functions ``g_j`` that act as internal
feedback forces (the extended inputs ``-g_j`` of Eq. 16). Every other term of
the model, polynomial or not, becomes a :class:`Basis` evaluated through
nlid's term language (``Term.evaluate``), so it can be computed at states
between the samples (interval means) and differentiated (noise model).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from nlid.plugin import Model, Term

__all__ = ["Basis", "split_model", "shifted_basis", "int_power"]

Func = Callable[[np.ndarray, np.ndarray], np.ndarray]


@dataclass(frozen=True)
class Basis:
    """One basis function ``g(z, v)`` fed to NSI as the extended input ``-g``.

    Attributes
    ----------
    name
        Canonical term name (or ``x^k`` for the shifted powers of nsi-shift).
    func
        Vectorised ``g(z, v)``.
    power
        ``k`` for the polynomial stiffness term ``z^k``, else ``None``.
    jumps_in_z, jumps_in_v
        The function is discontinuous in that variable (``sign(...)`` factors):
        its first-order noise propagation is left out there.
    uses_z, uses_v
        The function depends on that variable (its derivative in a variable
        it does not use is zero without evaluating it).
    """

    name: str
    func: Func
    power: int | None = None
    jumps_in_z: bool = False
    jumps_in_v: bool = False
    uses_z: bool = True
    uses_v: bool = True

    def jacobian(
        self, z: np.ndarray, v: np.ndarray, hz: float | None = None, hv: float | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(dg/dz, dg/dv)`` by central differences (zero where the function jumps).

        The steps are ``1e-6`` of the standard deviations of ``z`` and ``v``
        unless given (pass those of the whole record when ``z``, ``v`` are a block of it).
        """
        hz = 1e-6 * (float(np.std(z)) + 1e-300) if hz is None else hz
        hv = 1e-6 * (float(np.std(v)) + 1e-300) if hv is None else hv
        if self.jumps_in_z or not self.uses_z:
            dz = np.zeros_like(z)
        else:
            dz = (self.func(z + hz, v) - self.func(z - hz, v)) / (2 * hz)
        if self.jumps_in_v or not self.uses_v:
            dv = np.zeros_like(z)
        else:
            dv = (self.func(z, v + hv) - self.func(z, v - hv)) / (2 * hv)
        return dz, dv


def int_power(x: np.ndarray, p: int) -> np.ndarray:
    """``x ** p`` for an integer ``p >= 1`` by square and multiply.

    NumPy evaluates ``x ** p`` with a float exponent through ``pow`` for
    ``p >= 3`` (~20 ns per element); two or three multiplications are ~10
    times faster and agree to a few ulp. Returns a new array.
    """
    x = np.asarray(x, dtype=float)
    result = None
    base = x
    while True:
        if p & 1:
            result = base.copy() if result is None else result * base
        p >>= 1
        if not p:
            return result
        base = base * base


def _part(x: np.ndarray, part: tuple[int, int]) -> np.ndarray | None:
    """``|x|^p sign(x)^s`` (``None`` for the empty part), as ``Term.evaluate`` defines it."""
    p, s = part
    if p == 0 and s == 0:
        return None
    if p % 2 == s:  # a plain power (odd with sign, even without)
        return int_power(x, p)
    if s == 0:
        return int_power(np.abs(x), p)
    sx = np.sign(x)
    return sx if p == 0 else sx * int_power(np.abs(x), p)


#: Fields and special-factor kinds of :class:`nlid.model.terms.Term` that :func:`_fast_term_func` evaluates.
_KNOWN_FIELDS = frozenset({"z", "v", "px", "special"})
_KNOWN_SPECIAL = frozenset({"exp1", "exp2", "tanh"})


def _fast_term_func(term: Term, model: Model) -> Func | None:
    """``g(z, v)`` of ``term`` with integer powers by multiplication, or ``None`` for an unknown kind of term.

    The same products, in the same order, as ``Term.evaluate`` (z, v and px
    parts, then the special factors), which ``x ** p`` makes ~10 times slower
    on long records (:func:`int_power`). A term with a field or a special
    factor this function does not know is left to ``Term.evaluate``.
    """
    if {f.name for f in dataclasses.fields(term)} != _KNOWN_FIELDS:
        return None
    if any(sp[0] not in _KNOWN_SPECIAL or sp[1] not in ("z", "v") for sp in term.special):
        return None

    def func(z: np.ndarray, v: np.ndarray) -> np.ndarray:
        z = np.asarray(z, dtype=float)
        values = {"z": z, "v": v, "px": model.px(z) if term.uses_px else None}
        out = None
        for var in ("z", "v", "px"):
            piece = _part(values[var], getattr(term, var))
            if piece is not None:
                out = piece if out is None else out * piece
        for kind, var, scale, mult in term.special:
            x = values[var]
            if kind == "exp1":
                piece = np.exp(-np.abs(x) * (mult / scale))
            elif kind == "exp2":
                piece = np.exp(-mult * (x / scale) ** 2)
            else:
                piece = np.tanh(x / scale) ** mult
            out = piece if out is None else out * piece
        if out is None:
            return np.ones_like(z)
        return out

    return func


def _term_func(term: Term, model: Model) -> Func:
    fast = _fast_term_func(term, model)
    if fast is not None:
        return fast

    def func(z: np.ndarray, v: np.ndarray) -> np.ndarray:
        px = model.px(z) if term.uses_px else None
        return np.asarray(term.evaluate(z, v, px, {}), dtype=float)

    return func


def _basis(term: Term, model: Model) -> Basis:
    jumps_z = term.z == (0, 1) or term.px == (0, 1)
    jumps_v = term.v == (0, 1)
    uses_z = term.z != (0, 0) or term.px != (0, 0) or any(sp[1] == "z" for sp in term.special)
    return Basis(term.name, _term_func(term, model), term.polynomial_power, jumps_z, jumps_v, uses_z, term.depends_on_v)


@dataclass(frozen=True)
class SplitModel:
    """A model split into the underlying-linear terms and the extended inputs.

    Attributes
    ----------
    constant, linear, viscous
        Whether the model has ``1``, ``z`` and ``v``.
    basis
        The other terms, in model order.
    """

    constant: bool
    linear: bool
    viscous: bool
    basis: tuple[Basis, ...]


def split_model(model: Model) -> SplitModel:
    """Split a model (see :class:`SplitModel`)."""
    names = set(model.names)
    others = tuple(_basis(t, model) for t in model.terms if t.name not in ("1", "z", "v"))
    return SplitModel("1" in names, "z" in names, "v" in names, others)


def shifted_basis(basis: tuple[Basis, ...], shift: float) -> tuple[tuple[Basis, ...], int]:
    """The basis in ``x = z - shift`` for the zero-reference shift (Sec. 3.1).

    Polynomial stiffness terms are re-expanded: every power ``x^k``,
    ``k = 2..kmax``, is an extended input (``z^3`` alone also needs ``x^2``);
    the linear and constant parts go to the ULS and the static balance.
    Other terms are re-centred, ``g(x + shift, v)``, and keep their names.

    Returns
    -------
    basis : tuple of Basis
    kmax : int
        Highest polynomial power (1 if there is none).
    """
    powers = [b.power for b in basis if b.power is not None]
    kmax = max(powers) if powers else 1
    out = [Basis(f"x^{k}", lambda x, v, k=k: int_power(x, k), k, uses_v=False) for k in range(kmax, 1, -1)]
    for b in basis:
        if b.power is None:
            out.append(
                Basis(
                    b.name,
                    lambda x, v, g=b.func, s=shift: g(x + s, v),
                    None,
                    b.jumps_in_z,
                    b.jumps_in_v,
                    b.uses_z,
                    b.uses_v,
                )
            )
    return tuple(out), kmax
