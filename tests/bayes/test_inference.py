"""The posterior end to end on a short noisy record, its outputs and its refusals."""

import dataclasses
import json

import numpy as np
import pytest

from nlid import identify
from nlid.bayes import (
    ConvergenceError,
    DegenerateParametersError,
    PosteriorSampler,
    PriorError,
    posterior_metrics,
    sample_posterior,
)
from nlid.bayes.datatree import netcdf_available
from nlid.errors import InputError
from nlid.model.terms import Model
from nlid.simulation.presets import get_preset
from nlid.study.metrics import posterior_columns


@pytest.fixture(scope="module")
def preset():
    return get_preset("paper-numerical").with_overrides(duration=20.0)


@pytest.fixture(scope="module")
def record(preset):
    """20 s of paper-numerical with 2 % noise on z and a (v estimated)."""
    return preset.simulate(11, noise=0.02, channels=("z", "a"))


@pytest.fixture(scope="module")
def result(preset, record):
    return identify(record, preset.model(), "rfs", mass=preset.mass)


@pytest.fixture(scope="module")
def posterior(record, result):
    return sample_posterior(record, result, params="damping", seed=3)


def test_posterior_samples_the_damping_terms_from_the_estimate(posterior, result):
    assert posterior.names == ("v", "v*|v|")
    assert posterior.others == "marginal"
    assert set(posterior.not_sampled) == {"1", "z", "z^2", "z^3"}
    assert all(posterior.not_sampled[n] == result.coefficients[n] for n in posterior.not_sampled)
    chains = posterior.chains
    assert chains.steps >= 50 * chains.tau.max() and chains.burn >= chains.tau.max()
    assert 0.1 < chains.acceptance < 0.9
    # the chain starts at the identifier's estimate
    np.testing.assert_allclose(
        np.median(chains.chain[0], axis=0), [result.coefficients[n] for n in posterior.names], rtol=0.05
    )


def test_summary_is_ordered_and_matches_the_gaussian_limit(posterior):
    mean, cov = posterior.gaussian_limit
    for i, (name, s) in enumerate(posterior.summary_dict().items()):
        assert s["q05"] < s["q50"] < s["q95"] and s["sd"] > 0
        sd = np.sqrt(cov[i, i])
        assert s["mean"] == pytest.approx(mean[i], abs=0.15 * sd)
        assert s["sd"] == pytest.approx(sd, rel=0.15)
        assert posterior.n_effective[name] > 500


def test_json_document(posterior):
    doc = json.loads(json.dumps(posterior.to_dict(), allow_nan=False))
    assert set(doc) >= {"params", "tau", "acceptance", "n_effective", "seconds"}
    assert set(doc["params"]["v*|v|"]) == {"mean", "sd", "q05", "q50", "q95"}
    assert doc["units"]["v*|v|"] == "N*s^2/m^2" and doc["seconds"] > 0


def test_same_seed_same_posterior(record, result, posterior):
    again = sample_posterior(record, result, params="damping", seed=3)
    np.testing.assert_array_equal(again.samples, posterior.samples)


def test_save_writes_table_json_npz_and_figures(posterior, tmp_path):
    paths = posterior.save(tmp_path, slices=[-0.02, 0.0, 0.015])
    names = {p.name for p in paths}
    assert names == {
        "posterior_table.csv",
        "posterior.json",
        "posterior_samples.npz",
        "posterior_corner.png",
        "posterior_trace.png",
        "posterior_damping.png",
    } | ({"posterior.nc"} if netcdf_available() else set())  # ArviZ's format, with the netcdf extra
    with np.load(tmp_path / "posterior_samples.npz", allow_pickle=False) as npz:
        assert npz["samples"].shape[1] == 2 and list(npz["names"]) == ["v", "v*|v|"]
        assert npz["damping0_q05"].shape == npz["damping0_v_grid"].shape
        assert np.all(npz["damping1_q05"] <= npz["damping1_q95"])


def test_damping_bands_contain_the_true_law(posterior):
    for band in posterior.damping_bands([-0.02, 0.015]):
        true = band.v_grid + 5.0 * band.v_grid * np.abs(band.v_grid)
        assert np.all(band.q05 <= band.q95)
        # the band is narrow compared with the force itself, and the truth lies within a few band widths
        width = np.max(band.q95 - band.q05)
        assert width < 0.05 * np.max(np.abs(true))
        assert np.max(np.abs(band.q50 - true)) < 5 * width


def test_marginal_carries_the_uncertainty_of_the_other_coefficients(record, result, posterior):
    # default: the stiffness is integrated out; the sd is that of the marginal covariance block
    idx = [posterior.model.index(n) for n in posterior.names]
    cov = posterior.likelihood.covariance[np.ix_(idx, idx)]
    fixed = sample_posterior(record, result, params="damping", seed=3, others="fixed")
    assert fixed.to_dict()["fixed"] == fixed.not_sampled and posterior.to_dict()["fixed"] == {}
    for i, name in enumerate(posterior.names):
        s = posterior.summary_dict()[name]
        assert s["sd"] == pytest.approx(np.sqrt(cov[i, i]), rel=0.15)
        # holding the stiffness fixed can only narrow the posterior (up to sampling noise)
        assert fixed.summary_dict()[name]["sd"] <= 1.1 * s["sd"]


def test_all_params_samples_the_stiffness_too(record, result):
    post = sample_posterior(record, result, params="all", seed=1, bias_pairs=2)
    assert len(post.names) == 6 and not post.not_sampled


def test_non_convergence_is_refused_with_what_to_raise(record, result):
    with pytest.raises(ConvergenceError, match=r"did not converge in 200 steps.*raise max_steps="):
        sample_posterior(record, result, params="damping", max_steps=200, bias_correction=False)


def test_prior_excluding_the_estimate(record, result):
    with pytest.raises(
        PriorError, match=r"prior of v\*\|v\| \(uniform\(0, 1\)\) excludes the identifier's estimate 4\.9"
    ):
        sample_posterior(record, result, priors={"v*|v|": "uniform(0, 1)"}, bias_correction=False)


def test_prior_on_a_fixed_term(record, result):
    with pytest.raises(PriorError, match="z\\^3, which is not sampled"):
        sample_posterior(record, result, priors=["z^3=normal(1e6, 1e5)"], bias_correction=False)


def test_degenerate_parameters(preset, record):
    # tanh(v/1000) is v/1000 to 1e-7 on this record: collinear with v
    model = Model.from_spec("z^3, z^2, v*|v|, tanh(v/1000)")
    res = identify(record, model, "rfs", mass=preset.mass)
    with pytest.raises(
        DegenerateParametersError, match=r"v, tanh\(v/1000\) are \(nearly\) collinear|tanh\(v/1000\), v are"
    ):
        sample_posterior(record, res, params="v, tanh(v/1000)", bias_correction=False)


def test_bad_params_and_missing_mass(record, result):
    with pytest.raises(InputError, match="does not contain"):
        sample_posterior(record, result, params="sign(v)")
    no_mass = dataclasses.replace(result, mass=None, scores=None)
    with pytest.raises(InputError, match="needs the mass"):
        sample_posterior(record, no_mass)
    with pytest.raises(InputError, match="unknown move"):
        PosteriorSampler(move="gibbs")


def test_posterior_metrics(record, result, preset):
    metrics = posterior_metrics(record, result, preset.truth(), seed=0, bias_pairs=2)
    assert set(metrics.intervals) == set(metrics.covers) == {"v", "v*|v|"}
    columns = posterior_columns(metrics)  # the study flattens the typed value into its row
    assert set(columns) == {
        *(f"ci_{kind}:{t}" for kind in ("lo", "hi", "width", "covers") for t in ("v", "v*|v|")),
        "posterior:level",
        "posterior:tau",
        "posterior:seconds",
        "posterior:max_bias_shift_sd",
    }
    for t in ("v", "v*|v|"):
        lo, hi = metrics.intervals[t]
        assert lo < hi and columns[f"ci_width:{t}"] == pytest.approx(hi - lo)
        assert columns[f"ci_lo:{t}"] == lo and columns[f"ci_hi:{t}"] == hi
        assert metrics.covers[t] == columns[f"ci_covers:{t}"] == (lo <= preset.truth()["coefficients"][t] <= hi)
    unknown = posterior_metrics(record, result, None, seed=0, bias_pairs=2, level=0.5)
    assert unknown.level == 0.5 and unknown.covers == {} and "ci_covers:v" not in posterior_columns(unknown)
    assert unknown.intervals["v"][1] - unknown.intervals["v"][0] < metrics.intervals["v"][1] - metrics.intervals["v"][0]
