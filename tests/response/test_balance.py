"""The harmonic-balance residual: its Jacobian is exact (AFT of the terms' own derivatives) for every kind of term."""

from __future__ import annotations

import numpy as np
import pytest

from nlid.model.terms import Model
from nlid.response.balance import Balance
from nlid.response.harmonics import Harmonics, crossings
from nlid.response.system import HarmonicSystem

SPECS = [
    "z^3, z^2",
    "v*|v|",
    "sign(v)",
    "sign(v)*|px(z)|, v^3*|px(z)|",
    "gap(z, 0.001)",
    "stop(z, -0.0005)",
    "tanh(v/0.01)",
    "z^2*v",
    "bouc_wen(20, 200)",
    "dahl(0.0005)",
]


@pytest.mark.parametrize("spec", SPECS)
def test_the_jacobian_is_the_derivative_of_the_residual(spec):
    """Central differences of the residual agree with the analytic Jacobian, jumps (Coulomb) and memory included."""
    model = Model.from_spec(spec, px_roots=(-0.02, 0.015) if "px" in spec else None)
    rng = np.random.default_rng(1)
    theta = np.array([1e6 if t.name == "z^3" else (1e3 if t.family != "damping" else 1.0) for t in model.terms])
    system = HarmonicSystem.from_model(model, theta * rng.uniform(0.5, 2.0, theta.size), 1.0)
    balance = Balance(system, 3, np.ones(1))
    X = np.zeros(balance.size)
    X[:3] = (1e-4, 2e-3, 5e-4)
    X[3:] = 1e-4 * rng.standard_normal(balance.size - 3)
    omega = 60.0
    _, J, dw, _, _ = balance.evaluate(X, omega, 1.0)
    h = 1e-9
    fd = np.column_stack(
        [
            (balance.evaluate(X + h * e, omega, 1.0)[0] - balance.evaluate(X - h * e, omega, 1.0)[0]) / (2 * h)
            for e in np.eye(X.size)
        ]
    )
    dfd = (balance.evaluate(X, omega + 1e-6, 1.0)[0] - balance.evaluate(X, omega - 1e-6, 1.0)[0]) / 2e-6
    assert np.max(np.abs(J - fd)) <= 1e-5 * np.max(np.abs(fd))
    assert np.max(np.abs(dw - dfd)) <= 1e-5 * np.max(np.abs(dfd))


def test_crossings_are_found_and_refined():
    basis = Harmonics(3)
    c = np.array([0.1, 1.0, 0.0, 0.3, 0.2, 0.0, 0.0])
    tau, slope, which = crossings(basis, c, np.array([0.0, 0.5]), 64)
    x = basis.values(tau) @ c
    assert np.allclose(x, np.array([0.0, 0.5])[which], atol=1e-12)
    assert np.allclose(slope, basis.slopes(tau) @ c)
    fine = basis.fine(c, 4096)
    for k, level in enumerate((0.0, 0.5)):
        changes = np.sum(np.sign(fine - level) != np.sign(np.roll(fine, -1) - level))
        assert np.sum(which == k) == changes
