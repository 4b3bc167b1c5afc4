"""The foundation's rfs plugin (least squares on the restoring-force surface)."""

import pytest

from nlid import IdentificationError, identify
from nlid.testing import check_identifier
from nlid_rfs import RestoringForceSurface

TERMS = "z^3, z^2, v*|v|"


def test_contract_and_accuracy():
    check_identifier(RestoringForceSurface, accuracy=1e-6)


def test_noise_free_recovery_within_0_1_percent(exact_record, numerical):
    """Issue 2: checks the simulator, term language and physics against each other."""
    truth = numerical.truth()["coefficients"]
    for mass in (0.2, None):
        res = identify(exact_record, TERMS, "rfs", mass=mass)
        for name, value in res.coefficients.items():
            assert value == pytest.approx(truth[name], rel=1e-3), name
        assert res.mass == pytest.approx(0.2, rel=1e-3)
        assert res.mass_estimated is (mass is None)
        assert res.eps_percent < 1e-6


def test_rank_deficient_model_fails_explicitly(short_record):
    # z*|z| and z^2 coincide on a one-sided record: same columns
    positive = short_record.replace(z=short_record.z - short_record.z.min() + 1e-3)
    with pytest.raises(IdentificationError, match="rank deficient|not positive"):
        identify(positive, "z^2, z*|z|", "rfs", mass=0.2)
