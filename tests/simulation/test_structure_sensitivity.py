"""The forward sensitivities of a structure's free run (oe's Jacobian) against the free run and finite differences."""

from __future__ import annotations

import numpy as np
import pytest

from nlid.model.structure import StructuralModel
from nlid.simulation.presets import get_preset
from nlid.simulation.structure import free_run_segments
from nlid.simulation.structure_sensitivity import structure_segments, structure_sensitivity_columns

ELEMENTS = "(z2-z3)^3, tanh((v1-v2)/0.01), dahl(z3, 1e-4), (v1-v3)*|v1-v3|"
COEFFICIENTS = {"(z2-z3)^3": 5e9, "tanh((v1-v2)/0.01)": 2.0, "dahl(z3, 1e-4)": 1.0, "(v1-v3)*|v1-v3|": 3.0}


@pytest.fixture(scope="module")
def case():
    preset = get_preset("3dof-cubic").with_overrides(duration=0.6, M=((1.0, 0.1, 0.0), (0.1, 1.0, 0.0), (0, 0, 2.0)))
    record = preset.simulate(0)
    base = preset.model()
    model = StructuralModel(base.M, base.C, base.K, ELEMENTS, COEFFICIENTS, [0.1, 0.2, -0.3])
    starts = np.array([0, 200, 400])
    states = np.column_stack([record.z, record.v])[starts] * 1.01
    run = structure_segments(model, record.f, record.fs, starts, states, force_hold="zoh", oversample=2)
    return model, record, starts, states, run


def _perturbed(model, states, name, h):
    K, C, s, theta, x0 = model.K.copy(), model.C.copy(), model.static.copy(), model.theta.copy(), states.copy()
    n = model.n_dofs
    if name in model.elements.names:
        theta[model.elements.names.index(name)] += h
    elif name[0] in "KC":
        i, j = (int(x) - 1 for x in name[2:-1].split(","))
        A = K if name[0] == "K" else C
        A[i, j] += h
        if i != j:
            A[j, i] += h
    elif name.startswith("s["):
        s[int(name[2]) - 1] += h
    else:
        x0[:, (0 if name[0] == "z" else n) + int(name[3]) - 1] += h
    return StructuralModel(model.M, C, K, model.elements, theta, s), x0


def test_the_run_is_the_free_run(case):
    model, record, starts, states, run = case
    z, ends = free_run_segments(model, record.f, record.fs, starts, states, force_hold="zoh", oversample=2)
    np.testing.assert_allclose(run.z, z, rtol=0, atol=1e-12 * np.abs(z).max())
    np.testing.assert_allclose(run.end_state[:-1], ends[:-1], rtol=1e-10, atol=1e-12)
    assert run.columns == structure_sensitivity_columns(model)
    assert run.sensitivities.shape == (record.n, 3, len(run.columns))


def test_sensitivities_match_central_differences(case):
    model, record, starts, states, run = case
    scale = {"K": 1e5, "C": 20.0, "s": 1.0, "z": 1e-3, "v": 0.1}
    for c, name in enumerate(run.columns):
        if name in model.elements.names:
            h = 1e-6 * abs(model.coefficient(name))
        else:
            h = 1e-6 * scale[name[0]]
        runs = []
        for sign in (1.0, -1.0):
            m, x0 = _perturbed(model, states, name, sign * h)
            runs.append(free_run_segments(m, record.f, record.fs, starts, x0, force_hold="zoh", oversample=2))
        fd = (runs[0][0] - runs[1][0]) / (2 * h)
        fd_end = (runs[0][1] - runs[1][1]) / (2 * h)
        big = np.abs(fd).max()
        assert big > 0, name
        np.testing.assert_allclose(run.sensitivities[:, :, c], fd, rtol=0, atol=1e-4 * big, err_msg=name)
        np.testing.assert_allclose(
            run.end_sensitivities[:-1, :, c], fd_end[:-1], rtol=0, atol=1e-4 * np.abs(fd_end[:-1]).max(), err_msg=name
        )
