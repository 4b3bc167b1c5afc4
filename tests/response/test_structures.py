"""3dof-cubic: the first-mode response and backbone at every DOF against time integration."""

from __future__ import annotations

import numpy as np
import pytest

from nlid.identified.structure import IdentifiedStructure
from nlid.simulation.presets import get_preset


@pytest.fixture(scope="module")
def chain():
    return get_preset("3dof-cubic").model()


@pytest.fixture(scope="module")
def first_mode(chain):
    from nlid.response import frequency_response

    return frequency_response(chain, 20.0, (18, 34), harmonics=7)


def test_the_response_of_every_dof_and_the_first_mode_backbone(first_mode):
    (curve,) = first_mode.curves
    assert curve.dofs == ("z1", "z2", "z3") and curve.coefficients.shape[1] == 3
    assert len(curve.folds) == 2
    labels = [b.label for b in first_mode.backbones]
    assert labels and all(lab.startswith("mode 1") for lab in labels)  # modes 2, 3 (63, 91 Hz) are outside the band
    frame = first_mode.to_frame()
    assert set(frame["dof"]) == {"z1", "z2", "z3"}


@pytest.mark.slow
def test_response_and_backbone_agree_with_time_integration_at_every_dof(first_mode):
    checked = first_mode.verify(points=3, unstable=1)
    assert checked.max_error_percent < 1.0 and checked.unstable_reached == 0
    assert all(len(c.simulated) == 3 for c in checked.checks)
    assert max(c.error_percent for c in checked.backbone_checks) < 1.0


def test_an_identified_structure_has_the_methods(chain):
    fit = IdentifiedStructure(structure=chain, method="truth")
    resp = fit.frequency_response(20.0, (18, 20), backbone=False)
    assert resp.dofs == ("z1", "z2", "z3")
    (b,) = fit.backbone(1e-3, modes=[1])
    assert b.mode == 1 and b.amplitude(3).max() > 0


def test_the_force_may_act_on_another_dof(chain):
    from nlid.response import frequency_response

    resp = frequency_response(chain, 5.0, (18, 20), dof=3, backbone=False)
    assert resp.forced == (0.0, 0.0, 1.0)
    assert np.all(resp.curves[0].amplitude(3) > resp.curves[0].amplitude(1))
