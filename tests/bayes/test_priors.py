"""Priors: parsing (never eval), defaults scaled to the data, exclusion."""

import numpy as np
import pytest

from nlid.bayes.likelihood import SufficientStatistics
from nlid.bayes.priors import (
    Flat,
    Normal,
    PriorError,
    Uniform,
    default_priors,
    parse_prior,
    parse_prior_assignments,
)


def test_parse_prior_forms():
    assert parse_prior("normal(0, 5)") == Normal(0.0, 5.0)
    assert parse_prior(" Uniform( -1e-3 , 2.5E1 ) ") == Uniform(-1e-3, 25.0)
    assert parse_prior("flat") == Flat()


@pytest.mark.parametrize(
    "text", ["normal(0)", "gauss(0, 1)", "normal(0, -1)", "uniform(2, 1)", "__import__('os')", "normal(0, 1) + 1"]
)
def test_bad_priors_are_one_clear_error(text):
    with pytest.raises(PriorError, match="prior"):
        parse_prior(text)


def test_assignments_use_canonical_names():
    priors = parse_prior_assignments(["sign(v)*|v|^2=normal(5, 1)", "sgn(v) = uniform(0, 3)"])
    assert set(priors) == {"v*|v|", "sign(v)"}
    with pytest.raises(PriorError, match="TERM=SPEC"):
        parse_prior_assignments(["v*|v| normal(5, 1)"])
    with pytest.raises(PriorError, match="two priors"):
        parse_prior_assignments(["v*|v|=flat", "sign(v)*v^2=flat"])


def test_uniform_density_is_zero_outside():
    u = Uniform(0.0, 2.0)
    lp = u.logpdf(np.array([-0.1, 1.0, 2.1]))
    assert np.isneginf(lp[0]) and np.isneginf(lp[2]) and lp[1] == pytest.approx(-np.log(2.0))


def test_default_priors_scale_with_each_regressor():
    rng = np.random.default_rng(0)
    G = np.column_stack([rng.standard_normal(1000), 1e-3 * rng.standard_normal(1000)])
    y = G @ [1.0, 1e3] + 0.1 * rng.standard_normal(1000)
    stats = SufficientStatistics.from_arrays(G, y)
    priors = default_priors(stats, ["a", "b"])
    rms_y = np.sqrt(np.mean(y**2))
    assert priors["a"].sd == pytest.approx(10 * rms_y / np.sqrt(np.mean(G[:, 0] ** 2)))
    assert priors["b"].sd == pytest.approx(1e3 * priors["a"].sd, rel=0.1)
    # weak: the true values sit well inside one prior standard deviation
    assert 1.0 < priors["a"].sd and 1e3 < priors["b"].sd
