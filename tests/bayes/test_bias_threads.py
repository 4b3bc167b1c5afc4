"""The bias correction's pairs on several threads give the numbers of one thread, to the bit."""

from __future__ import annotations

import numpy as np
import pytest

from nlid.bayes import bias
from nlid.bayes.noise import channel_noise
from nlid.errors import IdentificationError, InputError
from nlid.estimation import balance
from nlid.simulation.presets import get_preset


@pytest.fixture(scope="module")
def case():
    """paper-experimental (30 s), 2 % noise on z and a, and its least-squares estimate."""
    preset = get_preset("paper-experimental").with_overrides(duration=30.0)
    model = preset.model()
    record = preset.simulate(2, noise=0.02, channels=("z", "a"))
    data = balance.regression_data(record, model)
    theta = np.linalg.lstsq(data.G, data.restoring_force(preset.mass), rcond=None)[0]
    levels = {c: level.sd for c, level in channel_noise(record, model, None).items()}
    return record, model, theta, preset.mass, data, levels


def _corrections(case, threads, sets=1):
    record, model, theta, mass, data, levels = case
    level_sets = [levels, {c: 1.1 * x for c, x in levels.items()}][:sets]
    return bias._bindings(
        record, model, theta, mass, data, level_sets, pairs=3, rng=np.random.default_rng(7), phase=0.5, threads=threads
    )


@pytest.mark.parametrize("threads", [2, 3])
def test_threads_give_the_numbers_of_one_thread(case, threads):
    one = _corrections(case, 1, sets=2)
    many = _corrections(case, threads, sets=2)
    for a, b in zip(one, many, strict=True):
        # exactly equal: the correction feeds the simulation of a chaotic model, where a last bit grows
        assert np.array_equal(a.binding, b.binding)
        assert np.array_equal(a.offset, b.offset)
        assert np.array_equal(a.pair_bindings, b.pair_bindings)
        assert a.noise == b.noise


def test_a_diverging_pair_is_reported_on_any_thread_count(case):
    record, model, theta, mass, data, levels = case
    unstable = theta.copy()
    unstable[model.index("z^3")] = -1e3 * abs(unstable[model.index("z^3")])  # a softening cubic: the state runs away
    for threads in (1, 2):
        with pytest.raises(IdentificationError, match="diverges when simulated"):
            bias._bindings(
                record,
                model,
                unstable,
                mass,
                data,
                [levels],
                pairs=2,
                rng=np.random.default_rng(0),
                phase=0.0,
                threads=threads,
            )


def test_in_order_yields_in_order_and_raises_at_the_failing_item():
    def work(i):
        if i == 3:
            raise ValueError("item 3")
        return i * i

    got = []
    with pytest.raises(ValueError, match="item 3"):
        for value in bias._in_order(work, 6, 2):
            got.append(value)
    assert got == [0, 1, 4]
    assert list(bias._in_order(lambda i: -i, 5, 3)) == [0, -1, -2, -3, -4]


def test_thread_count(monkeypatch):
    monkeypatch.setenv("NLID_WORKERS", "3")
    assert bias.bias_threads(8) == 3
    assert bias.bias_threads(2) == 2  # at most one per pair
    monkeypatch.delenv("NLID_WORKERS")
    monkeypatch.setenv("NUMBA_NUM_THREADS", "1")  # a pinned study run: one run per core
    assert bias.bias_threads(8) == 1
    monkeypatch.delenv("NUMBA_NUM_THREADS")
    assert 1 <= bias.bias_threads(8) <= 8
    assert bias.bias_threads(1) == 1


def test_an_invalid_pool_size_is_an_error_for_the_bias_correction_too(monkeypatch):
    monkeypatch.delenv("NUMBA_NUM_THREADS", raising=False)
    monkeypatch.setenv("NLID_WORKERS", "zero")
    with pytest.raises(InputError, match="NLID_WORKERS must be a positive integer"):
        bias.bias_threads(8)
