"""The posterior of a structure's unknowns (nlid.bayes.structure): elements on connections, K, C."""

from __future__ import annotations

import json

import numpy as np
import pytest

import nlid
from nlid.bayes import sample_posterior
from nlid.bayes.structure import NO_CORRECTION, NOISY_VELOCITY, StructureParameters, select_structure_params
from nlid.errors import InputError, NlidError
from nlid.estimation.structure_regression import unknown_names
from nlid.simulation.presets import get_preset


@pytest.fixture(scope="module")
def chain():
    """The 3dof-cubic preset, 8 s."""
    return get_preset("3dof-cubic").with_overrides(duration=8.0)


@pytest.fixture(scope="module")
def chain_noisy(chain):
    """3dof-cubic, 2 % noise on the accelerations only (regressors exact: no errors-in-variables bias)."""
    return chain.simulate(3, noise={"a": 0.02})


@pytest.fixture(scope="module")
def chain_fit(chain_noisy):
    return nlid.identify(chain_noisy, "z3^3", "rfs", mass=chain_noisy.mass)


def test_the_element_posterior_covers_the_truth_and_matches_its_gaussian_limit(chain_noisy, chain_fit):
    post = sample_posterior(chain_noisy, chain_fit, params="elements", seed=1, bias_correction=False)
    assert post.names == ("z3^3",)
    truth = chain_noisy.meta["reference"]["coefficients"]["z3^3"]
    lo, hi = post.interval(0.99)["z3^3"]
    assert lo < truth < hi
    mean, cov = post.gaussian_limit
    sd = post.summary_dict()["z3^3"]["sd"]
    assert sd == pytest.approx(np.sqrt(cov[0, 0]), rel=0.2)
    # every channel measured: nothing is filtered, the residual is white
    assert post.likelihood.info["band_hz"] is None
    assert post.warnings == (NO_CORRECTION,)  # velocities measured: no second warning
    assert post.reference == {"z3^3": pytest.approx(truth)}
    doc = json.loads(json.dumps(post.to_dict(), allow_nan=False))
    assert doc["units"] == {"z3^3": "N/m^3"}
    assert doc["likelihood"]["bias_correction"] is False
    assert "mass matrix diagonal" in post.format_table() and "N/m^3" in post.format_table()


def test_linear_unknowns_and_damping_can_be_sampled(chain_noisy, chain_fit):
    post = sample_posterior(chain_noisy, chain_fit, params="K[1,2], C[1,1]", seed=0)
    assert post.names == ("K[1,2]", "C[1,1]")
    units = post.to_dict()["units"]
    assert units == {"K[1,2]": "N/m", "C[1,1]": "N*s/m"}
    # the identified values lie inside the sampled posterior's bulk
    for name, (lo, hi) in post.interval(0.999).items():
        assert lo < post.start[name] < hi
    damping = sample_posterior(chain_noisy, chain_fit, params="damping", seed=0, others="fixed")
    assert all(n.startswith("C[") for n in damping.names)


def test_settings_a_structure_cannot_honour_are_refused(chain_noisy, chain_fit):
    with pytest.raises(InputError, match="noise floor"):
        sample_posterior(chain_noisy, chain_fit, params="elements", noise={"z": 1e-5})
    with pytest.raises(NlidError, match="not an element"):
        sample_posterior(chain_noisy, chain_fit, params="(z1-z2)^3")
    with pytest.raises(NlidError, match="not an unknown"):
        sample_posterior(chain_noisy, chain_fit, params="K[1,4]")


def test_unknowns_are_named_in_any_spelling_of_their_orientation():
    elements = nlid.identification.structure_fit.as_elements("(z1-z2)^3, (z1-z2)^2, (v1-v2)*|v1-v2|", 2)
    unknowns = StructureParameters(unknown_names(elements), elements)
    assert unknowns.canonical("(z1 - z2)^3") == "(z1-z2)^3"
    assert unknowns.canonical("(v1-v2)*|v1-v2|") == "(v1-v2)*|v1-v2|"
    with pytest.raises(InputError, match="opposite sign"):
        unknowns.canonical("(z2-z1)^3")
    assert unknowns.unit("s[2]") == "N"
    picked = select_structure_params(unknowns, "(z1-z2)^3, K[1,2]")
    assert [unknowns.names[i] for i in picked] == ["(z1-z2)^3", "K[1,2]"]
    assert [unknowns.names[i] for i in select_structure_params(unknowns, "damping")] == [
        "(v1-v2)*|v1-v2|",
        "C[1,1]",
        "C[1,2]",
        "C[2,2]",
    ]


def test_priors_on_a_structure_use_its_names(chain_noisy, chain_fit):
    truth = chain_noisy.meta["reference"]["coefficients"]["z3^3"]
    post = sample_posterior(
        chain_noisy, chain_fit, params="elements", priors={"z3 ^ 3": f"normal({truth}, {abs(truth)})"}, seed=0
    )
    assert post.priors["z3^3"].startswith("normal(")
    with pytest.raises(NlidError, match="not sampled"):
        sample_posterior(chain_noisy, chain_fit, params="elements", priors={"K[1,1]": "flat"})


def test_a_filtered_balance_counts_its_correlated_residual(chain):
    """Velocities and accelerations estimated from z: the residual is correlated and the sample size shrinks."""
    record = chain.simulate(5, noise={"z": 0.005}, channels=["z1", "z2", "z3"])
    fit = nlid.identify(record, "z3^3", "rfs", mass=record.mass)
    post = sample_posterior(record, fit, params="elements", seed=0)
    info = post.likelihood.info
    assert info["band_hz"] == pytest.approx(fit.diagnostics["balance_cutoff_hz"])
    assert info["tau_residual_samples"] > 2.0
    assert info["dof"] < info["samples"] / 2.0
    assert len(info["dof_weights"]) == 3 and max(info["dof_weights"]) == 1.0
    # the correction simulated each displacement's noise at its floor, which sees at least the noise the record
    # was given (signal in the floor's band can only add to it: nlid.signal.derivatives.noise_sd)
    true_sd = 0.005 * record.z.std(axis=0)  # noise added relative to the clean channel's std (~ the noisy one's)
    assert info["bias_correction"] is True
    assert np.all(np.asarray(info["noise_sd"]) > 0.8 * true_sd)
    assert post.warnings == ()  # no velocity measured, nothing uncorrected
    plain = sample_posterior(record, fit, params="elements", seed=0, bias_correction=False)
    assert any("velocities estimated from the displacements (v1, v2, v3)" in w for w in plain.warnings)
    assert NO_CORRECTION in plain.warnings


def test_the_correction_removes_the_damping_bias_of_noisy_displacements():
    """2 % noise on z (v differentiated from it) biases the quadratic damping between the masses by several sd."""
    record = get_preset("2dof-double-well").with_overrides(duration=10.0).simulate(
        11, noise={"z": 0.02, "a": 0.02}, channels=["z", "a"]
    )
    fit = nlid.identify(record, "(z1-z2)^3, (z1-z2)^2, (v1-v2)*|v1-v2|", "rfs", mass=record.mass)
    name, truth = "(v1-v2)*|v1-v2|", record.meta["reference"]["coefficients"]["(v1-v2)*|v1-v2|"]
    post = sample_posterior(record, fit, params=name, seed=0)
    lik = post.likelihood
    i = lik.names.index(name)
    sd = float(np.sqrt(lik.covariance[i, i]))
    assert abs(lik.estimate[i] - truth) > 2 * sd  # the least-squares estimate misses by more than 2 sd
    assert abs(lik.center[i] - truth) < abs(lik.estimate[i] - truth) / 2
    lo, hi = post.interval(0.99)[name]
    assert lo < truth < hi
    assert post.bias_shifts[name] == pytest.approx((lik.center[i] - lik.estimate[i]) / sd)


def test_measured_velocities_are_named_as_not_simulated(chain_noisy, chain_fit):
    post = sample_posterior(chain_noisy, chain_fit, params="elements", seed=0)
    assert post.warnings == (NOISY_VELOCITY.format(channels="v1, v2, v3"),)
