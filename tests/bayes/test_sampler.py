"""emcee until converged: a known Gaussian, and the refusal to report unconverged chains."""

import numpy as np
import pytest

from nlid.bayes.sampler import ConvergenceError, run_until_converged
from nlid.errors import InputError


def _gaussian(mean, cov):
    prec = np.linalg.inv(cov)

    def log_prob(x):
        d = x - mean
        return -0.5 * np.einsum("wi,ij,wj->w", d, prec, d)

    return log_prob


MEAN = np.array([1.0, -2.0, 0.5])
COV = np.array([[1.0, 0.6, 0.0], [0.6, 1.0, -0.2], [0.0, -0.2, 0.25]])


@pytest.mark.parametrize("move", ["de", "stretch"])
def test_recovers_a_known_gaussian(move):
    chains = run_until_converged(
        _gaussian(MEAN, COV), MEAN + 3.0, np.full(3, 0.01), walkers=32, max_steps=50_000, seed=1, move=move
    )
    assert chains.steps >= 50 * chains.tau.max()
    s = chains.samples
    se = np.sqrt(np.diag(COV) / chains.n_effective)
    assert np.all(np.abs(s.mean(axis=0) - MEAN) < 5 * se)
    np.testing.assert_allclose(np.cov(s, rowvar=False), COV, atol=0.1)
    assert 0.1 < chains.acceptance < 0.8


def test_same_seed_same_chains():
    kw = dict(walkers=16, max_steps=20_000, seed=7)
    a = run_until_converged(_gaussian(MEAN, COV), MEAN, np.full(3, 0.1), **kw)
    b = run_until_converged(_gaussian(MEAN, COV), MEAN, np.full(3, 0.1), **kw)
    np.testing.assert_array_equal(a.chain, b.chain)


def test_too_few_steps_is_refused_with_what_to_raise():
    with pytest.raises(
        ConvergenceError, match=r"did not converge in 300 steps.*raise max_steps= \(e\.g\. max_steps=\d+\)"
    ):
        run_until_converged(
            _gaussian(MEAN, COV), MEAN, np.full(3, 0.1), walkers=16, max_steps=300, seed=0, names=("a", "b", "c")
        )


def test_too_few_walkers():
    with pytest.raises(InputError, match="at least 2 x 3 = 6 walkers"):
        run_until_converged(_gaussian(MEAN, COV), MEAN, np.full(3, 0.1), walkers=4, max_steps=100)


@pytest.mark.parametrize(
    ("ours", "theirs"),
    [("_DEMove", "DEMove"), ("_StretchMove", "StretchMove")],
)
def test_vectorised_moves_give_emcees_chains_to_the_bit(ours, theirs):
    """The faster acceptance test and log-probability call change no number of emcee's own."""
    import emcee

    from nlid.bayes import sampler as mod

    gaussian = _gaussian(MEAN, COV)

    def log_prob(x):  # a bounded support, so that some proposals have zero density
        lp = gaussian(x)
        lp[x[:, 0] > 1.5] = -np.inf
        return lp

    rng = np.random.default_rng(3)
    p0 = MEAN - 0.5 + 0.1 * rng.standard_normal((16, 3))
    chains = []
    for sampler_cls, move in (
        (mod._Sampler, getattr(mod, ours)()),
        (emcee.EnsembleSampler, getattr(emcee.moves, theirs)()),
    ):
        sampler = sampler_cls(16, 3, log_prob, vectorize=True, moves=move)
        state = emcee.State(p0.copy(), log_prob=log_prob(p0), random_state=np.random.RandomState(5).get_state())
        for _ in range(2):  # in chunks, as run_until_converged runs it: the second continues from the first
            for state in sampler.sample(state, iterations=200, skip_initial_state_check=True):  # noqa: B007, B020
                pass
        chains.append((sampler.get_chain(), sampler.get_log_prob(), sampler.acceptance_fraction))
    (c1, l1, a1), (c2, l2, a2) = chains
    assert 0.05 < a2.mean() < 0.95  # both accepted and rejected proposals were tested
    assert c2[:, :, 0].max() > 1.3  # the walkers reached the bound
    np.testing.assert_array_equal(c1, c2)
    np.testing.assert_array_equal(l1, l2)
    np.testing.assert_array_equal(a1, a2)


def test_a_nan_log_probability_is_refused_with_emcees_message():
    from nlid.bayes.sampler import _Sampler

    sampler = _Sampler(8, 2, lambda x: np.full(x.shape[0], np.nan), vectorize=True)
    with pytest.raises(ValueError, match="Probability function returned NaN"):
        sampler.compute_log_prob(np.zeros((8, 2)))
