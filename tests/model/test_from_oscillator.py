"""The one-DOF oscillator as the n = 1 structure (issue 32, the bridge of ``StructuralModel.from_oscillator``).

The structure built from a one-DOF model must move as the one-DOF model does: the same response from the
structure integrator as from the one-DOF kernel, on the paper's two presets (one of them chaotic, whose
px(z) friction roots travel as the element set's roots).
"""

from __future__ import annotations

import numpy as np
import pytest

from nlid.model.structure import StructuralModel
from nlid.simulation import simulate
from nlid.simulation.presets import get_preset
from nlid.simulation.structure import simulate as simulate_structure


def _both(name: str, seconds: float | None = None):
    preset = get_preset(name)
    model, force = preset.model(), preset.force(0)
    if seconds is not None:
        force = force[: int(seconds * preset.fs)]
    one = simulate(model, dict(preset.coefficients), preset.mass, force, preset.fs, preset.x0)
    structure = StructuralModel.from_oscillator(model, dict(preset.coefficients), preset.mass)
    x0 = [[preset.x0[0]], [preset.x0[1]]]
    many = simulate_structure(structure, force, preset.fs, x0=x0)
    return one, [channel[:, 0] for channel in many], structure


def test_numerical_preset_moves_as_one_dof():
    one, many, structure = _both("paper-numerical")
    assert structure.elements.n_dofs == 1
    for exact, bridged in zip(one, many, strict=True):
        # the same arithmetic in another kernel: equal to rounding, over the whole 122 880-sample record
        assert np.max(np.abs(bridged - exact)) <= 1e-12 * np.std(exact)


def test_chaotic_preset_moves_as_one_dof_while_rounding_cannot_grow():
    # paper-experimental is chaotic: a last-bit difference grows, so the comparison stops after 2 s
    one, many, structure = _both("paper-experimental", seconds=2.0)
    assert structure.elements.px_roots  # px(z)'s roots travel with the elements
    for exact, bridged in zip(one, many, strict=True):
        assert np.max(np.abs(bridged - exact)) <= 1e-9 * np.std(exact)


def test_linear_terms_become_the_matrices():
    preset = get_preset("paper-numerical")
    structure = StructuralModel.from_oscillator(preset.model(), dict(preset.coefficients), preset.mass)
    coefficients = dict(preset.coefficients)
    assert structure.M[0, 0] == pytest.approx(preset.mass, rel=0, abs=0)
    assert structure.K[0, 0] == pytest.approx(coefficients.get("z", 0.0), rel=0, abs=0)
    assert structure.C[0, 0] == pytest.approx(coefficients.get("v", 0.0), rel=0, abs=0)
