"""Shared fixtures: simulated presets (built once per session) and the data folder; parallel runs.

``python -m pytest`` without paths runs the whole suite on every core when
pytest-xdist is installed (``-n auto``, added by :func:`pytest_cmdline_main`);
``-n 0`` (or ``-p no:xdist``) runs it serially, and a run of chosen paths
stays serial unless ``-n`` is given.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from nlid.simulation.presets import get_preset

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_DATA = (ROOT / ".." / "shared" / "data").resolve()


@pytest.hookimpl(tryfirst=True)
def pytest_cmdline_main(config: pytest.Config) -> None:
    """``-n auto`` for the whole suite when pytest-xdist is installed and ``-n`` was not given."""
    if (
        config.pluginmanager.hasplugin("xdist")
        and getattr(config.option, "numprocesses", None) is None
        and not hasattr(config, "workerinput")
        and not os.environ.get("PYTEST_XDIST_WORKER")
        and config.args_source == pytest.Config.ArgsSource.TESTPATHS
        and not config.getoption("usepdb", False)
    ):
        config.option.numprocesses = "auto"


# The measured benchmarks live outside the repository; tests default to ../shared/data.
os.environ.setdefault("NLID_DATA_DIR", str(DEFAULT_DATA))


@pytest.fixture(scope="session")
def data_dir() -> Path:
    """The folder with the measured records; skips when it is absent."""
    path = Path(os.environ["NLID_DATA_DIR"])
    if not (path / "emps" / "DATA_EMPS.mat").is_file():
        pytest.skip(f"measured data not found in NLID_DATA_DIR={path}")
    return path


@pytest.fixture(scope="session")
def numerical():
    """The paper-numerical preset."""
    return get_preset("paper-numerical")


@pytest.fixture(scope="session")
def exact_record(numerical):
    """paper-numerical, seed 0, noise-free, exact v and a."""
    return numerical.simulate(0, channels=("z", "v", "a"))


@pytest.fixture(scope="session")
def short_record(numerical):
    """10 s of paper-numerical, seed 1, noise-free, exact v and a."""
    return numerical.with_overrides(duration=10.0).simulate(1, channels=("z", "v", "a"))


@pytest.fixture(scope="session")
def rfs_oe_registry():
    """A function making a registry of rfs and oe registered in-process (no installed entry point needed)."""
    import pluggy

    import nlid_oe
    import nlid_rfs
    from nlid.contract import hookspecs
    from nlid.contract.registry import load_registry

    def make():
        pm = pluggy.PluginManager(hookspecs.PROJECT)
        pm.add_hookspecs(hookspecs)
        pm.register(nlid_rfs, name="rfs")
        pm.register(nlid_oe, name="oe")
        return load_registry(pm)

    return make


# Structure records simulated once per session (short, so the suite stays fast): the structures' tests in
# tests/dataio, tests/plugins and tests/study use them.
@pytest.fixture(scope="session")
def chain():
    """The 3dof-cubic preset, 8 s."""
    return get_preset("3dof-cubic").with_overrides(duration=8.0)


@pytest.fixture(scope="session")
def chain_record(chain):
    """3dof-cubic, seed 0, noise-free, exact v and a."""
    return chain.simulate(0)


@pytest.fixture(scope="session")
def well():
    """The 2dof-double-well preset, 8 s."""
    return get_preset("2dof-double-well").with_overrides(duration=8.0)


@pytest.fixture(scope="session")
def well_record(well):
    """2dof-double-well, seed 0, noise-free, exact v and a."""
    return well.simulate(0)
