"""Posteriors as xarray DataTrees (ArviZ 1.0's format): the groups, netCDF round trips, ArviZ, the missing extra."""

from __future__ import annotations

import importlib
import warnings

import numpy as np
import pytest

import nlid
from nlid.bayes import datatree, sample_posterior
from nlid.errors import InputError
from nlid.simulation.presets import get_preset

needs_netcdf = pytest.mark.skipif(
    not datatree.netcdf_available(), reason="xarray with DataTree and h5netcdf or netCDF4 are not installed"
)


@pytest.fixture(scope="module")
def one_dof():
    """10 s of paper-numerical with 2 % noise on z and a, and the posterior of its damping terms."""
    preset = get_preset("paper-numerical").with_overrides(duration=10.0)
    record = preset.simulate(5, noise=0.02, channels=("z", "a"))
    fit = nlid.identify(record, preset.model(), "rfs", mass=preset.mass)
    return record, sample_posterior(record, fit, params="damping", seed=2, bias_correction=False)


@pytest.fixture(scope="module")
def structure():
    """3dof-cubic, 6 s, noisy accelerations: the posterior of K[1,2] and C[1,1]."""
    record = get_preset("3dof-cubic").with_overrides(duration=6.0).simulate(3, noise={"a": 0.02})
    fit = nlid.identify(record, "z3^3", "rfs", mass=record.mass)
    return record, sample_posterior(record, fit, params="K[1,2], C[1,1]", seed=0, bias_correction=False)


def _draws(post, name):
    """The samples of one coefficient as (chain, draw): walkers by kept steps."""
    i = post.names.index(name)
    return post.samples[:, i].reshape(-1, post.chains.walkers).T


def _check_tree(tree, post, record):
    assert set(tree.children) == {"posterior", "sample_stats", "observed_data"}
    group = tree["posterior"]
    assert list(group.data_vars) == [datatree.variable_name(n) for n in post.names]
    for name in post.names:
        var = group[datatree.variable_name(name)]
        assert var.dims == ("chain", "draw")
        np.testing.assert_array_equal(var.values, _draws(post, name))
        assert var.attrs["units"] == post.unit(name) and var.attrs["term"] == name
    c = post.chains
    np.testing.assert_array_equal(tree["sample_stats"]["lp"].values, c.log_prob[c.burn :: c.thin].T)
    assert tree["sample_stats"].attrs["acceptance_fraction"] == pytest.approx(c.acceptance)
    observed = tree["observed_data"]
    for channel, values in record.to_dict().items():
        if channel == "t":
            np.testing.assert_array_equal(observed["time"].values, values)
        else:
            np.testing.assert_array_equal(observed[channel].values, values)
            assert observed[channel].attrs["units"] == record.units[channel]
    assert tree.attrs["credible_interval"] == datatree.CREDIBLE_LEVEL == 0.9
    assert tree.attrs["credible_interval_kind"] == "equal-tailed"
    np.testing.assert_allclose(tree.attrs["credible_interval_quantiles"], [0.05, 0.95])


@needs_netcdf
def test_one_dof_tree_round_trips_through_netcdf(one_dof, tmp_path):
    import xarray as xr

    record, post = one_dof
    tree = post.to_datatree()
    _check_tree(tree, post, record)
    assert tree["posterior"]["v*|v|"].attrs["units"] == "N*s^2/m^2"
    paths = post.save(tmp_path / "out", figures=False)
    assert tmp_path / "out" / "posterior.nc" in paths
    with xr.open_datatree(tmp_path / "out" / "posterior.nc") as back:
        back.load()
        _check_tree(back, post, record)
        assert back.attrs["method"] == "rfs"


@needs_netcdf
def test_structure_tree_round_trips_through_netcdf(structure, tmp_path):
    import xarray as xr

    record, post = structure
    tree = post.to_datatree()
    _check_tree(tree, post, record)
    assert {n: tree["posterior"][n].attrs["units"] for n in post.names} == {"K[1,2]": "N/m", "C[1,1]": "N*s/m"}
    assert set(tree["observed_data"].data_vars) == set(record.channels)
    path = datatree.write_netcdf(tree, tmp_path / "posterior.nc")
    with xr.open_datatree(path) as back:
        back.load()
        _check_tree(back, post, record)


@needs_netcdf
def test_arviz_reads_the_tree_and_its_summary_matches_nlids(one_dof, tmp_path):
    import xarray as xr

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)  # ArviZ 0.x announces its 1.0 refactor on import
        az = pytest.importorskip("arviz")
    _, post = one_dof
    path = datatree.write_netcdf(post.to_datatree(), tmp_path / "posterior.nc")
    with xr.open_datatree(path) as back:
        back.load()
        major = int(az.__version__.split(".")[0])
        if major >= 1:  # ArviZ 1.0 reads the DataTree itself
            table = az.summary(back, ci_prob=0.9, ci_kind="eti")
        else:
            table = az.summary(az.from_datatree(back), hdi_prob=0.9)
    ours = post.summary_dict()
    for name in post.names:
        # ArviZ rounds its table to the sd's leading digits: compare within the printed precision
        assert table.loc[name, "mean"] == pytest.approx(ours[name]["mean"], abs=0.1 * ours[name]["sd"])
        assert table.loc[name, "sd"] == pytest.approx(ours[name]["sd"], rel=0.1)


def test_a_missing_xarray_is_one_clear_message(one_dof, tmp_path, monkeypatch):
    """Runs with or without the extra: the absence is simulated."""
    _, post = one_dof
    monkeypatch.setattr(datatree, "_installed", lambda name: False)
    assert not datatree.netcdf_available()
    with pytest.raises(InputError, match=r"needs the optional package xarray \(pip install 'nlid\[netcdf\]'\)"):
        post.to_datatree()
    with pytest.raises(InputError, match=r"nlid\[netcdf\]"):
        post.save(tmp_path / "asked", figures=False, netcdf=True)
    assert not (tmp_path / "asked").exists()  # refused before anything is written
    paths = post.save(tmp_path / "default", figures=False)  # the default writes the rest without it
    assert {p.name for p in paths} == {"posterior_table.csv", "posterior.json", "posterior_samples.npz"}


def test_a_missing_engine_is_one_clear_message(monkeypatch):
    if importlib.util.find_spec("xarray") is None:
        pytest.skip("xarray is not installed: the message of a missing xarray comes first")
    monkeypatch.setattr(datatree, "_installed", lambda name: name == "xarray")
    with pytest.raises(InputError, match=r"h5netcdf or netCDF4 \(pip install 'nlid\[netcdf\]'\)"):
        datatree.require_netcdf()


def test_a_slash_in_a_term_is_not_a_netcdf_group():
    assert datatree.variable_name("tanh(v/0.01)") == "tanh(v\u22150.01)"
    assert datatree.variable_name("v*|v|") == "v*|v|"
