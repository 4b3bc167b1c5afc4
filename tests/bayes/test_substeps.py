"""The bias correction simulates accurately the record it corrects (issue 35: Silverbox, 9 samples a period)."""

from __future__ import annotations

import numpy as np
import pytest

import nlid
from nlid.bayes.bias import STEPS_PER_PERIOD, _trajectory, correction_substeps, indirect_inference
from nlid.bayes.likelihood import build_likelihood
from nlid.bayes.trust import CORRECTION_BOUND_SD
from nlid.errors import InputError
from nlid.estimation.balance import regression_data
from nlid.model.terms import Model
from nlid.simulation import free_run, simulate

SILVERBOX_LIKE = {"1": 0.0, "z": 0.989, "z^3": 3.86, "v": 0.000226}
MASS = 5.36e-6
FS = 610.35


@pytest.fixture(scope="module")
def silverbox_like():
    """The Silverbox-like oscillator of test_trust, 0.1 % noise on z (its own level)."""
    rng = np.random.default_rng(0)
    f = 0.022 * rng.standard_normal(24000)
    z, _, _ = free_run(Model.from_spec("z^3"), SILVERBOX_LIKE, MASS, f, FS, force_hold="sampled")
    noise = 1e-3 * np.std(z)
    return nlid.Record(f=f, z=z + noise * rng.standard_normal(z.size), fs=FS), noise


def test_the_rule_takes_enough_steps_per_period_of_the_linear_mode(silverbox_like):
    record, _ = silverbox_like
    model = Model.from_spec("z^3")
    theta = model.vector(SILVERBOX_LIKE)
    q = correction_substeps(record, model, theta, MASS)
    fn = np.sqrt(SILVERBOX_LIKE["z"] / MASS) / (2 * np.pi)  # the linear mode at the equilibrium z = 0
    assert FS * q / fn >= STEPS_PER_PERIOD > FS * (q - 1) / fn
    # a paper record has many samples per period: one step per sample
    paper = nlid.simulate("paper-numerical", seed=0, duration=5.0)
    pmodel = Model.from_spec("z^3, z^2, v*|v|")
    ptheta = pmodel.vector({**paper.meta["reference"]["coefficients"]})
    assert correction_substeps(paper, pmodel, ptheta, paper.mass) == 1


def test_the_trajectory_is_the_simulators():
    model = Model.from_spec("z^3")
    theta = model.vector(SILVERBOX_LIKE)
    f = 0.022 * np.random.default_rng(1).standard_normal(2000)
    held = nlid.Record(f=f, z=f, fs=FS, meta={"force_hold": "zoh"})
    z, v, a = _trajectory(model, theta, MASS, f, held, (0.0, 0.0), 1)
    z1, v1, a1 = simulate(model, theta, MASS, f, FS)
    assert np.array_equal(z, z1) and np.array_equal(v, v1) and np.array_equal(a, a1)  # to the bit
    sampled = nlid.Record(f=f, z=f, fs=FS)
    z, v, a = _trajectory(model, theta, MASS, f, sampled, (0.0, 0.0), 8)
    z8, v8, _ = free_run(model, theta, MASS, f, FS, force_hold="sampled", oversample=8)
    assert np.array_equal(z, z8) and np.array_equal(v, v8)
    # the acceleration at the sample times is the force balance with the force samples themselves
    r = model.evaluate_terms(theta, z, v)
    assert np.allclose(a, (f - r) / MASS, rtol=1e-9, atol=1e-9 * np.max(np.abs(a)))


def test_a_record_with_few_samples_per_period_is_corrected_to_its_truth(silverbox_like):
    record, noise = silverbox_like
    model = Model.from_spec("z^3")
    data = regression_data(record, model)
    lik = build_likelihood(record, model, MASS, data=data, bias_correction=False)
    truth = model.vector(SILVERBOX_LIKE)
    centres = {}
    for q in (None, 1):  # the rule's sub-steps, and one step per sample (before issue 35)
        centre, cov, info = indirect_inference(
            record, model, lik.center, MASS, data, lik.covariance, noise={"z": noise}, rng=rng(), substeps=q
        )
        centres[q] = (centre - truth) / np.sqrt(np.diag(cov)), (centre - lik.center) / np.sqrt(np.diag(cov))
        if q is None:
            assert info["substeps"] >= 5
    error, move = centres[None]
    assert np.all(np.abs(error) < 3.0), error  # the corrected estimate is within 3 sd of the truth
    assert np.all(np.abs(move) < CORRECTION_BOUND_SD)
    # one step per sample: the integration error is read as a bias far beyond the bound
    assert np.max(np.abs(centres[1][1])) > CORRECTION_BOUND_SD


def rng() -> np.random.Generator:
    """The correction's noise draws."""
    return np.random.default_rng(0)


def test_substeps_must_be_a_positive_whole_number(silverbox_like):
    from nlid.bayes import simulate_bias

    record, _ = silverbox_like
    model = Model.from_spec("z^3")
    data = regression_data(record, model)
    with pytest.raises(InputError, match="substeps"):
        simulate_bias(record, model, model.vector(SILVERBOX_LIKE), MASS, data, substeps=0)
