"""nlid's own identifiers against the named compliance checks of nlid.testing, one case per check."""

import pytest

from nlid.testing import parametrize_with_checks
from nlid_nsi import NSIInputPerturbation, NSIZeroShift
from nlid_rfs import RestoringForceSurface
from nlid_sindy import SparseIdentification


@parametrize_with_checks([RestoringForceSurface], accuracy=1e-6)
def test_rfs(check):
    check()


@parametrize_with_checks([SparseIdentification], accuracy=2e-3)
def test_sindy(check):
    check()


@parametrize_with_checks([SparseIdentification], options={"library": "automatic", "threshold": 0.01}, accuracy=2e-3)
def test_sindy_automatic_library(check):
    check()


# the check record is 10 s long (a sixth of the paper's): c_v comes out 0.2 % off there
@pytest.mark.slow
@parametrize_with_checks([NSIInputPerturbation, NSIZeroShift], accuracy=5e-3)
def test_nsi(check):
    check()
