"""Structure records simulated once per session (short, so the suite stays fast)."""

from __future__ import annotations

import pytest

from nlid.simulation.presets import get_preset


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
