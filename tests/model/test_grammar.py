"""The term grammar: canonical spellings, normalisation, rejection, no eval."""

import builtins
import re

import numpy as np
import pytest

from nlid import TermError
from nlid.model.terms import Model, parse_term

CANONICAL = [
    "1",
    "z",
    "z^2",
    "z^3",
    "z^5",
    "v",
    "v*|v|",
    "v^3",
    "sign(v)",
    "|v|",
    "|v|^3",
    "z*|z|",
    "sign(v)*|px(z)|",
    "v*|px(z)|",
    "v*|v|*|px(z)|",
    "v^3*|px(z)|",
    "px(z)",
    "px(z)^2",
    "sign(v)*exp(-(v/0.01)^2)",
    "sign(v)*exp(-|v|/0.01)",
    "tanh(v/0.001)",
    "z^2*v",
    "sign(z)*sign(v)",
    "v*|v|^3",
]


@pytest.mark.parametrize("name", CANONICAL)
def test_canonical_spellings_round_trip(name):
    assert parse_term(name).name == name


@pytest.mark.parametrize(
    "spelling, canonical",
    [
        ("sign(v)*|v|^0", "sign(v)"),
        ("sign(v)*|v|^1", "v"),
        ("sign(v)*|v|^2", "v*|v|"),
        ("sign(v)*|v|^3", "v^3"),
        ("sign(v)*|v|^2*|px(z)|", "v*|v|*|px(z)|"),
        ("|px(z)|*sign(v)", "sign(v)*|px(z)|"),
        ("|v|*v", "v*|v|"),
        ("z*z*z", "z^3"),
        ("z ** 2", "z^2"),
        ("abs(v)^3", "|v|^3"),
        ("sgn(v)", "sign(v)"),
        ("(z*v)^2", "z^2*v^2"),
        ("sign(z*v)", "sign(z)*sign(v)"),
        ("tanh(v/1e-3)", "tanh(v/0.001)"),
        ("  v  *  | v |  ", "v*|v|"),
        ("z^0", "1"),
    ],
)
def test_spellings_normalise(spelling, canonical):
    assert parse_term(spelling).name == canonical


@pytest.mark.parametrize(
    "text, position, message",
    [
        ("z^^2", 3, "exponent"),
        ("x^2", 1, "unknown name 'x'"),
        ("2*z", 1, "cannot be a factor"),
        ("z+v", 2, "separate terms with commas"),
        ("v*|v", 5, "closing '|'"),
        ("sign(v", 7, "closing ')'"),
        ("exp(v)", 5, "'-'"),
        ("z^-1", 3, "exponent"),
        ("z v", 3, "'*' between factors"),
        ("tanh(v/0)", 8, "positive"),
        ("foo(z)", 1, "unknown name 'foo'"),
        ("z^99", 3, "maximum"),
        ("z$", 2, "unexpected character"),
        ("", 1, "empty term"),
        ("px(v)", 4, "px(z)"),
    ],
)
def test_malformed_terms_point_at_the_character(text, position, message):
    with pytest.raises(TermError, match=re.escape(message)) as info:
        parse_term(text)
    assert info.value.position == position - 1
    if text:
        assert f"at character {position} of" in str(info.value)


def test_error_position_is_relative_to_the_whole_list():
    with pytest.raises(TermError) as info:
        Model.from_spec("z^3, z^2, v*|v")
    assert info.value.position == len("z^3, z^2, v*|v")


def test_parser_never_evaluates(monkeypatch):
    def forbidden(*args, **kwargs):
        raise AssertionError("eval/exec must not be used")

    monkeypatch.setattr(builtins, "eval", forbidden)
    monkeypatch.setattr(builtins, "exec", forbidden)
    for text in CANONICAL + ["__import__('os').system('true')"]:
        try:
            parse_term(text)
        except TermError:
            pass


def test_term_metadata():
    t = parse_term("v*|v|")
    assert (t.family, t.unit, t.coefficient_unit) == ("damping", "m^2/s^2", "N*s^2/m^2")
    assert parse_term("z^3").coefficient_unit == "N/m^3"
    assert parse_term("1").family == "stiffness" and parse_term("1").is_constant
    assert parse_term("sign(v)*|px(z)|").uses_px
    assert parse_term("z^3").polynomial_power == 3 and parse_term("z*|z|").polynomial_power is None


def test_evaluation_matches_definitions():
    rng = np.random.default_rng(1)
    z, v = rng.normal(size=50), rng.normal(size=50)
    cases = {
        "v*|v|": v * np.abs(v),
        "sign(v)": np.sign(v),
        "z^3": z**3,
        "|v|^3": np.abs(v) ** 3,
        "z^2*v": z**2 * v,
        "sign(v)*exp(-(v/0.5)^2)": np.sign(v) * np.exp(-((v / 0.5) ** 2)),
        "tanh(v/0.1)": np.tanh(v / 0.1),
    }
    for name, expected in cases.items():
        np.testing.assert_allclose(parse_term(name).evaluate(z, v), expected, rtol=1e-14)
