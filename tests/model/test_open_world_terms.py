"""Non-smooth springs and memory terms in the term language, the force balance and the simulator (issue 13)."""

from __future__ import annotations

import numpy as np
import pytest

from nlid.errors import TermError
from nlid.model.terms import Model, parse_term, split_terms
from nlid.model.terms.memory import bouc_wen_path, dahl_path, rate
from nlid.simulation import free_run, random_force, simulate


@pytest.mark.parametrize(
    "text, name, family, unit, shapes",
    [
        ("gap(z,0.01)", "gap(z, 0.01)", "stiffness", "N/m", (0.01,)),
        ("stop(z, -0.002)", "stop(z, -0.002)", "stiffness", "N/m", (-0.002,)),
        ("sign(v)*gap(z, 0.01)", "sign(v)*gap(z, 0.01)", "damping", "N/m", (0.01,)),
        ("bouc_wen(800, -1100)", "bouc_wen(800, -1100)", "memory", "N/m", (800.0, -1100.0)),
        ("dahl(1e-4)", "dahl(0.0001)", "memory", "N", (1e-4,)),
    ],
)
def test_new_terms_parse_to_one_spelling(text, name, family, unit, shapes):
    term = parse_term(text)
    assert (term.name, term.family, term.coefficient_unit, term.shapes) == (name, family, unit, shapes)
    assert parse_term(term.name) == term


@pytest.mark.parametrize(
    "text, message",
    [
        ("bouc_wen(1, 2)*z", "stands alone"),
        ("z*dahl(0.1)", "stands alone"),
        ("bouc_wen(1, 2)^2", "cannot be raised"),
        ("gap(z, -1)", "clearance"),
        ("dahl(0)", "must be positive"),
        ("sign(gap(z, 1))", "not supported"),
    ],
)
def test_new_terms_refuse_what_they_cannot_mean(text, message):
    with pytest.raises(TermError, match=message):
        parse_term(text)


def test_commas_inside_parentheses_belong_to_the_term():
    split = [t for t, _ in split_terms("z^3, gap(z, 0.01), bouc_wen(1, 2)")]
    assert split == ["z^3", " gap(z, 0.01)", " bouc_wen(1, 2)"]
    assert Model.from_spec("stop(z, 0.01), dahl(0.001)").names[-1] == "dahl(0.001)"


def test_shapes_can_be_changed_and_are_validated():
    term = parse_term("sign(v)*exp(-(v/0.01)^2)")
    assert term.with_shapes([0.02]).name == "sign(v)*exp(-(v/0.02)^2)"
    with pytest.raises(ValueError, match="positive"):
        term.with_shapes([-1.0])
    model = Model.from_spec("gap(z, 0.01)").with_term_shapes("gap(z, 0.01)", [0.02])
    assert "gap(z, 0.02)" in model.names


def test_gap_and_stop_values():
    z = np.array([-0.03, -0.01, 0.0, 0.01, 0.03])
    np.testing.assert_allclose(parse_term("gap(z, 0.02)").evaluate(z), [-0.01, 0, 0, 0, 0.01])
    np.testing.assert_allclose(parse_term("stop(z, 0.02)").evaluate(z), [0, 0, 0, 0, 0.01])
    np.testing.assert_allclose(parse_term("stop(z, -0.02)").evaluate(z), [-0.01, 0, 0, 0, 0])


def test_memory_paths_integrate_their_rate_forms():
    t = np.linspace(0.0, 1.0, 4001)
    z = 1e-3 * np.sin(2 * np.pi * 3 * t) * (1 + t)
    for law, params, path in (("bouc_wen", (800.0, -1100.0), bouc_wen_path), ("dahl", (2e-4,), dahl_path)):
        exact = path(z, *params)
        fine = np.interp(np.linspace(0, 1, 400001), t, z)
        w = 0.0
        for dz in np.diff(fine):  # explicit Euler on a 100 times finer path of the rate form (v dt = dz)
            w += rate(law, params, w, dz)
        assert exact[-1] == pytest.approx(w, rel=2e-3, abs=1e-9)
    assert np.all(np.abs(dahl_path(z, 2e-4)) <= 1.0)


def test_simulated_memory_and_gap_records_satisfy_the_force_balance():
    """The simulator's states and the path integration of the force balance describe the same model."""
    fs = 750.0
    f = random_force(20000, fs, 50.0, np.random.default_rng(1), band=(5, 150))
    for terms, coeffs in (
        ("bouc_wen(800, -1100)", {"z": 5e4, "v": 10.0, "bouc_wen(800, -1100)": 5e4}),
        ("gap(z, 0.0005)", {"z": 5e4, "v": 10.0, "gap(z, 0.0005)": 1e5}),
        ("dahl(0.0002)", {"z": 5e4, "v": 10.0, "dahl(0.0002)": 20.0}),
    ):
        model = Model.from_spec(terms, without="1")
        z, v, a = free_run(model, coeffs, 2.0, f, fs, force_hold="zoh", oversample=16)
        residual = f - 2.0 * a - model.evaluate(z, v) @ model.vector(coeffs)
        assert np.std(residual) < 2e-3 * np.std(f), terms


def test_a_stiff_pre_sliding_law_does_not_blow_up_the_integrator():
    model = Model.from_spec("dahl(1e-6)")
    f = random_force(5000, 1000.0, 20.0, np.random.default_rng(2))
    z, v, a = simulate(model, {"1": 0.0, "z": 2000.0, "v": 2.0, "dahl(1e-06)": 2.0}, 0.2, f, 1000.0)
    assert np.all(np.isfinite(z)) and np.std(z) > 0
