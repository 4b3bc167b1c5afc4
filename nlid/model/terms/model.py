"""A model: the set of basis functions of ``R(z, v) = sum_i theta_i g_i(z, v)``.

The underlying-linear terms ``z`` and ``v`` and the constant ``1`` (static
load, e.g. gravity ``m g``) are part of every model by default, as in the
paper's NSI (Eq. 5, 13-16); the user names the others and may remove a
default with ``without=``.

``px(z)`` (Eq. 10) is the normal-force polynomial
``alpha z^3 + beta z^2 + gamma z + delta`` with ``px(z^-) = px(z^+) = 0``,
``px(0) = 1`` and ``px'(0) = 0`` (Eq. 9). Its coefficients follow from the
roots ``z^- < 0 < z^+`` (the corrected Eq. 11 of NOTES.md):
``delta = 1``, ``gamma = 0``, ``alpha = (z^- + z^+) / (z^+^2 z^-^2)``,
``beta = -(1 + alpha z^+^3) / z^+^2``.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np

from ...errors import InputError, TermError
from .grammar import parse_term, split_terms
from .term import Term

__all__ = ["Model", "DEFAULT_TERMS", "px_coefficients"]

#: Terms included in every model unless removed.
DEFAULT_TERMS: tuple[str, ...] = ("1", "z", "v")


def px_coefficients(z_minus: float, z_plus: float) -> tuple[float, float, float, float]:
    """Coefficients ``(alpha, beta, gamma, delta)`` of ``px(z)`` (Eq. 10-11).

    Parameters
    ----------
    z_minus, z_plus
        The non-zero roots of the stiffness polynomial ``p_zeta`` (Eq. 4),
        ``z_minus < 0 < z_plus``.
    """
    zm, zp = float(z_minus), float(z_plus)
    if not (zm < 0.0 < zp):
        raise InputError(f"px(z) needs roots z- < 0 < z+, got z- = {zm:g}, z+ = {zp:g}")
    alpha = (zm + zp) / (zp**2 * zm**2)
    beta = -(1.0 + alpha * zp**3) / zp**2
    return alpha, beta, 0.0, 1.0


def _as_terms(spec: str | Iterable[str | Term]) -> list[tuple[Term, str]]:
    """Parse a comma-separated string or an iterable of terms."""
    out: list[tuple[Term, str]] = []
    if isinstance(spec, str):
        for piece, offset in split_terms(spec):
            try:
                out.append((parse_term(piece), piece.strip()))
            except TermError as exc:
                pos = None if exc.position is None else exc.position + offset
                raise TermError(exc.reason, spec, pos) from None
        return out
    for item in spec:
        if isinstance(item, Term):
            out.append((item, item.name))
        else:
            out.append((parse_term(item), str(item).strip()))
    return out


@dataclass(frozen=True)
class Model:
    """An ordered, duplicate-free set of terms (canonical order).

    Build it with :meth:`Model.from_spec`.

    Attributes
    ----------
    terms
        The terms, in canonical order (stiffness family first).
    px_roots
        ``(z^-, z^+)`` used to evaluate ``px(z)``; ``None`` if not set yet.
    """

    terms: tuple[Term, ...]
    px_roots: tuple[float, float] | None = None
    _index: dict = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        terms = tuple(sorted(set(self.terms), key=Term.sort_key))
        if not terms:
            raise InputError("a model needs at least one term")
        object.__setattr__(self, "terms", terms)
        object.__setattr__(self, "_index", {t.name: i for i, t in enumerate(terms)})
        if self.px_roots is not None:
            roots = (float(self.px_roots[0]), float(self.px_roots[1]))
            px_coefficients(*roots)  # validates
            object.__setattr__(self, "px_roots", roots)

    @classmethod
    def from_spec(
        cls,
        spec: str | Iterable[str | Term] = (),
        *,
        defaults: bool = True,
        without: str | Iterable[str | Term] = (),
        px_roots: Sequence[float] | None = None,
    ) -> Model:
        """Build a model from the user's terms.

        Parameters
        ----------
        spec
            Comma-separated string (``"z^3, z^2, v*|v|"``) or iterable of terms.
        defaults
            Include :data:`DEFAULT_TERMS` (``1``, ``z``, ``v``).
        without
            Terms to remove (usually default ones, e.g. ``"1"``).
        px_roots
            ``(z^-, z^+)`` for terms that use ``px(z)``.

        Raises
        ------
        TermError
            For a malformed term, or one listed twice under different spellings.
        """
        user = _as_terms(spec)
        seen: dict[Term, str] = {}
        for term, text in user:
            if term in seen:
                raise TermError(
                    f"terms {seen[term]!r} and {text!r} are the same function ({term.name}); list it once"
                    if seen[term] != text
                    else f"term {text!r} is listed twice"
                )
            seen[term] = text
        terms = [t for t, _ in user]
        if defaults:
            terms += [parse_term(t) for t in DEFAULT_TERMS]
        removed = {t for t, _ in _as_terms(without)}
        terms = [t for t in terms if t not in removed]
        if not terms:
            raise InputError("the model has no terms left")
        roots = None if px_roots is None else (float(px_roots[0]), float(px_roots[1]))
        return cls(tuple(terms), roots)

    # ------------------------------------------------------------------ queries
    @property
    def names(self) -> tuple[str, ...]:
        """Canonical names of the terms, in order."""
        return tuple(t.name for t in self.terms)

    def __len__(self) -> int:
        return len(self.terms)

    def __iter__(self):
        return iter(self.terms)

    def __contains__(self, item: object) -> bool:
        name = item.name if isinstance(item, Term) else parse_term(str(item)).name
        return name in self._index

    def index(self, term: str | Term) -> int:
        """Column index of ``term`` (any spelling)."""
        name = term.name if isinstance(term, Term) else parse_term(term).name
        try:
            return self._index[name]
        except KeyError:
            raise InputError(f"term {name!r} is not in the model ({', '.join(self.names)})") from None

    @property
    def uses_velocity(self) -> bool:
        """True if any term depends on velocity."""
        return any(t.depends_on_v for t in self.terms)

    @property
    def uses_memory(self) -> bool:
        """True if any term is a memory (hysteretic) term, evaluated along the path of ``z``."""
        return any(t.is_memory for t in self.terms)

    @property
    def shapes(self) -> tuple[tuple[float, ...], ...]:
        """The shape parameters of each term (empty tuples for terms without)."""
        return tuple(t.shapes for t in self.terms)

    def with_term_shapes(self, term: str | Term, values: Sequence[float]) -> Model:
        """The model with one term's shape parameters changed (the term's name changes with them)."""
        old = self.terms[self.index(term)]
        new = old.with_shapes(tuple(values))
        if new != old and new in self.terms:
            raise InputError(f"changing {old.name} to {new.name} duplicates a term of the model")
        return Model(tuple(new if t == old else t for t in self.terms), self.px_roots)

    @property
    def uses_px(self) -> bool:
        """True if any term contains ``px(z)``."""
        return any(t.uses_px for t in self.terms)

    def family(self, family: str) -> tuple[Term, ...]:
        """Terms of the ``"stiffness"`` or ``"damping"`` family."""
        return tuple(t for t in self.terms if t.family == family)

    def __str__(self) -> str:
        return ", ".join(self.names)

    # ------------------------------------------------------------------ derived models
    def with_px_roots(self, roots: Sequence[float] | None) -> Model:
        """The same terms with new ``px(z)`` roots."""
        return Model(self.terms, None if roots is None else (float(roots[0]), float(roots[1])))

    def with_terms(self, add: str | Iterable[str | Term] = (), remove: str | Iterable[str | Term] = ()) -> Model:
        """A model with terms added and/or removed."""
        removed = {t for t, _ in _as_terms(remove)}
        terms = [t for t in self.terms if t not in removed] + [t for t, _ in _as_terms(add)]
        return Model(tuple(terms), self.px_roots)

    # ------------------------------------------------------------------ evaluation
    def px(self, z: np.ndarray) -> np.ndarray:
        """``px(z)`` of Eq. 10 with this model's roots."""
        if self.px_roots is None:
            raise InputError("the model uses px(z) but its roots z-, z+ are not set")
        alpha, beta, gamma, delta = px_coefficients(*self.px_roots)
        z = np.asarray(z, dtype=float)
        return ((alpha * z + beta) * z + gamma) * z + delta

    def evaluate(self, z: np.ndarray, v: np.ndarray | None = None, *, order: str = "C") -> np.ndarray:
        """The regressor matrix ``G[k, i] = g_i(z_k, v_k)``, shape ``(N, p)``.

        Parameters
        ----------
        z, v
            Samples of displacement and velocity (``v`` only if a term needs it).
        order
            The matrix's memory layout: ``"C"`` (rows contiguous, default) or ``"F"`` (each column
            contiguous, for callers that work column by column); the same numbers.
        """
        z = np.asarray(z, dtype=float)
        if v is None and self.uses_velocity:
            raise InputError(f"the model ({self}) has velocity terms but no velocity was given")
        px = self.px(z) if self.uses_px else None
        cache: dict = {}
        if order not in ("C", "F"):
            raise InputError(f"order= must be 'C' or 'F', got {order!r}")
        out = np.empty((z.size, len(self.terms)), order=order)
        for i, term in enumerate(self.terms):
            out[:, i] = term.evaluate(z, v, px, cache)
        return out

    def evaluate_terms(
        self,
        coefficients: dict[str, float] | np.ndarray,
        z: np.ndarray,
        v: np.ndarray | None = None,
        family: str | None = None,
    ) -> np.ndarray:
        """``sum_i theta_i g_i(z, v)`` over all terms or over one family.

        Parameters
        ----------
        coefficients
            By canonical name, or a vector in model order.
        family
            ``"stiffness"`` (gives ``K(z)``), ``"damping"`` (``D(z, v)``) or
            ``None`` (``R``).
        """
        theta = self.vector(coefficients)
        keep = [i for i, t in enumerate(self.terms) if family is None or t.family == family]
        if not keep:
            return np.zeros(np.shape(z))
        sub = Model(tuple(self.terms[i] for i in keep), self.px_roots)
        zz = np.atleast_1d(np.asarray(z, dtype=float))
        vv = None if v is None else np.broadcast_to(np.asarray(v, dtype=float), zz.shape)
        if vv is None and sub.uses_velocity:
            vv = np.zeros_like(zz)
        values = sub.evaluate(zz.ravel(), None if vv is None else vv.ravel()) @ theta[keep]
        return values.reshape(np.shape(z)) if np.ndim(z) else values[0]

    def vector(self, coefficients: dict[str, float] | np.ndarray | Sequence[float]) -> np.ndarray:
        """Coefficients as a vector in model order (dicts may use any spelling)."""
        if isinstance(coefficients, dict):
            theta = np.zeros(len(self.terms))
            for name, value in coefficients.items():
                theta[self.index(name)] = float(value)
            return theta
        theta = np.asarray(coefficients, dtype=float)
        if theta.shape != (len(self.terms),):
            raise InputError(f"expected {len(self.terms)} coefficients, got shape {theta.shape}")
        return theta

    def as_dict(self, theta: np.ndarray | Sequence[float]) -> dict[str, float]:
        """Coefficient vector to ``{canonical name: value}``."""
        return {name: float(x) for name, x in zip(self.names, self.vector(theta), strict=True)}
