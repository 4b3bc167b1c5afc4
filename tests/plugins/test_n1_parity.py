"""One DOF as the n = 1 structure, identifier by identifier (issue 32, house.md "One DOF as n = 1").

Before a structure path can replace a one-DOF path, it must give the same answer at n = 1. rfs's does: the
same joint least squares, to rounding. (nsi's multi-output path does not yet: on the record below it moves
``v*|v|`` by 2.5 % and takes 4x as long, so the one-DOF nsi stays the n = 1 path; docs/architecture.md.)
"""

from __future__ import annotations

import pytest

import nlid
from nlid.data.structure_record import StructureRecord
from nlid.simulation.presets import get_preset


@pytest.fixture(scope="module")
def noisy_record():
    return get_preset("paper-numerical").simulate(seed=1, noise=0.01, channels=("z",))


def test_rfs_structure_path_at_n1_is_the_one_dof_path(noisy_record):
    preset = get_preset("paper-numerical")
    one = nlid.identify(noisy_record, "z^2, z^3, v*|v|", "rfs", mass=preset.mass)
    many = nlid.identify(StructureRecord.from_record(noisy_record), "z1^2, z1^3, v1*|v1|", "rfs", mass=[[preset.mass]])
    pairs = {"z^2": "z1^2", "z^3": "z1^3", "v*|v|": "v1*|v1|"}
    for name, element in pairs.items():
        assert many.coefficients[element] == pytest.approx(one.coefficients[name], rel=1e-9)
