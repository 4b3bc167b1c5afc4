"""Terms on connections: the localised nonlinear elements of a structure.

An :class:`Element` is a term of the one-degree-of-freedom language
(:mod:`nlid.model.terms`: polynomial, friction, gap/stop, Bouc-Wen, Dahl, ``px``)
evaluated on the *relative* coordinate of a connection between two degrees
of freedom, ``x = z_i - z_j`` and ``x' = v_i - v_j``, or between one degree of
freedom and the ground, ``x = z_k``. Its force ``theta g(x, x')`` enters the
restoring force of DOF ``i`` with ``+`` and that of DOF ``j`` with ``-``
(``R = f - M a``): the connectivity vector :meth:`Element.b` has ``+1`` at
``i`` and ``-1`` at ``j``.

Spelling
--------
Degrees of freedom are numbered from 1, as engineers write them::

    (z1-z2)^3                   cubic spring between DOF 1 and DOF 2
    z3^3                        cubic spring from DOF 3 to the ground
    sign(v2-v1)                 Coulomb friction (= -sign(v1-v2))
    (v1-v2)*|v1-v2|             quadratic damping
    tanh((v1-v2)/0.001)         smoothed Coulomb friction
    gap(z1-z2, 0.001)           a spring engaging beyond a clearance
    stop(z4, -0.002)            a one-sided stop to the ground
    bouc_wen(z1-z2, 50, 10)     Bouc-Wen hysteresis on the connection
    dahl(z2, 1e-4)              Dahl friction to the ground
    sign(v1-v2)*|px(z1-z2)|     the paper's position-dependent friction

A memory law (``bouc_wen``, ``dahl``) takes the connection's displacement as
its first argument, then its parameters as in one DOF. ``px(...)`` is the
connection's normal-force polynomial (Eq. 10-11): its roots come from the
stiffness on that connection (:attr:`ElementSet.px_roots`), so it does not
depend on the order the coordinate is written in.

Every variable of one term must refer to the same connection (``(z1-z2)*v3``
is an error). A term is parsed by rewriting its indexed coordinates to the
one-DOF variables ``z`` and ``v`` and calling :func:`nlid.model.terms.parse_term`
(never ``eval``); the DOF numbers never reach that grammar.

Orientation
-----------
The canonical orientation of a connection is the lower DOF first and the
ground last: ``(1, 2)`` is ``z1 - z2``, ``(3, 0)`` is ``z3``. A term written
the other way round is normalised by its parity under ``x -> -x``: odd parts
(``sign``, odd powers, ``tanh``, ``gap``, memory laws) flip the sign of the
coefficient, even ones (``|x|``, even powers, ``exp``) do not, and
``stop(x, d)`` becomes ``-stop(x, -d)``. :func:`parse_element` returns that
sign with the element; coefficients given under any spelling are converted by
:meth:`ElementSet.vector`.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..base.frozen import FrozenDict
from ..errors import InputError, TermError
from .spelling import Connection, canonical, render, rewrite
from .terms import Model, Term, split_terms

__all__ = [
    "Element",
    "ElementSet",
    "parse_element",
]


@dataclass(frozen=True)
class Element:
    """A term on a connection: ``theta g(x, x')`` with ``x = z_i - z_j`` (``x = z_i`` when ``j = 0``).

    Build elements with :func:`parse_element` (any spelling, any orientation);
    the constructor takes the canonical orientation only.

    Attributes
    ----------
    term
        The one-DOF term in normal form, evaluated on the relative coordinate.
    i, j
        The DOFs it connects (1-based), ``i < j``; ``j = 0`` is the ground.
    """

    term: Term
    i: int
    j: int = 0

    def __post_init__(self) -> None:
        if not isinstance(self.term, Term):
            raise InputError(f"an element's term must be an nlid Term, got {type(self.term).__name__}")
        for name in ("i", "j"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
                raise InputError(f"an element's DOF {name} must be an integer, got {value!r}")
            object.__setattr__(self, name, int(value))
        if self.i < 1 or self.j < 0:
            raise InputError(f"DOFs are numbered from 1 (0 is the ground), got ({self.i}, {self.j})")
        if self.i == self.j:
            raise InputError(f"an element connects two different DOFs, got ({self.i}, {self.j})")
        if (self.i, self.j) != canonical(self.i, self.j):
            raise InputError(
                f"connection ({self.i}, {self.j}) is not in canonical order (lower DOF first, ground last): "
                "build elements with parse_element"
            )
        if self.term.is_constant:
            raise InputError("the constant 1 is not an element: static loads are the model's static force per DOF")

    @property
    def connection(self) -> Connection:
        """``(i, j)``, canonical."""
        return (self.i, self.j)

    @property
    def to_ground(self) -> bool:
        """True when the element connects a DOF to the ground."""
        return self.j == 0

    @property
    def name(self) -> str:
        """The canonical spelling, e.g. ``(z1-z2)^3``, ``sign(v1-v2)``, ``z3^3``, ``bouc_wen(z1-z2, 50, 10)``."""
        return render(self.term, self.connection)

    def __str__(self) -> str:
        return self.name

    def __repr__(self) -> str:
        return f"Element({self.name!r})"

    @property
    def family(self) -> str:
        """``"stiffness"``, ``"damping"`` or ``"memory"``, as the term's (:attr:`nlid.model.terms.Term.family`)."""
        return self.term.family

    @property
    def coefficient_unit(self) -> str:
        """SI unit of the element's coefficient (the term's, on the relative coordinate)."""
        return self.term.coefficient_unit

    def b(self, n_dofs: int) -> np.ndarray:
        """The connectivity vector (``n_dofs``,): ``+1`` at DOF ``i``, ``-1`` at DOF ``j`` (none for the ground)."""
        if self.i > n_dofs or self.j > n_dofs:
            raise InputError(f"element {self.name} acts on DOF {max(self.i, self.j)} but the structure has {n_dofs}")
        out = np.zeros(n_dofs)
        out[self.i - 1] = 1.0
        if self.j:
            out[self.j - 1] = -1.0
        return out

    def relative(self, z: np.ndarray) -> np.ndarray:
        """The relative coordinate ``z_i - z_j`` of samples ``z`` of shape ``(N, n)`` (or ``(n,)``)."""
        z = np.asarray(z, dtype=float)
        x = z[..., self.i - 1]
        return x - z[..., self.j - 1] if self.j else x.copy()

    def evaluate(
        self, x: np.ndarray, xd: np.ndarray | None = None, px_roots: Sequence[float] | None = None
    ) -> np.ndarray:
        """``g(x, x')`` on samples of the relative coordinate (a memory term is integrated along ``x`` from 0).

        Parameters
        ----------
        x, xd
            Relative displacement (m) and velocity (m/s); ``xd`` only if the term uses it.
        px_roots
            ``(z-, z+)`` of the connection's ``px`` polynomial, when the term uses it.
        """
        model = Model((self.term,), None if px_roots is None else (float(px_roots[0]), float(px_roots[1])))
        x = np.asarray(x, dtype=float)
        if xd is None and self.term.depends_on_v:
            raise InputError(f"element {self.name} depends on the velocity; give it")
        return model.evaluate(x.ravel(), None if xd is None else np.asarray(xd, dtype=float).ravel())[:, 0].reshape(
            x.shape
        )


def parse_element(text: str) -> tuple[Element, float]:
    """Parse a term on a connection, e.g. ``"sign(v2-v1)"``: ``(element, sign)``.

    Parameters
    ----------
    text
        The term as written, with indexed coordinates (module docstring).

    Returns
    -------
    tuple
        The :class:`Element` in canonical orientation and normal form, and
        ``+1.0`` or ``-1.0``: the written term equals ``sign`` times the
        element (``sign(v2-v1)`` is ``-1 * sign(v1-v2)``).

    Raises
    ------
    TermError
        A malformed term (the position refers to ``text``), a coordinate
        without its DOF number, two connections in one term, or one
        coordinate written in both orders.
    """
    term, connection, sign = rewrite(text)
    return Element(term, *connection), sign


# --------------------------------------------------------------------------- a set of elements
def _order(element: Element) -> tuple:
    i, j = element.connection
    return (i, j if j else 10**9, element.term.sort_key())


@dataclass(frozen=True)
class ElementSet:
    """What a structure's nonlinear part is made of: an ordered, duplicate-free set of elements on ``n_dofs`` DOFs.

    The multi-DOF counterpart of :class:`nlid.model.terms.Model`: identifiers of
    several DOFs receive one (with the record) and estimate a coefficient per
    element, together with the underlying linear system (``M``, ``C``,
    ``K``) and, when :attr:`static` is set, a constant force per DOF (a
    static load such as gravity, the counterpart of the one-DOF term ``1``).

    Build it with :meth:`from_spec`.

    Attributes
    ----------
    elements
        The elements in canonical order (by connection, then as one-DOF terms).
    n_dofs
        Number of DOFs of the structure.
    static
        Whether the model has a constant force per DOF.
    px_roots
        ``{connection: (z-, z+)}`` of the ``px`` polynomial of each connection that uses it.
    """

    elements: tuple[Element, ...]
    n_dofs: int
    static: bool = True
    px_roots: Mapping[Connection, tuple[float, float]] = field(default_factory=FrozenDict)

    def __post_init__(self) -> None:
        elements = tuple(sorted(set(self.elements), key=_order))
        n = self.n_dofs
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
            raise InputError(f"n_dofs must be a positive integer, got {n!r}")
        object.__setattr__(self, "n_dofs", int(n))
        for e in elements:
            if max(e.i, e.j) > n:
                raise InputError(f"element {e.name} acts on DOF {max(e.i, e.j)} but the structure has {n}")
        object.__setattr__(self, "elements", elements)
        roots = {}
        for conn, pair in dict(self.px_roots or {}).items():
            key = canonical(int(conn[0]), int(conn[1]))
            zm, zp = float(pair[0]), float(pair[1])
            if not zm < 0.0 < zp:
                raise InputError(f"px roots of connection {key} must satisfy z- < 0 < z+, got ({zm:g}, {zp:g})")
            roots[key] = (zm, zp)
        object.__setattr__(self, "px_roots", FrozenDict(roots))

    @classmethod
    def from_spec(
        cls,
        spec: str | Iterable[str | Element] = (),
        n_dofs: int | None = None,
        *,
        static: bool = True,
        px_roots: Mapping[Connection, Sequence[float]] | None = None,
    ) -> ElementSet:
        """Parse ``"(z1-z2)^3, sign(v2-v1), z3^3"`` (or an iterable of terms or elements).

        Parameters
        ----------
        spec
            Comma-separated terms on connections (module docstring).
        n_dofs
            Number of DOFs; default: the highest DOF an element names.
        static
            Include a constant force per DOF.
        px_roots
            ``{(i, j): (z-, z+)}`` for connections whose terms use ``px``.

        Raises
        ------
        TermError
            A malformed term, or one element listed twice (under any spelling).
        """
        items: list[tuple[Element, str]] = []
        if isinstance(spec, str):
            for piece, offset in split_terms(spec):
                try:
                    element, _ = parse_element(piece)
                except TermError as exc:
                    pos = None if exc.position is None else exc.position + offset
                    raise TermError(exc.reason, spec, pos) from None
                items.append((element, piece.strip()))
        else:
            for item in spec:
                element = item if isinstance(item, Element) else parse_element(item)[0]
                items.append((element, str(item).strip()))
        seen: dict[Element, str] = {}
        for element, text in items:
            if element in seen:
                raise TermError(
                    f"terms {seen[element]!r} and {text!r} are the same element ({element.name}); list it once"
                    if seen[element] != text
                    else f"term {text!r} is listed twice"
                )
            seen[element] = text
        elements = tuple(seen)
        if n_dofs is None:
            if not elements:
                raise InputError("n_dofs is needed when no element names the DOFs")
            n_dofs = max(max(e.i, e.j) for e in elements)
        return cls(elements, n_dofs, static, FrozenDict({k: tuple(v) for k, v in dict(px_roots or {}).items()}))

    # ------------------------------------------------------------------ queries
    @property
    def names(self) -> tuple[str, ...]:
        """Canonical names of the elements, in order."""
        return tuple(e.name for e in self.elements)

    def __len__(self) -> int:
        return len(self.elements)

    def __iter__(self):
        return iter(self.elements)

    def __str__(self) -> str:
        return ", ".join(self.names)

    @property
    def connections(self) -> tuple[Connection, ...]:
        """The connections carrying elements, in order, each once."""
        return tuple(dict.fromkeys(e.connection for e in self.elements))

    @property
    def B(self) -> np.ndarray:
        """Connectivity matrix ``(n_dofs, len(self))``: column ``e`` is :meth:`Element.b`."""
        out = np.zeros((self.n_dofs, len(self.elements)))
        for k, e in enumerate(self.elements):
            out[:, k] = e.b(self.n_dofs)
        return out

    def locate(self, term: str | Element) -> tuple[int, float]:
        """``(index, sign)`` of a term written in any spelling and orientation."""
        element, sign = (term, 1.0) if isinstance(term, Element) else parse_element(term)
        for k, e in enumerate(self.elements):
            if e == element:
                return k, sign
        raise InputError(f"{element.name} is not an element of the model ({self})")

    def index(self, term: str | Element) -> int:
        """Position of an element (any spelling)."""
        return self.locate(term)[0]

    def vector(self, coefficients: Mapping[str, float] | Sequence[float] | np.ndarray) -> np.ndarray:
        """Coefficients as a vector in element order; a mapping may use any spelling (signs follow orientation)."""
        if isinstance(coefficients, Mapping):
            theta = np.zeros(len(self.elements))
            for name, value in coefficients.items():
                k, sign = self.locate(name)
                theta[k] = sign * float(value)
            return theta
        theta = np.asarray(coefficients, dtype=float)
        if theta.shape != (len(self.elements),):
            raise InputError(f"expected {len(self.elements)} coefficients, got shape {theta.shape}")
        return theta

    def as_dict(self, theta: Sequence[float] | np.ndarray) -> dict[str, float]:
        """Coefficient vector to ``{canonical name: value}``."""
        return {n: float(x) for n, x in zip(self.names, self.vector(theta), strict=True)}

    def roots_of(self, element: Element) -> tuple[float, float] | None:
        """The ``px`` roots of an element's connection (``None`` when it does not use ``px``)."""
        if not element.term.uses_px:
            return None
        roots = self.px_roots.get(element.connection)
        if roots is None:
            raise InputError(f"{element.name} uses px but the roots of connection {element.connection} are not set")
        return roots

    def with_px_roots(self, roots: Mapping[Connection, Sequence[float]]) -> ElementSet:
        """The same elements with ``px`` roots set (or replaced) per connection."""
        merged = {**dict(self.px_roots), **{k: tuple(v) for k, v in roots.items()}}
        return ElementSet(self.elements, self.n_dofs, self.static, FrozenDict(merged))

    # ------------------------------------------------------------------ evaluation
    def relative(self, z: np.ndarray, v: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
        """The relative coordinates of every element: ``x`` and ``x'`` of shape ``(N, len(self))``."""
        B = self.B
        z = np.asarray(z, dtype=float).reshape(-1, self.n_dofs)
        x = z @ B
        xd = None if v is None else np.asarray(v, dtype=float).reshape(-1, self.n_dofs) @ B
        return x, xd

    def evaluate(self, z: np.ndarray, v: np.ndarray | None = None) -> np.ndarray:
        """The regressors ``G[k, e] = g_e(x_e(k), x'_e(k))`` on samples ``z``, ``v`` of shape ``(N, n_dofs)``.

        Memory elements are integrated along their relative displacement from
        ``w = 0`` (:mod:`nlid.model.terms.memory`).
        """
        x, xd = self.relative(z, v)
        out = np.empty_like(x)
        for k, e in enumerate(self.elements):
            if e.term.depends_on_v and xd is None:
                raise InputError(f"element {e.name} depends on the velocity; give v")
            out[:, k] = e.evaluate(x[:, k], None if xd is None else xd[:, k], self.roots_of(e))
        return out

    def to_dict(self) -> dict[str, Any]:
        """``{"elements": [...], "n_dofs": n, "static": bool, "px_roots": {"1-2": [z-, z+]}}``."""
        return {
            "elements": list(self.names),
            "n_dofs": self.n_dofs,
            "static": self.static,
            "px_roots": {f"{i}-{j}": list(r) for (i, j), r in self.px_roots.items()} or None,
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> ElementSet:
        """Inverse of :meth:`to_dict`."""
        roots = {}
        for key, pair in dict(data.get("px_roots") or {}).items():
            i, _, j = str(key).partition("-")
            roots[(int(i), int(j))] = tuple(pair)
        return cls.from_spec(
            list(data.get("elements") or ()), int(data["n_dofs"]), static=bool(data.get("static", True)), px_roots=roots
        )
