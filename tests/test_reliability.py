"""Issue 18 through the Python API: untrustworthy results refused, outputs guarded, inputs bounded.

The command-line side of the same classes is tests/test_hostile.py; the
property-based side tests/test_properties.py.
"""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

import nlid
from nlid.base.numerics import collect_warnings, describe_warnings
from nlid.bayes import Posterior
from nlid.bayes.priors import Normal, PriorConflictError, Uniform, prior_conflicts
from nlid.bayes.sampler import Chains
from nlid.contract.estimate import Estimate
from nlid.data.record import Record
from nlid.errors import IdentificationError, InputError, PluginError, describe_exception
from nlid.identified.model import IdentifiedModel
from nlid.model.terms import Model
from nlid.runtime.outputs import MARKER, POSTERIOR_OUTPUTS, STUDY_OUTPUTS, check_new_file, output_folder


# --------------------------------------------------------------------------- group 1
def _scaled(record: Record, factor: float) -> Record:
    return Record(f=record.f * factor, z=record.z, v=record.v, a=record.a, fs=record.fs, meta={"mass": 0.2})


def test_identify_refuses_non_finite_figures_through_the_api(short_record):
    with pytest.raises(IdentificationError) as info:
        nlid.identify(_scaled(short_record, 1e298), "z^3, z^2, v*|v|", method="rfs", mass=0.2)
    text = str(info.value)
    assert "cannot be trusted" in text and "standard errors of" in text and "overflow encountered" in text


def test_a_large_but_representable_scale_is_identified_exactly(short_record):
    """The refusal is about non-finite figures, not size: f x 1e30 scales the coefficients by 1e30."""
    base = nlid.identify(short_record, "z^3, z^2, v*|v|", method="rfs", mass=0.2)
    scaled = Record(f=short_record.f * 1e30, z=short_record.z, v=short_record.v, a=short_record.a,
                    fs=short_record.fs)
    fit = nlid.identify(scaled, "z^3, z^2, v*|v|", method="rfs", mass=0.2e30)
    for name in base.terms:
        assert fit.coefficients[name] == pytest.approx(1e30 * base.coefficients[name], rel=1e-6)
    assert np.isfinite(fit.eps_percent)


def test_from_estimate_names_every_kind_of_non_finite_figure(short_record):
    model = Model.from_spec("z^3")
    estimate = Estimate(
        coefficients={n: 1.0 for n in model.names},
        standard_errors={"z": float("nan"), "v": -1.0},
        modal=[{"equilibrium": 0.0, "fn_hz": float("inf"), "zeta": 0.1}],
    )
    with pytest.raises(IdentificationError) as info:
        IdentifiedModel.from_estimate(estimate, model=model, record=short_record, method="test", mass=0.2)
    text = str(info.value)
    assert "standard errors of z is nan" in text
    assert "standard errors of v are negative" in text
    assert "fn = inf Hz" in text


def test_collected_runtime_warnings_never_reach_the_caller():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with collect_warnings() as found:
            np.float64(1e308) * np.float64(10.0)
            np.log(np.zeros(2))
    assert len(found) == 2 and "overflow" in found[0] and "divide by zero" in found[1]
    assert "x2" in describe_warnings(["a (f.py:1)", "a (f.py:1)"])


def _posterior(samples: np.ndarray, names=("v",)) -> Posterior:
    chain = samples.reshape(samples.shape[0], 1, -1)
    chains = Chains(chain=chain, log_prob=np.zeros(chain.shape[:2]), tau=np.ones(len(names)), acceptance=0.3,
                    burn=0, thin=1)
    model = Model.from_spec("")
    return Posterior(model=model, names=tuple(names), chains=chains, start={n: 0.0 for n in model.names},
                     priors={}, likelihood=None, mass=1.0, method="test", seconds=0.0)  # type: ignore[arg-type]


def test_a_posterior_whose_mean_lies_outside_its_own_range_is_a_problem():
    rng = np.random.default_rng(0)
    # 4 % of the samples stuck far away: the mean leaves the 5-95 % range of the rest
    stuck = np.concatenate([np.full(960, 100.0) + 1e-6 * rng.standard_normal(960), np.full(40, -3000.0)])
    problems = _posterior(stuck[:, None]).problems()
    assert any("lies outside its own 5-95 % range" in p for p in problems), problems


def test_a_posterior_wider_than_its_normal_prior_is_a_problem():
    rng = np.random.default_rng(1)
    samples = rng.normal(0.0, 2.0, size=(4000, 1))
    assert _posterior(samples).problems({"v": 1.9}) == []  # within sampling error of the prior's width
    problems = _posterior(samples).problems({"v": 1.0})
    assert any("exceeds the sd of its normal prior" in p for p in problems), problems


def test_prior_conflicts_are_measured_in_combined_standard_deviations():
    mean, cov = np.array([1.0, 5.0]), np.diag([0.01, 0.04])  # sd 0.1 and 0.2
    near = {"v": Normal(1.3, 0.1), "v*|v|": Uniform(4.0, 6.0)}
    assert prior_conflicts(("v", "v*|v|"), near, mean, cov) == []
    far = {"v": Normal(100.0, 0.001), "v*|v|": Uniform(7.5, 9.0)}
    found = prior_conflicts(("v", "v*|v|"), far, mean, cov)
    assert len(found) == 2 and "standard deviations from what the data say" in found[0]


def test_the_posterior_api_reports_a_prior_in_conflict(numerical):
    record = numerical.with_overrides(duration=4.0).simulate(0, noise=0.02, channels=("z", "a"))
    fit = nlid.identify(record, "z^3, z^2, v*|v|", method="rfs", mass=0.2)
    with pytest.raises(PriorConflictError, match="the prior of v"):
        nlid.posterior(record, fit, priors={"v": "normal(100, 0.001)"}, bias_correction=False)


@pytest.mark.parametrize(
    "settings, message",
    [
        ({"seed": -1}, "seed must be an integer"),
        ({"walkers": 1}, "walkers= must be"),
        ({"max_steps": 0}, "max_steps= must be"),
        ({"bias_pairs": 10**6}, "bias_pairs= must be"),
        ({"cutoff": float("nan")}, "cutoff= must be"),
        ({"noise": {"q": 1.0}}, "only z and v"),
        ({"priors": ["v=normal(0,0)"]}, "positive sd"),
        ({"bias_correction": "no"}, "bias_correction must be"),
    ],
)
def test_posterior_settings_are_checked_when_given(settings, message):
    from nlid.bayes import PosteriorSampler

    with pytest.raises(InputError, match=message):
        PosteriorSampler(**settings)


# --------------------------------------------------------------------------- group 3
def test_plugin_boundary_descriptions():
    assert describe_exception(SystemExit(3)) == "called sys.exit(3)"
    assert describe_exception(SystemExit()) == "called sys.exit()"
    assert describe_exception(ValueError("x")) == "raised ValueError: x"


def test_identify_in_a_child_process_matches_identify_here(short_record):
    here = nlid.identify(short_record, "z^3, z^2, v*|v|", method="rfs", mass=0.2)
    there = nlid.identify(short_record, "z^3, z^2, v*|v|", method="rfs", mass=0.2, timeout=120)
    assert there.coefficients == here.coefficients and there.eps_percent == here.eps_percent


class _Exits:
    name = "exits"
    needs_mass = False

    def identify(self, record, model, *, mass=None):
        raise SystemExit(5)


def test_sys_exit_in_identify_is_a_plugin_error(short_record):
    with pytest.raises(PluginError, match="'exits' called sys.exit\\(5\\)"):
        nlid.identify(short_record, "z^3", method=_Exits())


# --------------------------------------------------------------------------- group 4
def test_output_folders_are_claimed_with_a_manifest(tmp_path):
    new = tmp_path / "new"
    with output_folder(new, POSTERIOR_OUTPUTS) as path:
        (path / "posterior.json").write_text("{}")
    manifest = json.loads((new / MARKER).read_text())
    assert set(POSTERIOR_OUTPUTS) <= set(manifest["entries"])
    with output_folder(new, STUDY_OUTPUTS):  # another writer of nlid's may add its entries
        pass
    assert set(STUDY_OUTPUTS) <= set(json.loads((new / MARKER).read_text())["entries"])


def test_a_foreign_folder_is_refused_and_never_touched(tmp_path):
    user = tmp_path / "user"
    user.mkdir()
    (user / "results.csv").write_text("mine")
    with pytest.raises(InputError, match="holds files nlid did not write"):
        with output_folder(user, STUDY_OUTPUTS):
            pass
    assert sorted(p.name for p in user.iterdir()) == ["results.csv"]
    with pytest.raises(InputError, match="results.csv, which nlid did not write"):
        with output_folder(user, STUDY_OUTPUTS, force=True):
            pass
    assert sorted(p.name for p in user.iterdir()) == ["results.csv"]
    with output_folder(user, POSTERIOR_OUTPUTS, force=True):  # beside the user's file, never over it
        pass
    assert (user / "results.csv").read_text() == "mine"
    with pytest.raises(InputError, match="results.csv, which nlid did not write"):
        with output_folder(user, STUDY_OUTPUTS, force=True):  # the manifest does not adopt the user's file
            pass


def test_a_study_folder_from_before_the_manifest_is_adopted(tmp_path):
    old = tmp_path / "old"
    (old / "runs").mkdir(parents=True)
    (old / "runs" / "a.json").write_text(json.dumps({"run_id": "a", "digest": "d", "row": {}}))
    (old / "results.csv").write_text("x")
    with output_folder(old, STUDY_OUTPUTS):
        pass
    assert (old / MARKER).is_file()


def test_a_named_file_is_replaced_only_with_force(tmp_path):
    path = tmp_path / "x.csv"
    check_new_file(path)
    path.write_text("mine")
    with pytest.raises(InputError, match="already exists; give force=True"):
        check_new_file(path)
    check_new_file(path, force=True)
    (tmp_path / "x.csv.meta.json").write_text('{"mine": 1}')
    with pytest.raises(InputError, match="was not written by nlid"):
        check_new_file(path, force=True)


def test_write_csv_never_replaces_a_foreign_sidecar(short_record, tmp_path):
    from nlid.data.io import write_csv

    (tmp_path / "r.csv.meta.json").write_text("my notes, not JSON")
    with pytest.raises(InputError, match="was not written by nlid"):
        write_csv(short_record, tmp_path / "r.csv")
    assert not (tmp_path / "r.csv").exists()
    assert (tmp_path / "r.csv.meta.json").read_text() == "my notes, not JSON"
