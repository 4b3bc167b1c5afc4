"""from_dict with an edited coefficient recomputes what the coefficients give, one DOF and structures (issue 35)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import nlid
from nlid.identified.schema import STALE_NOTE
from nlid.identified.structure import STALE_NOTE as STRUCTURE_STALE
from nlid.identified.structure import IdentifiedStructure
from nlid.model import physics
from nlid.model.modes import linear_modes


@pytest.fixture(scope="module")
def fit(short_record):
    return nlid.identify(short_record, "z^3, z^2, v*|v|", "rfs", mass=0.2)


def test_an_unedited_model_comes_back_as_it_was(fit):
    back = nlid.IdentifiedModel.from_dict(json.loads(json.dumps(fit.to_dict())))
    assert back.modal == fit.modal and back.equilibria == fit.equilibria
    assert back.eps_percent == fit.eps_percent and STALE_NOTE not in back.warnings


@pytest.mark.parametrize("term, factor", [("v", 2.0), ("z", 1.5)])
def test_an_edited_coefficient_recomputes_the_modal_table(fit, term, factor):
    data = json.loads(json.dumps(fit.to_dict()))
    data["coefficients"][term] *= factor
    back = nlid.IdentifiedModel.from_dict(data)
    theta = back.model.vector(dict(back.coefficients))
    eq = physics.equilibria(back.model, theta, back.z_range)
    expected = physics.modal(back.model, theta, back.mass, eq.stable, back.z_range)
    assert [m.zeta for m in back.modal] == pytest.approx([m.zeta for m in expected], rel=1e-9)
    assert [m.fn_hz for m in back.modal] == pytest.approx([m.fn_hz for m in expected], rel=1e-9)
    old = {round(m.equilibrium, 9): m for m in fit.modal}
    changed = [m for m in back.modal if round(m.equilibrium, 9) in old]
    if term == "v":  # doubling the viscous term raises every damping ratio, the frequencies stay
        assert all(m.zeta > old[round(m.equilibrium, 9)].zeta for m in changed)
    assert not np.allclose([m.fn_hz for m in back.modal], [m.fn_hz for m in fit.modal]) or term == "v"
    assert back.scores is None and STALE_NOTE in back.warnings  # the fit's scores were of other coefficients


# ------------------------------------------------------------------ structures: the same rule
@pytest.fixture(scope="module")
def structure_fit():
    from nlid.simulation.presets import get_preset

    preset = get_preset("2dof-double-well")
    record = preset.with_overrides(duration=8.0).simulate(1, noise={"z": 0.005}, channels=["z", "v", "a"])
    return nlid.identify(record, preset.elements, "rfs", mass=record.meta["mass"])


def test_an_unedited_structure_comes_back_as_it_was(structure_fit):
    back = IdentifiedStructure.from_dict(json.loads(json.dumps(structure_fit.to_dict())))
    assert back.equilibria == structure_fit.equilibria
    assert [m.fn_hz.tolist() for m in back.modes] == [m.fn_hz.tolist() for m in structure_fit.modes]
    assert back.eps_percent == structure_fit.eps_percent and STRUCTURE_STALE not in back.warnings


@pytest.mark.parametrize("edit", ["element", "damping matrix"])
def test_an_edited_structure_recomputes_its_modes(structure_fit, edit):
    data = json.loads(json.dumps(structure_fit.to_dict()))
    if edit == "element":  # every coefficient of the elements doubled: other equilibria, other modes
        coefficients = data["structure"]["coefficients"]
        for name in coefficients:
            coefficients[name] *= 2.0
    else:  # the linear damping doubled: the same equilibria, higher damping ratios
        data["structure"]["C"] = (2.0 * np.asarray(data["structure"]["C"])).tolist()
    back = IdentifiedStructure.from_dict(data)
    s = back.structure
    eq = s.equilibria(back.z_range)
    assert back.equilibria == eq
    expected = s.modes(points=eq.stable)
    assert len(back.modes) == len(expected) > 0
    for got, want in zip(back.modes, expected, strict=True):
        assert got.fn_hz == pytest.approx(want.fn_hz, rel=1e-9) and got.zeta == pytest.approx(want.zeta, rel=1e-9)
    linear = linear_modes(s.M, s.C, s.K, [0.0] * s.n_dofs)
    assert back.linear_modes.zeta == pytest.approx(linear.zeta, rel=1e-9)
    old = structure_fit.modes
    if edit == "damping matrix":
        assert all(np.all(b.zeta > a.zeta) for a, b in zip(old, back.modes, strict=True))
    else:
        assert not all(np.allclose(a.fn_hz, b.fn_hz) for a, b in zip(old, back.modes, strict=False))
    # the residuals were of other coefficients
    assert back.eps_percent is None and back.force_residual_percent is None and STRUCTURE_STALE in back.warnings
    assert "modes" in str(back.summary())  # the summary reads a structure without residuals
