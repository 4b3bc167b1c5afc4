import math

import pytest

from nlid import IdentificationResult
from nlid.study.metrics import equilibrium_metrics, match_equilibria


def test_match_equilibria_nearest_first_each_once():
    assert match_equilibria([-0.03, 0.02], [0.021, -0.029, 0.004]) == {0: 1, 1: 0}
    assert match_equilibria([-0.03, 0.02], [0.019]) == {1: 0}


def test_modal_matched_by_position_not_identity():
    # nsi-shift reports each well's modes at its own reference point, a hair away
    # from the combined model's equilibrium: they must still be scored.
    result = IdentificationResult(
        method="m",
        coefficients={},
        equilibria={"stable": [-0.0266, 0.0173], "unstable": [0.0043]},
        modal=[
            {"equilibrium": -0.02657, "fn_hz": 13.0, "zeta": 0.03},
            {"equilibrium": 0.01731, "fn_hz": 8.6, "zeta": 0.05},
        ],
    )
    reference = {
        "equilibria": [-0.0266, 0.0173],
        "modal": [{"fn_hz": 13.1, "zeta": 0.0304}, {"fn_hz": 8.52, "zeta": 0.0467}],
    }
    row = equilibrium_metrics(result, reference)
    assert row["fn_error_pct:s1"] == pytest.approx(100 * (13.0 - 13.1) / 13.1)  # signed
    assert row["zeta_error_pct:s2"] == pytest.approx(100 * (0.05 - 0.0467) / 0.0467)
    assert row["eq_missing"] == 0 and not math.isnan(row["eq_error_max_pct"])
