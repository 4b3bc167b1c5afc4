import dataclasses
import math

import numpy as np
import pytest

from nlid import IdentifiedModel, Model
from nlid.identified.reference import match_equilibria
from nlid.model.physics import Equilibria
from nlid.study.metrics import equilibrium_metrics


def test_match_equilibria_nearest_first_each_once():
    assert match_equilibria([-0.03, 0.02], [0.021, -0.029, 0.004]) == {0: 1, 1: 0}
    assert match_equilibria([-0.03, 0.02], [0.019]) == {1: 0}


def test_modal_matched_by_position_not_identity():
    # nsi-shift reports each well's modes at its own reference point, a hair away
    # from the combined model's equilibrium: they must still be scored.
    result = IdentifiedModel(
        model=Model.from_spec("z^3", without="v"),
        coefficients={"1": 1.962, "z": -500.0, "z^3": 1e6},
        mass=0.2,
        method="m",
        equilibria=Equilibria(stable=(-0.0266, 0.0173), unstable=(0.0043,)),
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


def test_surface_metrics_rms_quality_and_slices(short_record):
    from nlid import identify
    from nlid.study.metrics import surface_metrics

    result = identify(short_record, "z^3, z^2, v*|v|", "rfs", mass=0.2)
    result = dataclasses.replace(result, diagnostics={**result.diagnostics, "quality": {"z^3": 123.0}})
    row, arrays = surface_metrics(short_record, result, slices=(-0.02, 0.0, 5.0))
    z, v = short_record.z, short_record.v
    assert row["rms:z^3"] == pytest.approx(1e6 * np.sqrt(np.mean(z**3 * z**3)), rel=1e-6)
    assert row["rms:v*|v|"] == pytest.approx(5 * np.sqrt(np.mean((v * np.abs(v)) ** 2)), rel=1e-6)
    assert row["quality:z^3"] == 123.0
    # two slices inside the motion, none at z0 = 5 m (no samples there)
    assert {k.split(":")[0] for k in arrays} == {"slice0", "slice1"}
    assert float(arrays["slice0:z0"]) == -0.02 and arrays["slice0:v"].size == arrays["slice0:measured"].size
