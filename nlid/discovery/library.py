"""Candidate effects: what the loop may add to a model.

A :class:`Candidate` is a named set of terms of the restoring force
``R(z, v) = f - m z''`` (the term language of :mod:`nlid.terms`), optionally
with one shape parameter written ``{c}`` in its terms and chosen by the loop
on a grid (:class:`Shape`). The built-in library (:data:`LIBRARY`) holds the
effects the issue names:

=============================  ==============================  ===========================================
name                           terms                           effect
=============================  ==============================  ===========================================
``coulomb``                    ``sign(v)``                     dry (Coulomb) friction, Eq. 24 with j = 0
``viscous``                    ``v``                           linear viscous damping
``quadratic-damping``          ``v*|v|``                       velocity-squared damping (Eq. 21 as read
                                                               in NOTES.md)
``cubic-damping``              ``v^3``                         cubic damping, Eq. 24 with j = 3
``position-dependent-friction`` ``sign(v)*|px(z)|``            Eq. 24 with j = 0; ``px(z)`` (Eq. 10-11)
                                                               takes its roots from the current stiffness
``stribeck``                   ``sign(v)*exp(-(v/c)^2)``       velocity-weakening (Gaussian Stribeck)
                                                               friction; ``c`` chosen on a grid
``offset``                     ``1``                           constant force (static load, sensor offset)
``quadratic-stiffness``        ``z^2``                         asymmetric stiffness
``cubic-stiffness``            ``z^3``                         hardening/softening (Duffing) spring
``quintic-stiffness``          ``z^5``                         fifth-order spring
=============================  ==============================  ===========================================

The Stribeck scale ``c`` is searched over :data:`STRIBECK_MULTIPLIERS` times
the RMS velocity of the estimation data (0.02 to 0.5 RMS(v)): a law whose
scale exceeds the velocities of the data is indistinguishable from Coulomb
friction plus quadratic damping, which the library already holds.

Users add candidates as terms (:meth:`Candidate.from_spec`,
``nlid discover --candidate NAME=TERMS``) or through the plugin hook
``nlid_candidates`` (:mod:`nlid.hookspecs`); :func:`resolve_candidates`
gathers them.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from difflib import get_close_matches

from ..errors import PASS_THROUGH, InputError, NlidError, describe_exception
from ..terms import Model, Term, parse_term

__all__ = [
    "Candidate",
    "Shape",
    "Variant",
    "LIBRARY",
    "STRIBECK_MULTIPLIERS",
    "library_names",
    "plugin_candidates",
    "resolve_candidates",
]

#: Grid of the Stribeck scale, as multiples of the RMS velocity.
STRIBECK_MULTIPLIERS: tuple[float, ...] = (0.02, 0.05, 0.1, 0.2, 0.5)
_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_.+-]*$")
_PLACEHOLDER = "{c}"


@dataclass(frozen=True)
class Shape:
    """A shape parameter ``c`` of a candidate, searched on a grid.

    Attributes
    ----------
    variable
        ``"v"`` or ``"z"``: the grid is ``multipliers * RMS(variable)`` of the
        estimation data.
    multipliers
        The grid, relative to that RMS.
    """

    variable: str
    multipliers: tuple[float, ...]

    def __post_init__(self) -> None:
        if self.variable not in ("z", "v"):
            raise InputError(f"a shape parameter scales with z or v, not {self.variable!r}")
        if not self.multipliers or any(not (m > 0) for m in self.multipliers):
            raise InputError("a shape grid needs positive multipliers")

    def grid(self, rms: Mapping[str, float]) -> list[float]:
        """The values of ``c`` for data whose RMS displacement/velocity is ``rms``."""
        scale = float(rms[self.variable])
        # three significant digits keep the term names readable
        return [float(format(m * scale, ".3g")) for m in self.multipliers]


@dataclass(frozen=True)
class Variant:
    """One concrete version of a candidate: its terms (and shape value)."""

    candidate: str
    terms: tuple[Term, ...]
    shape: float | None = None
    positive: tuple[Term, ...] = ()

    @property
    def names(self) -> list[str]:
        """Canonical names of the terms."""
        return [t.name for t in self.terms]

    def inadmissible(self, coefficients: Mapping[str, float]) -> str:
        """Why fitted coefficients are not the named effect ("" if they are)."""
        bad = [t.name for t in self.positive if not coefficients.get(t.name, 0.0) > 0]
        if not bad:
            return ""
        return (
            f"the coefficient of {', '.join(bad)} is not positive: not {self.candidate} "
            "(friction and damping oppose the motion; a Stribeck law weakens with speed)"
        )

    @property
    def extra_parameters(self) -> int:
        """Parameters the variant adds: one per term, plus the shape if chosen on a grid."""
        return len(self.terms) + (0 if self.shape is None else 1)


@dataclass(frozen=True)
class Candidate:
    """A named effect the loop can add to a model.

    Parameters
    ----------
    name
        What reports and ``--candidates`` call it (letters, digits, ``-_.+``).
    terms
        Terms of the term language; ``{c}`` marks the shape parameter.
    description
        One line for reports and ``nlid discover --list``.
    shape
        The grid of ``c`` when the terms contain ``{c}``.
    positive
        Terms (as written in ``terms``) whose coefficient the physics of the
        effect makes positive: friction and damping oppose the motion, and a
        Stribeck law *weakens* with speed (static above kinetic friction). A
        fit that gives such a term a negative coefficient is not the named
        effect (e.g. a negative ``sign(v)*exp(-(v/c)^2)`` next to Coulomb
        friction smooths the friction step, which is what an error in the
        estimated velocity near ``v = 0`` looks like) and is rejected.

    Raises
    ------
    InputError
        For a bad name, an unparsable term (named with the candidate) or a
        placeholder without a shape (or the reverse).
    """

    name: str
    terms: tuple[str, ...]
    description: str = ""
    shape: Shape | None = field(default=None)
    positive: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if isinstance(self.terms, str):
            object.__setattr__(self, "terms", tuple(t.strip() for t in self.terms.split(",") if t.strip()))
        else:
            object.__setattr__(self, "terms", tuple(str(t).strip() for t in self.terms))
        if not isinstance(self.name, str) or not _NAME.match(self.name):
            raise InputError(
                f"candidate name {self.name!r} must start with a letter and use letters, digits, '-', '_', '.', '+'"
            )
        if not self.terms:
            raise InputError(f"candidate {self.name!r} has no terms")
        has_placeholder = any(_PLACEHOLDER in t for t in self.terms)
        if has_placeholder and self.shape is None:
            raise InputError(f"candidate {self.name!r} uses {{c}} but declares no shape grid")
        if self.shape is not None and not has_placeholder:
            raise InputError(f"candidate {self.name!r} declares a shape grid but no term uses {{c}}")
        for term in self.terms:
            try:
                parse_term(term.replace(_PLACEHOLDER, "1"))
            except InputError as exc:
                raise InputError(f"candidate {self.name!r}: {exc}") from None
        object.__setattr__(self, "positive", tuple(str(t).strip() for t in self.positive))
        unknown = [t for t in self.positive if t not in self.terms]
        if unknown:
            raise InputError(f"candidate {self.name!r}: positive term {unknown[0]!r} is not one of its terms")

    @classmethod
    def from_spec(cls, spec: str) -> Candidate:
        """A user candidate from ``"NAME=TERMS"``, e.g. ``"drag=v*|v|, v^3"``."""
        if "=" not in spec:
            raise InputError(f"a user candidate is written NAME=TERMS (e.g. 'drag=v*|v|'), got {spec!r}")
        name, terms = spec.split("=", 1)
        return cls(name.strip(), terms, description=f"user candidate: {terms.strip()}")

    @property
    def uses_px(self) -> bool:
        """True if a term contains ``px(z)`` (its roots come from the current stiffness)."""
        return any(parse_term(t.replace(_PLACEHOLDER, "1")).uses_px for t in self.terms)

    def variant(self, model: Model, c: float | None = None) -> Variant | None:
        """The terms to add to ``model`` for shape value ``c`` (``None`` if all are already there)."""
        if (c is None) != (self.shape is None):
            raise InputError(f"candidate {self.name!r}: a shape value is needed exactly when it has a shape grid")
        if c is not None:
            c = float(format(float(c), ".3g"))

        def concrete(text: str) -> Term:
            return parse_term(text if c is None else text.replace(_PLACEHOLDER, format(c, ".6g")))

        terms = tuple(dict.fromkeys(concrete(t) for t in self.terms))
        new = tuple(t for t in terms if t not in model)
        if not new:
            return None
        positive = tuple(dict.fromkeys(concrete(t) for t in self.positive))
        return Variant(self.name, new, c, tuple(t for t in positive if t in new))

    def variants(self, model: Model, rms: Mapping[str, float]) -> list[Variant]:
        """The concrete term sets to try on top of ``model``: one per value of the shape grid.

        Terms already in the model are left out; an empty list means the
        candidate is already entirely in the model.

        Parameters
        ----------
        model
            The current model.
        rms
            RMS displacement ``"z"`` and velocity ``"v"`` of the estimation data
            (sets the shape grid).
        """
        values: Sequence[float | None] = self.shape.grid(rms) if self.shape else [None]
        out = [self.variant(model, c) for c in values]
        return [v for v in out if v is not None]

    def describe(self) -> dict[str, object]:
        """JSON-friendly description."""
        return {
            "name": self.name,
            "terms": list(self.terms),
            "description": self.description,
            "shape": None
            if self.shape is None
            else {"variable": self.shape.variable, "multipliers_of_rms": list(self.shape.multipliers)},
            "positive": list(self.positive),
        }


LIBRARY: tuple[Candidate, ...] = (
    Candidate("coulomb", ("sign(v)",), "Coulomb (dry) friction: sign(v), Eq. 24 with j = 0", positive=("sign(v)",)),
    Candidate("viscous", ("v",), "linear viscous damping: v", positive=("v",)),
    Candidate("quadratic-damping", ("v*|v|",), "quadratic damping: v*|v| (= sign(v)*v^2)"),
    Candidate("cubic-damping", ("v^3",), "cubic damping: v^3"),
    Candidate(
        "position-dependent-friction",
        ("sign(v)*|px(z)|",),
        "friction proportional to the normal-force polynomial: sign(v)*|px(z)|, Eq. 24 with j = 0; "
        "px roots from the current stiffness estimate",
        positive=("sign(v)*|px(z)|",),
    ),
    Candidate(
        "stribeck",
        ("sign(v)*exp(-(v/{c})^2)",),
        "velocity-weakening (Stribeck) friction sign(v)*exp(-(v/c)^2), c chosen on a grid of "
        + ", ".join(f"{m:g}" for m in STRIBECK_MULTIPLIERS)
        + " x RMS(v) and refined by the estimation residual",
        Shape("v", STRIBECK_MULTIPLIERS),
        positive=("sign(v)*exp(-(v/{c})^2)",),
    ),
    Candidate("offset", ("1",), "constant force (static load, sensor offset): 1"),
    Candidate("quadratic-stiffness", ("z^2",), "quadratic (asymmetric) stiffness: z^2"),
    Candidate("cubic-stiffness", ("z^3",), "cubic (Duffing) stiffness: z^3"),
    Candidate("quintic-stiffness", ("z^5",), "quintic stiffness: z^5"),
)


def library_names() -> list[str]:
    """Names of the built-in candidates, in library order."""
    return [c.name for c in LIBRARY]


def plugin_candidates(pm=None) -> tuple[list[Candidate], dict[str, str]]:
    """Candidates provided by installed plugins through ``nlid_candidates``.

    Each plugin is asked on its own, so one that raises or returns something
    else than :class:`Candidate` objects is reported in the failures (by
    plugin name) and does not hide the others.

    Returns
    -------
    candidates : list of Candidate
    failures : dict
        ``{plugin name: error}``.
    """
    from ..registry import plugin_manager

    failures: dict[str, str] = {}
    if pm is None:
        pm = plugin_manager(failures=failures)
    out: list[Candidate] = []
    for impl in reversed(pm.hook.nlid_candidates.get_hookimpls()):
        try:
            items = list(impl.function())
            bad = [x for x in items if not isinstance(x, Candidate)]
            if bad:
                raise TypeError(f"expected nlid.discovery.Candidate objects, got {type(bad[0]).__name__}")
        except PASS_THROUGH:
            raise
        except BaseException as exc:  # noqa: BLE001 - reported per plugin, sys.exit too
            failures[impl.plugin_name] = f"nlid_candidates() {describe_exception(exc)}"
            continue
        out.extend(items)
    return out, failures


def resolve_candidates(
    names: str | Iterable[str] | None = None,
    extra: Iterable[Candidate | str] = (),
    *,
    plugins: bool | Iterable[Candidate] = True,
) -> list[Candidate]:
    """The candidates a run tests.

    Parameters
    ----------
    names
        Library or plugin candidates to use (comma-separated string or
        iterable); ``None`` or ``"all"`` uses all of them.
    extra
        User candidates (:class:`Candidate` or ``"NAME=TERMS"``), always added.
    plugins
        Include candidates from installed plugins (``True``), none
        (``False``), or the given ones.

    Raises
    ------
    InputError
        For an unknown name (with a suggestion) or two candidates with the
        same name.
    """
    pool = list(LIBRARY)
    if plugins is True:
        try:
            found, _ = plugin_candidates()
        except NlidError:
            found = []
        pool += found
    elif plugins:
        pool += list(plugins)
    by_name: dict[str, Candidate] = {}
    for cand in pool:
        by_name.setdefault(cand.name, cand)
    if names is None or (isinstance(names, str) and names.strip().lower() in ("", "all")):
        chosen = list(by_name.values())
    else:
        items = [n.strip() for n in (names.split(",") if isinstance(names, str) else names) if n.strip()]
        chosen = []
        for n in items:
            if n not in by_name:
                hint = get_close_matches(n, list(by_name), n=1)
                raise InputError(
                    f"unknown candidate {n!r}"
                    + (f" (did you mean {hint[0]!r}?)" if hint else "")
                    + f"; known: {', '.join(by_name)} (add your own with NAME=TERMS)"
                )
            chosen.append(by_name[n])
    for item in extra:
        cand = item if isinstance(item, Candidate) else Candidate.from_spec(str(item))
        chosen.append(cand)
    seen: set[str] = set()
    for cand in chosen:
        if cand.name in seen:
            raise InputError(f"two candidates are called {cand.name!r}; give user candidates distinct names")
        seen.add(cand.name)
    return chosen
