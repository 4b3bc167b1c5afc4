"""Measured points: stepped and swept sines read back, and the prediction error on them."""

from __future__ import annotations

import numpy as np
import pytest

from nlid.data.record import Record
from nlid.errors import InputError
from nlid.response.measured import measure
from nlid.simulation import SineTest, simulate


def _record(model, test: SineTest, fs: float = 512.0, meta: bool = True) -> Record:
    f, steps = test.force(fs)
    z, v, a = simulate(model.model, model.theta, model.mass, f, fs)
    info = {"signal": {"kind": f"{test.kind}-sine", "steps": steps}} if meta else {}
    return Record(f=f, z=z, fs=fs, meta={"force_hold": "zoh", **info})


@pytest.fixture(scope="module")
def stepped(duffing):
    return _record(duffing, SineTest("stepped", 1.0, (12.0, 22.0), steps=21, periods=60))


def test_steps_are_found_with_and_without_the_record_saying_where(duffing, stepped):
    told = measure(stepped)
    found = measure(Record(f=stepped.f, z=stepped.z, fs=stepped.fs, meta={}))
    assert told.kind == found.kind == "stepped" and len(told) == len(found) == 41
    assert np.allclose(told.frequency_hz, found.frequency_hz, rtol=1e-3)
    # the steps found start a little later: the same where the response settles fast (up, away from the jump)
    assert np.allclose(told.amplitude[:20], found.amplitude[:20], rtol=3e-3)
    assert np.allclose(told.force, 1.0, rtol=1e-3)
    assert told.direction[:20] == ("up",) * 20 and told.direction[-1] == "down"


def test_the_truth_predicts_its_own_stepped_sine(duffing, stepped):
    resp = duffing.frequency_response(1.0, (12, 22), backbone=False).compare(stepped)
    m = resp.measured
    assert m.error_percent < 1.0
    assert np.isfinite(m.predicted).all()
    # the hysteresis: the test goes up the upper branch and comes down on it (the top, 22 Hz, is below the
    # upper fold) until it falls at the lower fold (18.07 Hz); the prediction follows the same path
    at18 = np.flatnonzero(np.isclose(m.frequency_hz, 18.5))
    assert at18.size == 2 and np.allclose(m.predicted[at18], m.amplitude[at18], rtol=0.01)
    lower = duffing.frequency_response(1.0, (18.4, 18.6), backbone=False).curves[0].amplitude().min()
    assert m.amplitude[at18].min() > 2 * lower  # both on the upper branch


def test_a_sweep_is_read_cycle_by_cycle(duffing):
    record = _record(duffing, SineTest("swept", 1.0, (12.0, 16.0), rate=0.5, directions="up"), meta=False)
    m = measure(record, cycles=10)
    assert m.kind == "swept" and len(m) >= 10
    assert np.all(np.diff(m.frequency_hz) > 0) and set(m.direction) == {"up"}


def test_a_record_without_a_sine_is_refused():
    t = np.arange(1000) / 100.0
    with pytest.raises(InputError, match="cycles"):
        measure(Record(f=np.sin(2 * np.pi * 0.2 * t), z=np.cos(t), fs=100.0))


def test_a_prediction_at_another_force_is_refused(duffing, stepped):
    resp = duffing.frequency_response(2.0, (12, 14), backbone=False)
    with pytest.raises(InputError, match="force="):
        resp.compare(stepped)


def test_the_sine_presets_carry_their_steps():
    import nlid

    record = nlid.simulate("paper-numerical-stepped")
    steps = record.meta["signal"]["steps"]
    assert steps[0][1] == 0 and steps[-1][2] == record.n and record.meta["signal"]["kind"] == "stepped-sine"
