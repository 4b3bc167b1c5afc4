"""nlid.estimation.balance: the force balance filtered ahead in a second thread, and long records' columns in blocks.

Both must give the arrays the scores would compute on their own, to the bit.
"""

import threading

import numpy as np
import pytest

from nlid.data.record import Record
from nlid.estimation import balance
from nlid.model.terms import Model

MODEL = "z^3, z^2, v*|v|"


def _record(n: int, seed: int = 0) -> Record:
    """A smooth random motion and force of ``n`` samples at 1 kHz (no acceleration: it is estimated)."""
    rng = np.random.default_rng(seed)
    z = np.cumsum(rng.standard_normal(n)) * 1e-4
    return Record(f=rng.standard_normal(n), z=z - z.mean(), fs=1000.0)


def _same(a: balance.RegressionData, b: balance.RegressionData) -> None:
    for name in ("f", "a", "G", "z", "v"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), strict=True)
    assert (a.filtered_at, a.kept, a.provenance) == (b.filtered_at, b.kept, b.provenance)


@pytest.fixture
def spare_core(monkeypatch):
    """As on a machine of two cores that no library holds to one thread."""
    monkeypatch.setattr(balance, "_spare_core", lambda: True)


def test_prefetched_balance_is_the_same_to_the_bit(spare_core, monkeypatch):
    monkeypatch.setattr(balance, "PREFETCH_MIN_SAMPLES", 1000)
    model = Model.from_spec(MODEL)
    ahead, fresh = _record(5000), _record(5000)
    threads = threading.active_count()
    wait = balance.prefetch_regression_data(ahead, model)
    wait()
    assert threading.active_count() == threads
    cache = balance._record_cache(ahead)
    assert any(isinstance(k, tuple) and k[0] == "a~" for k in cache)  # the prefetch filled the record's cache
    _same(balance.regression_data(ahead, model), balance.regression_data(fresh, model))
    _same(balance.regression_data(ahead, model, trim=False), balance.regression_data(fresh, model, trim=False))


def test_a_caller_during_the_prefetch_waits_for_it(spare_core, monkeypatch):
    """The identifier's own regression_data of the record takes the prefetched arrays (the same objects)."""
    monkeypatch.setattr(balance, "PREFETCH_MIN_SAMPLES", 1000)
    model = Model.from_spec(MODEL)
    rec = _record(4000, seed=1)
    wait = balance.prefetch_regression_data(rec, model)
    mine = balance.regression_data(rec, model)
    wait()
    again = balance.regression_data(rec, model)
    assert mine.a.base is again.a.base and mine.f.base is again.f.base
    _same(mine, balance.regression_data(_record(4000, seed=1), model))


def test_nothing_is_started_without_reason(monkeypatch):
    model = Model.from_spec(MODEL)
    rec = _record(2000)
    threads = threading.active_count()
    # short record
    monkeypatch.setattr(balance, "_spare_core", lambda: True)
    assert balance.prefetch_regression_data(rec, model) is balance._nothing
    monkeypatch.setattr(balance, "PREFETCH_MIN_SAMPLES", 1000)
    # every channel the model needs is measured
    v = np.gradient(rec.z) * rec.fs
    measured = Record(f=rec.f, z=rec.z, v=v, a=np.gradient(v) * rec.fs, fs=rec.fs)
    assert balance.prefetch_regression_data(measured, model) is balance._nothing
    # px(z) roots still to be found
    px = Model.from_spec("z^3, sign(v)*|px(z)|")
    assert balance.prefetch_regression_data(rec, px) is balance._nothing
    assert threading.active_count() == threads
    assert not balance._record_cache(rec)


@pytest.mark.parametrize("setting", ["OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"])
def test_one_thread_asked_for_means_no_second_thread(monkeypatch, setting):
    monkeypatch.setenv(setting, "1")
    assert not balance._spare_core()


def test_columns_in_blocks_are_the_columns_at_once(monkeypatch):
    """A long record's columns a few at a time (here forced on a short one): the same numbers, the same order."""
    model = Model.from_spec("z^3, z^2, v*|v|, sign(v)")
    whole = balance.regression_data(_record(3000, seed=2), model)
    monkeypatch.setattr(balance, "COLUMN_BLOCK_BYTES", 2 * 8 * 3000)  # two columns per block
    blocks = balance.regression_data(_record(3000, seed=2), model)
    _same(whole, blocks)
    assert blocks.G.shape == (whole.G.shape[0], len(model))
