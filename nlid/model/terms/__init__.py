"""The term language shared by every identifier.

Users write a model as a comma-separated list of terms in ``z`` (displacement,
m) and ``v`` (velocity, m/s), for example ``"z^3, z^2, v*|v|"``. Each term is
parsed by a small grammar (:mod:`nlid.model.terms.grammar`, never ``eval``),
normalised to one canonical spelling (:mod:`nlid.model.terms.term`) and evaluated on
a record (:class:`Model`). Every coefficient nlid reports is the coefficient of
its term in the restoring force ``R(z, v) = f - m z''``.
"""

from .grammar import parse_term, split_terms
from .model import DEFAULT_TERMS, Model, px_coefficients
from .term import Term

__all__ = ["Term", "Model", "parse_term", "split_terms", "px_coefficients", "DEFAULT_TERMS", "LANGUAGE", "EXAMPLES"]

#: (spelling, meaning) pairs shown by ``nlid terms``.
EXAMPLES: tuple[tuple[str, str], ...] = (
    ("1", "constant (static load, e.g. gravity m*g); default term"),
    ("z", "linear stiffness; default term"),
    ("z^2, z^3, z^5", "polynomial stiffness (Eq. 4-6)"),
    ("z*|z|", "quadratic stiffness, odd"),
    ("v", "linear viscous damping; default term"),
    ("v*|v|", "quadratic damping  (= sign(v)*|v|^2, Eq. 21 read as mu*v*|v|)"),
    ("v^3", "cubic damping  (= sign(v)*|v|^3)"),
    ("sign(v)", "Coulomb friction  (= sign(v)*|v|^0)"),
    ("sign(v)*|px(z)|", "position-dependent Coulomb friction (Eq. 24, j=0)"),
    ("v*|px(z)|, v*|v|*|px(z)|, v^3*|px(z)|", "Eq. 24, j=1..3 (sign(v)*|v|^j*|px(z)|)"),
    ("sign(v)*exp(-(v/0.01)^2)", "Stribeck (Gaussian velocity-weakening) friction with scale 0.01 m/s"),
    ("sign(v)*exp(-|v|/0.01)", "Stribeck (exponential) friction"),
    ("tanh(v/0.001)", "smoothed Coulomb friction"),
    ("z^2*v", "van der Pol-type damping; products of any factors are allowed"),
)

LANGUAGE = """\
Terms are products (*) of factors, each optionally raised to an integer power (^, or ** as in Python):
  1                 the constant
  z, v              displacement (m), velocity (m/s)
  |x|, abs(x)       absolute value of a product x
  sign(x)           sign of a product x   (sgn accepted)
  px(z)             normal-force polynomial of Eq. 10-11 (needs the roots z-, z+,
                    given or taken from the identified stiffness)
  exp(-|v|/c), exp(-(v/c)^2), tanh(v/c)   with a positive scale c
Separate terms with commas. Numbers are not factors (nlid estimates the
coefficients); '+' and '-' are not allowed inside a term.
Every spelling is normalised to one canonical form, e.g. sign(v)*|v|^2 -> v*|v|,
|v|*v -> v*|v|, sign(v)*|v| -> v, z*z*z -> z^3. The terms 1, z and v are
included in every model unless removed.
"""
