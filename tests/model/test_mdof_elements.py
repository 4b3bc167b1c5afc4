"""Terms on connections: spelling, orientation by parity, the element set, forces on both DOFs."""

from __future__ import annotations

import re

import numpy as np
import pytest

from nlid.errors import InputError, TermError
from nlid.model.elements import Element, ElementSet, parse_element
from nlid.model.structure import StructuralModel
from nlid.model.terms import parse_term

SPELLINGS = [
    "(z1-z2)^3",
    "(z2-z1)^3",
    "(z2-z1)^2",
    "sign(v2-v1)",
    "(v2-v1)*|v2-v1|",
    "|z1-z2|*(v2-v1)",
    "(z2-z1)*(v1-v2)",
    "tanh((v2-v1)/0.01)",
    "exp(-((v2-v1)/0.05)^2)*sign(v2-v1)",
    "gap(z2-z1, 0.001)",
    "stop(z2-z1, 0.002)",
    "stop(z2-z1, -0.002)",
    "z3^3",
    "sign(v3)*exp(-|v3|/0.01)",
]


@pytest.mark.parametrize("text", SPELLINGS)
def test_a_term_written_either_way_is_its_sign_times_the_canonical_element(text):
    element, sign = parse_element(text)
    assert (element.i < element.j) or element.j == 0
    again, same = parse_element(element.name)
    assert again == element and same == 1.0
    rng = np.random.default_rng(1)
    z = rng.uniform(-0.01, 0.01, (200, 3))
    v = rng.uniform(-0.2, 0.2, (200, 3))
    # the term as written, evaluated literally: the one-DOF term on the coordinates in the order written
    one_dof = text
    for letter, arr in (("z", z), ("v", v)):
        for a, b in ((2, 1), (1, 2)):
            if f"{letter}{a}-{letter}{b}" in text:
                coordinate = arr[:, a - 1] - arr[:, b - 1]
                one_dof = re.sub(rf"(?<![a-z])\({letter}{a}-{letter}{b}\)", letter, one_dof)
                one_dof = one_dof.replace(f"{letter}{a}-{letter}{b}", letter)
        if f"{letter}3" in text:
            coordinate = arr[:, 2]
            one_dof = one_dof.replace(f"{letter}3", letter)
        if letter == "z":
            x = coordinate if letter in one_dof else None
        else:
            xd = coordinate if letter in one_dof else None
    expected = parse_term(one_dof).evaluate(x if x is not None else np.zeros(200), xd)
    got = sign * element.evaluate(element.relative(z), element.relative(v))
    assert np.allclose(got, expected, rtol=1e-12, atol=1e-300)


def test_memory_terms_and_px_on_a_connection():
    bw, sign = parse_element("bouc_wen(z2-z1, 50, 10)")
    assert bw.name == "bouc_wen(z1-z2, 50, 10)" and sign == -1.0 and bw.family == "memory"
    dahl, sign = parse_element("dahl(z2, 1e-4)")
    assert dahl.name == "dahl(z2, 0.0001)" and sign == 1.0 and dahl.connection == (2, 0)
    px, sign = parse_element("sign(v1-v2)*|px(z2-z1)|")
    assert px.name == "sign(v1-v2)*|px(z1-z2)|" and sign == 1.0  # px belongs to the connection, not to an order


@pytest.mark.parametrize(
    ("text", "why"),
    [
        ("z^3", "name the degree of freedom"),
        ("(z1-z2)*v3", "mixes z1-z2 and z3"),
        ("(z1-z2)*(z2-z1)", "same order"),
        ("z0^3", "numbered from 1"),
        ("z1-z1", "is zero"),
        ("bouc_wen(1, 2)", "takes its displacement first"),
        ("bouc_wen(v1-v2, 1, 2)", "not its velocity"),
        ("1", "names no connection"),
        ("px(z)", "name the degree of freedom"),
        ("(z1-v2)^3", "difference of two displacements"),
        ("(z1-z2)^3 + z3", "is not allowed inside a term"),
        ("stop(z2-z1, 0)", "no spelling in the canonical order"),
    ],
)
def test_malformed_terms_are_refused_in_one_line(text, why):
    with pytest.raises(TermError, match=why) as info:
        parse_element(text)
    assert "\n" not in str(info.value)


def test_an_error_points_into_the_text_as_written():
    with pytest.raises(TermError) as info:
        parse_element("(z1-z2)^3*foo(v1-v2)")
    assert info.value.text == "(z1-z2)^3*foo(v1-v2)" and info.value.position == 10


def test_the_element_set_orders_dedupes_and_converts_signs():
    spec = ElementSet.from_spec("z3^3, sign(v2-v1), (z1-z2)^3")
    assert spec.names == ("(z1-z2)^3", "sign(v1-v2)", "z3^3") and spec.n_dofs == 3
    assert spec.connections == ((1, 2), (3, 0))
    assert np.array_equal(spec.B, [[1, 1, 0], [-1, -1, 0], [0, 0, 1]])
    theta = spec.vector({"sign(v2-v1)": 3.0, "(z2-z1)^3": 2.0, "z3^3": 1.0})
    assert np.array_equal(theta, [-2.0, -3.0, 1.0])
    with pytest.raises(TermError, match="same element"):
        ElementSet.from_spec("(z1-z2)^3, (z2-z1)^3")
    with pytest.raises(InputError, match="acts on DOF 3"):
        ElementSet.from_spec("z3^3", 2)
    with pytest.raises(InputError, match="not an element of the model"):
        spec.index("z2^3")
    assert ElementSet.from_dict(spec.to_dict()) == spec


def test_an_elements_force_enters_both_dofs_with_opposite_signs():
    model = StructuralModel(np.eye(3), np.zeros((3, 3)), np.zeros((3, 3)), "(z1-z3)^3", {"(z3-z1)^3": 2.0})
    z = np.array([[0.1, 0.0, -0.2]])
    assert model.coefficients == {"(z1-z3)^3": -2.0}  # written on z3 - z1: the canonical coefficient is -2
    force = -2.0 * (0.1 - (-0.2)) ** 3  # theta g(z1 - z3): + on DOF 1, - on DOF 3
    assert np.allclose(model.restoring(z, np.zeros((1, 3))), [[force, 0.0, -force]])


def test_the_canonical_orientation_is_required_of_the_constructor():
    with pytest.raises(InputError, match="canonical order"):
        Element(parse_term("z^3"), 2, 1)
    with pytest.raises(InputError, match="static loads"):
        Element(parse_term("1"), 1, 0)
