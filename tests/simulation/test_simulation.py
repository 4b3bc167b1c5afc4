"""nlid.simulation's compiled kernel against the term language (issue 14: the specialised kernel)."""

from __future__ import annotations

import numpy as np
import pytest

from nlid.model.terms import Model
from nlid.simulation import simulate

SPECS = [
    ("1, z, v, z^2, z^3, v*|v|", None),
    ("z, v, z^5, z^4, z*|z|, |z|^3, sign(z), |v|, v^3, v^5*|v|, z^7*v^6, |z|^9*sign(v)", None),
    ("z, v, sign(v)*exp(-|v|/0.05), v*exp(-(v/0.1)^2), tanh(v/0.01), tanh(z/0.01)^2*v, z^2*v", None),
    ("z, v, z^3, sign(v)*|px(z)|, v*|px(z)|, px(z)^2*v, sign(px(z))*v, |px(z)|^3*z^2*v*|v|", (-0.027, 0.017)),
]


def _model(spec, roots):
    model = Model.from_spec(spec, defaults=False)
    return model.with_px_roots(roots) if roots is not None else model


@pytest.mark.parametrize("spec, roots", SPECS)
def test_kernel_restoring_force_equals_the_term_language(spec, roots):
    # with f = 0 and m = 1 the first acceleration is exactly -R(z0, v0)
    model = _model(spec, roots)
    rng = np.random.default_rng(0)
    theta = rng.uniform(0.5, 2.0, len(model)) * np.where(rng.random(len(model)) < 0.5, -1.0, 1.0)
    states = np.column_stack([0.03 * rng.standard_normal(200), 0.5 * rng.standard_normal(200)])
    states[:4] = [[0.0, 0.0], [0.0, 0.3], [-0.02, 0.0], [0.017, -0.1]]  # zeros of z, v and px
    for z0, v0 in states:
        _, _, a = simulate(model, theta, 1.0, np.zeros(1), 1000.0, (z0, v0))
        zz, vv = np.array([z0]), np.array([v0])
        ref = float(model.evaluate(zz, vv)[0] @ theta)
        assert -a[0] == pytest.approx(ref, rel=1e-13, abs=1e-13 * np.abs(theta).sum())


def test_trajectory_matches_a_plain_rk4_of_the_term_language():
    model = _model(*SPECS[1])
    coefs = {n: 0.0 for n in model.names}
    coefs.update({"z": 2000.0, "v": 1.5, "z^5": 1e7, "v^3": 0.2, "sign(z)": 0.1, "|v|": 0.05})
    theta = model.vector(coefs)
    force = np.random.default_rng(1).standard_normal(400) * 5
    z, v, a = simulate(model, coefs, 0.2, force, 2048.0, (0.01, -0.1))

    def accel(zz, vv, f):
        return (f - float(model.evaluate(np.array([zz]), np.array([vv]))[0] @ theta)) / 0.2

    dt, zr, vr = 1 / 2048, 0.01, -0.1
    for k, f in enumerate(force):
        assert z[k] == pytest.approx(zr, rel=1e-12, abs=1e-15) and v[k] == pytest.approx(vr, rel=1e-12, abs=1e-14)
        a1 = accel(zr, vr, f)
        a2 = accel(zr + dt / 2 * vr, vr + dt / 2 * a1, f)
        a3 = accel(zr + dt / 2 * (vr + dt / 2 * a1), vr + dt / 2 * a2, f)
        a4 = accel(zr + dt * (vr + dt / 2 * a2), vr + dt * a3, f)
        v2, v3, v4 = vr + dt / 2 * a1, vr + dt / 2 * a2, vr + dt * a3
        zr, vr = zr + dt / 6 * (vr + 2 * v2 + 2 * v3 + v4), vr + dt / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
