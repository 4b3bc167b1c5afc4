"""IdentifiedModel.from_dict with an edited coefficient recomputes what the coefficients give (issue 35)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import nlid
from nlid.identified.schema import STALE_NOTE
from nlid.model import physics


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
