"""Presets, the simulator and the physics checked against the paper (Sec. 3, NOTES.md)."""

import numpy as np
import pytest

from nlid import InputError
from nlid.model import physics
from nlid.model.terms import Model
from nlid.simulation import SimulationError, simulate
from nlid.simulation.presets import PRESETS, get_preset


def test_paper_numerical_physics_matches_the_paper(numerical):
    model, theta = numerical.model(), numerical.truth()["coefficients"]
    eq = physics.equilibria(model, theta)
    # NOTES.md / paper Sec. 3: -0.02658, 0.00426 (unstable), 0.01732 m
    assert eq.stable == pytest.approx((-0.02658, 0.01732), rel=5e-4)
    assert eq.unstable == pytest.approx((0.00426,), rel=5e-3)
    modal = physics.modal(model, theta, numerical.mass)
    assert [round(m.fn_hz, 2) for m in modal] == [13.10, 8.52]
    assert [round(100 * m.zeta, 2) for m in modal] == [3.04, 4.67]


def test_paper_experimental_reproduces_the_rig(tmp_path):
    p = get_preset("paper-experimental")
    model, theta = p.model(), p.truth()["coefficients"]
    assert model.px_roots == pytest.approx((-0.02798, 0.02668), abs=1e-5)
    eq = physics.equilibria(model, theta)
    # Table 7: measured -0.030 m and +0.024 m
    assert eq.stable == pytest.approx((-0.030, 0.024), abs=2e-4)
    rec = p.with_overrides(duration=30.0).simulate(0, channels=("z",))
    crossings = np.count_nonzero(np.diff(np.sign(rec.z - eq.unstable[0])))
    assert crossings / rec.duration > 1.0, "the preset must cross between the wells"


def test_record_size_seed_and_noise(numerical):
    rec = numerical.simulate(0, noise=0.02, channels=("z", "a"))
    assert rec.n == 122_880 and rec.fs == 2048.0 and rec.channels == ("f", "z", "a")
    clean = numerical.simulate(0, channels=("z", "v", "a"))
    np.testing.assert_array_equal(rec.f, clean.f)  # force independent of channels and noise
    noise = rec.z - clean.z
    assert noise.std() == pytest.approx(0.02 * clean.z.std(), rel=0.02)
    assert abs(np.corrcoef(noise, rec.a - clean.a)[0, 1]) < 0.02, "independent noise per channel"
    assert rec.f.std() == pytest.approx(50.0)
    assert rec.meta["truth"]["coefficients"]["v*|v|"] == 5.0
    other = numerical.simulate(1, channels=("z",))
    assert not np.allclose(other.f, rec.f)


def test_simulated_acceleration_is_consistent(exact_record, numerical):
    model = numerical.model()
    R = physics.restoring(model, numerical.truth()["coefficients"], exact_record.z, exact_record.v)
    np.testing.assert_allclose(numerical.mass * exact_record.a, exact_record.f - R, atol=1e-9)


def test_overrides_and_errors(numerical):
    p = numerical.with_overrides(mass=0.4, coefficients={"z^3": 2e6})
    assert p.coefficients["1"] == pytest.approx(0.4 * 9.81) and p.coefficients["z^3"] == 2e6
    with pytest.raises(InputError, match="did you mean 'mass'"):
        numerical.with_overrides(mas=1.0)
    with pytest.raises(InputError, match="did you mean 'paper-numerical'"):
        get_preset("paper-numeric")
    with pytest.raises(InputError, match="unknown channel"):
        numerical.simulate(0, channels=("q",))
    assert set(PRESETS) >= {"paper-numerical", "paper-experimental"}


def test_divergence_is_reported():
    model = Model.from_spec("z^3")
    with pytest.raises(SimulationError, match="diverged"):
        simulate(model, {"z^3": -1e9, "z": 1.0}, 1.0, np.full(2000, 100.0), 100.0)
