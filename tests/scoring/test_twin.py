"""The chaos check's second run stopped where it joins the first: the two whole runs, to the bit (issue 36)."""

from __future__ import annotations

import numpy as np
import pytest

from nlid.model.terms import Model
from nlid.runtime import parallel
from nlid.scoring import twin
from nlid.simulation import SimulationError, free_run, random_force

FS = 200.0
MASS = 1.0


def _force(seed: int, n: int = 3000, scale: float = 1.0) -> np.ndarray:
    return scale * random_force(n, FS, 0.5, np.random.default_rng(seed), band=(0.5, 20.0))


def _whole(model, theta, force, x0, hold="zoh"):
    return free_run(model, theta, MASS, force, FS, force_hold=hold, x0=x0)[0]


def _bits(x: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(x, dtype=float).view(np.int64)


@pytest.mark.parametrize("hold", ["zoh", "sampled"])
@pytest.mark.parametrize("budget", [1, 2])
def test_a_damped_model_joins_and_gives_the_whole_runs(hold, budget, monkeypatch):
    model = Model.from_spec("z, v, z^3", defaults=False)
    theta = np.array([40.0, 8.0, 5.0])
    force = _force(1)
    x0, x1 = (0.01, 0.0), (0.01 + 1e-8, 0.0)
    joins = []
    monkeypatch.setattr(twin._Pair, "joined", _record_join(joins))
    with parallel.thread_budget(budget):
        z0, z1 = twin.free_run_pair(model, theta, MASS, force, FS, force_hold=hold, x0=x0, x1=x1, chunk=128)
    assert np.array_equal(_bits(z0), _bits(_whole(model, theta, force, x0, hold)))
    assert np.array_equal(_bits(z1), _bits(_whole(model, theta, force, x1, hold)))
    assert joins and joins[0] is not None and joins[0] < force.size - 256  # the second run stopped before the end


def test_a_run_that_never_joins_is_integrated_to_the_end():
    """Negative damping with a cubic limit: the offset grows and stays; the pair is still the whole runs."""
    model = Model.from_spec("z, v, v^3", defaults=False)
    theta = np.array([40.0, -1.0, 0.5])
    force = _force(2, scale=0.01)
    x0, x1 = (0.01, 0.0), (0.0100001, 0.0)
    for budget in (1, 2):
        with parallel.thread_budget(budget):
            z0, z1 = twin.free_run_pair(model, theta, MASS, force, FS, force_hold="zoh", x0=x0, x1=x1, chunk=100)
        assert np.array_equal(_bits(z0), _bits(_whole(model, theta, force, x0)))
        assert np.array_equal(_bits(z1), _bits(_whole(model, theta, force, x1)))
        assert not np.array_equal(z0[-100:], z1[-100:])


def test_a_diverging_run_raises_the_whole_runs_message():
    model = Model.from_spec("z, v", defaults=False)
    theta = np.array([40.0, -30.0])  # strongly negative damping: overflows
    force = _force(3, n=20000)
    with pytest.raises(SimulationError) as whole:
        _whole(model, theta, force, (0.01, 0.0))
    for budget in (1, 2):
        with parallel.thread_budget(budget), pytest.raises(SimulationError) as pair:
            twin.free_run_pair(model, theta, MASS, force, FS, force_hold="zoh", x0=(0.01, 0.0), x1=(0.02, 0.0))
        assert str(pair.value) == str(whole.value)


def test_the_bit_compare_tells_minus_zero_from_zero():
    assert twin._same((0.0, 1.0), (0.0, 1.0))
    assert not twin._same((-0.0, 1.0), (0.0, 1.0))
    assert not twin._same((0.0, 1.0), (0.0, np.nextafter(1.0, 2.0)))


def _record_join(joins):
    original = twin._Pair.joined

    def joined(self):
        joins.append(self.join)
        return original(self)

    return joined
