"""Candidate effects: what the loop may add to a model.

A :class:`Candidate` is a named set of terms of the restoring force
``R(z, v) = f - m z''`` (the term language of :mod:`nlid.model.terms`), optionally
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
``gap``                        ``gap(z, c)``                   a spring that engages beyond a clearance
                                                               ``c`` on both sides (a stop with play)
``stop-positive``              ``stop(z, c)``                  a one-sided stop engaging beyond ``z = c``
``stop-negative``              ``stop(z, -c)``                 ... beyond ``z = -c``
``hysteresis-bouc-wen``        ``bouc_wen(a, b)``              Bouc-Wen hysteresis (memory), ``a``, ``b``
                                                               on a grid in units of 1/std(z)
``dahl-friction``              ``dahl(c)``                     Dahl pre-sliding friction (memory)
=============================  ==============================  ===========================================

Two more candidates are built by the loop itself (:mod:`nlid.discovery`):
``mass`` (when a mass was given: the same model with the mass estimated) and
``dictionary`` (terms chosen from an automatic dictionary of products of
``z``, ``|z|``, ``v``, ``|v|``, ``sign(v)`` and ``|px(z)|`` by sparse
regression on the residual, :func:`dictionary_terms`).

The clearances ``c`` of gaps and stops are searched over multiples of std(z)
(:data:`GAP_MULTIPLIERS`), Dahl's pre-sliding displacement likewise
(:data:`DAHL_MULTIPLIERS`), the Bouc-Wen parameters over
:data:`BOUC_WEN_A` and :data:`BOUC_WEN_B` divided by std(z).

The Stribeck scale ``c`` is searched over :data:`STRIBECK_MULTIPLIERS` times
the RMS velocity of the estimation data (0.02 to 0.5 RMS(v)): a law whose
scale exceeds the velocities of the data is indistinguishable from Coulomb
friction plus quadratic damping, which the library already holds.

Users add candidates as terms (:meth:`Candidate.from_spec`,
``nlid discover --candidate NAME=TERMS``) or through the plugin hook
``nlid_candidates`` (:mod:`nlid.contract.hookspecs`); :func:`resolve_candidates`
gathers them.
"""

from __future__ import annotations

import itertools
import math
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field

from ..base.validate import did_you_mean
from ..errors import PASS_THROUGH, InputError, NlidError, brief, describe_exception
from ..model.terms import Model, Term, parse_term, split_terms
from .paths import INPUT_PATH, InputPathCandidate

__all__ = [
    "Candidate",
    "Shape",
    "Variant",
    "LIBRARY",
    "STRIBECK_MULTIPLIERS",
    "GAP_MULTIPLIERS",
    "DAHL_MULTIPLIERS",
    "BOUC_WEN_A",
    "BOUC_WEN_B",
    "dictionary_terms",
    "dissipative",
    "library_names",
    "plugin_candidates",
    "resolve_candidates",
]

#: Why a fitted effect must have a positive coefficient (the reason a wrong sign rejects it; reports say it once).
SIGN_WHY = "friction and damping oppose the motion, stops and hysteresis push back, a Stribeck law weakens with speed"

#: Grid of the Stribeck scale, as multiples of the RMS velocity.
STRIBECK_MULTIPLIERS: tuple[float, ...] = (0.02, 0.05, 0.1, 0.2, 0.5)
#: Grid of gap and stop clearances, as multiples of std(z).
GAP_MULTIPLIERS: tuple[float, ...] = (0.25, 0.5, 1.0, 1.5, 2.0)
#: Grid of Dahl's pre-sliding displacement, as multiples of std(z).
DAHL_MULTIPLIERS: tuple[float, ...] = (0.003, 0.01, 0.03, 0.1, 0.3)
#: Grids of the Bouc-Wen parameters a and b, times 1/std(z).
BOUC_WEN_A: tuple[float, ...] = (0.2, 0.5, 1.0, 2.0)
BOUC_WEN_B: tuple[float, ...] = (-1.5, -0.7, -0.3, 0.0, 0.3, 0.7)
_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_.+-]*$")
_PLACEHOLDER = "{c}"
_PLACEHOLDERS = re.compile(r"\{([a-z])\}")


def dissipative(term: Term) -> bool:
    """True if ``term`` is a friction or damping law, ``g(z, v) v >= 0`` (:attr:`nlid.model.terms.Term.dissipative`)."""
    return term.dissipative


@dataclass(frozen=True)
class Shape:
    """A shape parameter of a candidate (``{c}`` in its terms, or ``{a}``, ``{b}``...), searched on a grid.

    Attributes
    ----------
    variable
        ``"v"`` or ``"z"``: the grid is ``multipliers * RMS(variable)`` of the
        estimation data (RMS of ``z`` about its mean: its standard deviation).
    multipliers
        The grid, relative to that RMS.
    placeholder
        The letter between braces in the terms (default ``c``).
    inverse
        The grid is ``multipliers / RMS(variable)`` (a rate per metre, as the
        Bouc-Wen parameters).
    """

    variable: str
    multipliers: tuple[float, ...]
    placeholder: str = "c"
    inverse: bool = False

    def __post_init__(self) -> None:
        if self.variable not in ("z", "v"):
            raise InputError(f"a shape parameter scales with z or v, not {self.variable!r}")
        if not self.multipliers or any(not math.isfinite(m) for m in self.multipliers):
            raise InputError("a shape grid needs finite multipliers")
        if not self.inverse and any(not (m > 0) for m in self.multipliers):
            raise InputError("a shape grid needs positive multipliers")
        if not re.fullmatch(r"[a-z]", self.placeholder):
            raise InputError(f"a shape placeholder is one lower-case letter, got {self.placeholder!r}")

    def grid(self, rms: Mapping[str, float]) -> list[float]:
        """The values of the parameter for data whose RMS displacement/velocity is ``rms``."""
        scale = float(rms[self.variable])
        values = [m / scale if self.inverse else m * scale for m in self.multipliers]
        # three significant digits keep the term names readable
        return [float(format(x, ".3g")) for x in values]


@dataclass(frozen=True)
class Variant:
    """One concrete version of a candidate: its terms (and shape values)."""

    candidate: str
    terms: tuple[Term, ...]
    shape: float | tuple[float, ...] | None = None
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
        return f"the coefficient of {', '.join(bad)} is not positive: not {self.candidate} ({SIGN_WHY})"

    @property
    def shape_count(self) -> int:
        """How many shape parameters were chosen on a grid."""
        if self.shape is None:
            return 0
        return len(self.shape) if isinstance(self.shape, tuple) else 1

    @property
    def extra_parameters(self) -> int:
        """Parameters the variant adds: one per term, plus each shape chosen on a grid."""
        return len(self.terms) + self.shape_count


@dataclass(frozen=True)
class Candidate:
    """A named effect the loop can add to a model.

    Parameters
    ----------
    name
        What reports and ``--candidates`` call it (letters, digits, ``-_.+``).
    terms
        Terms of the term language; ``{c}`` (or ``{a}``, ``{b}``...) marks a
        shape parameter.
    description
        One line for reports and ``nlid discover --list``.
    shape
        The grid of each placeholder: one :class:`Shape` (``{c}``) or a tuple
        (their grids are combined).
    positive
        Terms (as written in ``terms``) whose coefficient the physics of the
        effect makes positive: friction and damping oppose the motion, stops
        and hysteresis push back, and a Stribeck law *weakens* with speed
        (static above kinetic friction). A fit that gives such a term a
        negative coefficient is not the named effect (e.g. a negative
        ``sign(v)*exp(-(v/c)^2)`` next to Coulomb friction smooths the friction
        step, which is what an error in the estimated velocity near ``v = 0``
        looks like) and is rejected. Every friction or damping law among the
        terms (:func:`dissipative`) is added whether listed or not: with a
        negative coefficient it would feed energy in.
    requires
        Remaining-structure probes (:data:`nlid.discovery.probes.PROBES`) of
        which one must find structure in the current residual for the
        candidate to be tested: a flexible effect (a gap, a hysteresis) can
        always explain a little of a residual, so it is only offered where
        the residual shows structure of its kind. Empty: always tested.

    Raises
    ------
    InputError
        For a bad name, an unparsable term (named with the candidate) or a
        placeholder without a shape (or the reverse).
    """

    name: str
    terms: tuple[str, ...]
    description: str = ""
    shape: Shape | tuple[Shape, ...] | None = field(default=None)
    positive: tuple[str, ...] = ()
    requires: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if isinstance(self.terms, str):
            object.__setattr__(self, "terms", tuple(t.strip() for t, _ in split_terms(self.terms)))
        else:
            object.__setattr__(self, "terms", tuple(str(t).strip() for t in self.terms))
        if isinstance(self.shape, Shape):
            object.__setattr__(self, "shape", (self.shape,))
        if not isinstance(self.name, str) or not _NAME.match(self.name):
            raise InputError(
                f"candidate name {self.name!r} must start with a letter and use letters, digits, '-', '_', '.', '+'"
            )
        if not self.terms:
            raise InputError(f"candidate {self.name!r} has no terms")
        used = sorted({m for t in self.terms for m in _PLACEHOLDERS.findall(t)})
        declared = sorted(sh.placeholder for sh in self.shapes)
        if used and not declared:
            raise InputError(f"candidate {self.name!r} uses {{{used[0]}}} but declares no shape grid")
        if declared and not used:
            raise InputError(f"candidate {self.name!r} declares a shape grid but no term uses {{{declared[0]}}}")
        if used != declared:
            raise InputError(f"candidate {self.name!r}: placeholders {used} but shape grids for {declared}")
        for term in self.terms:
            try:
                parse_term(_PLACEHOLDERS.sub("1", term))
            except InputError as exc:
                raise InputError(f"candidate {self.name!r}: {exc}") from None
        object.__setattr__(self, "positive", tuple(str(t).strip() for t in self.positive))
        unknown = [t for t in self.positive if t not in self.terms]
        if unknown:
            raise InputError(f"candidate {self.name!r}: positive term {unknown[0]!r} is not one of its terms")
        # every friction or damping law carries its physical sign, declared or not (a user's, a plugin's)
        laws = [t for t in self.terms if dissipative(parse_term(_PLACEHOLDERS.sub("1", t)))]
        object.__setattr__(self, "positive", tuple(dict.fromkeys((*self.positive, *laws))))
        from .probes import PROBES

        object.__setattr__(self, "requires", tuple(self.requires))
        bad = [r for r in self.requires if r not in PROBES]
        if bad:
            raise InputError(f"candidate {self.name!r}: unknown probe {bad[0]!r}; probes: {', '.join(PROBES)}")

    @property
    def shapes(self) -> tuple[Shape, ...]:
        """The shape grids (empty for a candidate without shape parameters)."""
        return tuple(self.shape or ())

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
        return any(parse_term(_PLACEHOLDERS.sub("1", t)).uses_px for t in self.terms)

    def variant(self, model: Model, c: float | Sequence[float] | None = None) -> Variant | None:
        """The terms to add to ``model`` for shape value(s) ``c`` (``None`` if all are already there).

        Raises
        ------
        InputError
            Wrong number of shape values, or values the terms do not admit.
        """
        shapes = self.shapes
        values: tuple[float, ...] = () if c is None else ((float(c),) if not isinstance(c, Sequence) else tuple(c))
        if len(values) != len(shapes):
            raise InputError(f"candidate {self.name!r} needs {len(shapes)} shape value(s), got {len(values)}")
        values = tuple(float(format(float(x), ".3g")) for x in values)
        mapping = {sh.placeholder: x for sh, x in zip(shapes, values, strict=True)}

        def concrete(text: str) -> Term:
            return parse_term(_PLACEHOLDERS.sub(lambda m: format(mapping[m.group(1)], ".6g"), text))

        try:
            terms = tuple(dict.fromkeys(concrete(t) for t in self.terms))
            positive = tuple(dict.fromkeys(concrete(t) for t in self.positive))
        except InputError as exc:
            raise InputError(f"candidate {self.name!r} at {mapping}: {exc}") from None
        new = tuple(t for t in terms if t not in model)
        if not new:
            return None
        shape: float | tuple[float, ...] | None = None if not values else (values[0] if len(values) == 1 else values)
        return Variant(self.name, new, shape, tuple(t for t in positive if t in new))

    def variants(self, model: Model, rms: Mapping[str, float]) -> list[Variant]:
        """The concrete term sets to try on top of ``model``: one per point of the shape grid.

        Terms already in the model are left out; an empty list means the
        candidate is already entirely in the model. Grid points the terms do
        not admit (e.g. a scale that is not positive) are skipped.

        Parameters
        ----------
        model
            The current model.
        rms
            RMS displacement ``"z"`` (about its mean) and velocity ``"v"`` of
            the estimation data (sets the shape grid).
        """
        if not self.shapes:
            out = [self.variant(model)]
        else:
            out = []
            for point in itertools.product(*(sh.grid(rms) for sh in self.shapes)):
                try:
                    out.append(self.variant(model, point))
                except InputError:
                    continue
        return [v for v in out if v is not None]

    def describe(self) -> dict[str, object]:
        """JSON-friendly description."""
        return {
            "name": self.name,
            "terms": list(self.terms),
            "description": self.description,
            "shape": None
            if not self.shapes
            else [
                {
                    "placeholder": sh.placeholder,
                    "variable": sh.variable,
                    "multipliers": list(sh.multipliers),
                    "of": f"1/RMS({sh.variable})" if sh.inverse else f"RMS({sh.variable})",
                }
                for sh in self.shapes
            ],
            "positive": list(self.positive),
            "requires": list(self.requires),
        }


LIBRARY: tuple[Candidate, ...] = (
    Candidate("coulomb", ("sign(v)",), "Coulomb (dry) friction: sign(v), Eq. 24 with j = 0", positive=("sign(v)",)),
    Candidate("viscous", ("v",), "linear viscous damping: v", positive=("v",)),
    Candidate("quadratic-damping", ("v*|v|",), "quadratic damping: v*|v| (= sign(v)*v^2)", positive=("v*|v|",)),
    Candidate("cubic-damping", ("v^3",), "cubic damping: v^3", positive=("v^3",)),
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
    Candidate("linear-stiffness", ("z",), "linear stiffness: z (a spring left out of the declared model)"),
    Candidate("quadratic-stiffness", ("z^2",), "quadratic (asymmetric) stiffness: z^2"),
    Candidate("cubic-stiffness", ("z^3",), "cubic (Duffing) stiffness: z^3"),
    Candidate("quintic-stiffness", ("z^5",), "quintic stiffness: z^5"),
    Candidate(
        "gap",
        ("gap(z, {c})",),
        "a spring engaging beyond a clearance c on both sides: gap(z, c) = sign(z) max(|z| - c, 0), c on a grid of "
        + ", ".join(f"{m:g}" for m in GAP_MULTIPLIERS)
        + " x std(z)",
        Shape("z", GAP_MULTIPLIERS),
        positive=("gap(z, {c})",),
        requires=("z", "z,v"),
    ),
    Candidate(
        "stop-positive",
        ("stop(z, {c})",),
        "a one-sided stop engaging beyond z = c: stop(z, c) = max(z - c, 0)",
        Shape("z", GAP_MULTIPLIERS),
        positive=("stop(z, {c})",),
        requires=("z", "z,v"),
    ),
    Candidate(
        "stop-negative",
        ("stop(z, -{c})",),
        "a one-sided stop engaging below z = -c: stop(z, -c) = min(z + c, 0)",
        Shape("z", GAP_MULTIPLIERS),
        positive=("stop(z, -{c})",),
        requires=("z", "z,v"),
    ),
    Candidate(
        "hysteresis-bouc-wen",
        ("bouc_wen({a}, {b})",),
        "Bouc-Wen hysteresis (a state with memory, dw = dz - a |dz| w - b dz |w|), a and b on a grid in units of "
        "1/std(z)",
        (Shape("z", BOUC_WEN_A, "a", inverse=True), Shape("z", BOUC_WEN_B, "b", inverse=True)),
        positive=("bouc_wen({a}, {b})",),
        requires=("memory",),
    ),
    Candidate(
        "dahl-friction",
        ("dahl({c})",),
        "Dahl pre-sliding friction (memory: the friction force builds up over a displacement c before sliding)",
        Shape("z", DAHL_MULTIPLIERS),
        positive=("dahl({c})",),
        requires=("memory",),
    ),
)


#: Factors of the automatic dictionary: displacement parts, velocity parts, position-dependent parts.
DICTIONARY_Z: tuple[str, ...] = ("", "z", "z^2", "z^3", "z^4", "z^5", "|z|", "z*|z|", "|z|^3")
DICTIONARY_V: tuple[str, ...] = ("", "sign(v)", "v", "v*|v|", "v^3", "|v|", "v^2")
DICTIONARY_PX: tuple[str, ...] = ("", "|px(z)|")
#: Largest total power (of z and v) of a dictionary term.
DICTIONARY_MAX_DEGREE = 5


def dictionary_terms(model: Model, px: bool = False) -> list[Term]:
    """The automatic dictionary: products of the factors above, up to :data:`DICTIONARY_MAX_DEGREE`.

    Every product of one displacement part, one velocity part and (with
    ``px``) ``|px(z)|`` is generated from the term grammar, normalised, and
    kept once; terms already in ``model`` are left out. About 60 terms
    (120 with ``px``).
    """
    out: dict[Term, None] = {}
    for zp, vp, pp in itertools.product(DICTIONARY_Z, DICTIONARY_V, DICTIONARY_PX if px else ("",)):
        factors = [f for f in (zp, vp, pp) if f]
        if not factors:
            continue
        term = parse_term("*".join(factors))
        if term.z[0] + term.v[0] > DICTIONARY_MAX_DEGREE or term in model:
            continue
        out.setdefault(term, None)
    return list(out)


def library_names() -> list[str]:
    """Names of the built-in candidates, in library order (the input-path effects last)."""
    return [c.name for c in (*LIBRARY, *INPUT_PATH)]


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
    from ..contract.registry import plugin_manager

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
) -> list[Candidate | InputPathCandidate]:
    """The candidates a run tests (the term candidates and the input-path effects).

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
    pool: list[Candidate | InputPathCandidate] = [*LIBRARY, *INPUT_PATH]
    if plugins is True:
        try:
            found, _ = plugin_candidates()
        except NlidError:
            found = []
        pool += found
    elif plugins:
        pool += list(plugins)
    by_name: dict[str, Candidate | InputPathCandidate] = {}
    for cand in pool:
        by_name.setdefault(cand.name, cand)
    if names is None or (isinstance(names, str) and names.strip().lower() in ("", "all")):
        chosen = list(by_name.values())
    else:
        items = [n.strip() for n in (names.split(",") if isinstance(names, str) else names) if n.strip()]
        chosen = []
        for n in items:
            if n not in by_name:
                raise InputError(
                    f"unknown candidate {brief(n)}{did_you_mean(n, by_name)}; known: {', '.join(by_name)} "
                    "(add your own with NAME=TERMS)"
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
