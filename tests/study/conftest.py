"""Test identifiers for studies, registered from outside through entry points.

As in tests/contract/test_registry.py, a module and a ``*.dist-info`` folder with an
``entry_points.txt`` are written to a temporary folder on ``sys.path``: to
``importlib.metadata`` (and to the study's worker processes, which get the
parent's ``sys.path``) that is an installed distribution.
"""

from __future__ import annotations

import pytest
from plugin_dist import write_distribution

from nlid.contract.registry import load_registry

PLUGINS = '''
import os
import time

import numpy as np

from nlid.plugin import Estimate, Identifier, Option, hookimpl


class Echo(Identifier):
    """Returns the true coefficients times a scale; sleeps first if asked."""

    name = "echo"
    summary = "returns the true coefficients (test plugin)"
    options = (
        Option("scale", "float", 1.0, "multiplies every coefficient"),
        Option("sleep", "float", 0.0, "seconds to sleep first", minimum=0.0),
    )
    needs_mass = True

    def identify(self, record, model, *, mass=None):
        time.sleep(self.settings["sleep"])
        truth = record.meta["truth"]["coefficients"]
        coeffs = {n: self.settings["scale"] * truth.get(n, 0.0) for n in model.names}
        f = np.linspace(1.0, 50.0, 64)
        w = 2 * np.pi * f
        frf = 1.0 / (-mass * w**2 + 1j * w * 1.0 + 700.0)
        arrays = {
            "singular_values": np.logspace(2, -3, 12),
            "frf_frequency_hz": f,
            "frf": frf,
            "coef_frequency_hz": f,
            **{f"coef_spectrum:{n}": np.full(64, coeffs[n]) + 0.01j * f for n in model.names if n != "1"},
        }
        return Estimate(coefficients=coeffs, arrays=arrays)


class Crash(Identifier):
    name = "crash"
    summary = "always raises (test plugin)"
    needs_mass = False

    def identify(self, record, model, *, mass=None):
        raise RuntimeError("deliberate failure in a test plugin")


class Hang(Identifier):
    name = "hang"
    summary = "never returns (test plugin)"
    needs_mass = False

    def identify(self, record, model, *, mass=None):
        while True:
            time.sleep(1.0)


class Die(Identifier):
    name = "die"
    summary = "kills its own process (test plugin)"
    needs_mass = False

    def identify(self, record, model, *, mass=None):
        os._exit(3)


@hookimpl
def nlid_identifiers():
    return [Echo, Crash, Hang, Die]
'''


@pytest.fixture(scope="module")
def plugin_path(tmp_path_factory):
    """A folder holding the test plugins as an installed distribution, on sys.path."""
    folder = tmp_path_factory.mktemp("study-plugins")
    write_distribution(
        folder,
        "nlid-study-test-plugins",
        {"nlid_study_test_plugins": PLUGINS},
        {"study-test": "nlid_study_test_plugins"},
    )
    with pytest.MonkeyPatch.context() as mp:
        mp.syspath_prepend(str(folder))
        yield folder


@pytest.fixture(scope="module")
def registry(plugin_path):
    """The registry with rfs and the test plugins."""
    reg = load_registry()
    assert {"rfs", "echo", "crash", "hang", "die"} <= set(reg.names()), reg.failures
    return reg


@pytest.fixture(scope="session")
def small_study():
    """A function giving the TOML text of a small paper-numerical study."""
    return _small_study


def _small_study(identifiers='["rfs", "echo"]', repetitions=2, duration=6.0, timeout=60, extra=""):
    """TOML text of a small paper-numerical study."""
    return f"""
[study]
name = "small"
description = "a small test study"
seed = 7
repetitions = {repetitions}
timeout = {timeout}
identifiers = {identifiers}

[[datasets]]
name = "short"
preset = "paper-numerical"
overrides = {{ duration = {duration} }}
noise = {{ z = 0.02 }}
terms = "z^3, z^2, v*|v|"
{extra}
"""
