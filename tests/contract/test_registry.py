"""Plugin discovery through entry points: built-ins, outside plugins, broken plugins.

Plugins from outside the package are made visible without installing anything:
each test writes a module and a ``*.dist-info`` folder with an
``entry_points.txt`` into a temporary directory on ``sys.path``, which is
exactly what an installed distribution looks like to ``importlib.metadata``.
"""

import pytest
from plugin_dist import write_distribution

from nlid import InputError, PluginError, identify
from nlid.contract.registry import load_registry

GOOD = """
import numpy as np
from nlid.plugin import Estimate, Identifier, Option, hookimpl


class Echo(Identifier):
    name = "{name}"
    summary = "returns the true coefficients (test plugin)"
    options = (Option("scale", "float", 1.0, "multiplies every coefficient"),)
    needs_mass = True

    def identify(self, record, model, *, mass=None):
        truth = record.meta["truth"]["coefficients"]
        coeffs = {{n: self.settings["scale"] * truth[n] for n in model.names}}
        return Estimate(coefficients=coeffs)


@hookimpl
def nlid_identifiers():
    return [Echo]
"""


@pytest.fixture
def make_plugin(tmp_path, monkeypatch):
    """Write a plugin module + dist-info under tmp_path and put it on sys.path."""
    monkeypatch.syspath_prepend(str(tmp_path))

    def make(dist: str, entry: str, module: str, source: str) -> None:
        write_distribution(tmp_path, dist, {module: source}, {entry: module})

    return make


def test_builtin_rfs_is_discovered_through_its_entry_point():
    reg = load_registry()
    assert "rfs" in reg.names() and reg.plugins["rfs"] == "rfs"
    assert reg.get("rfs").__module__.startswith("nlid_rfs")


def test_outside_plugin_is_discovered_and_runs(make_plugin, short_record):
    make_plugin("echo-plugin", "echo", "nlid_test_echo", GOOD.format(name="echo"))
    reg = load_registry()
    assert "echo" in reg.names() and reg.plugins["echo"] == "echo"
    res = identify(short_record, "z^3,z^2,v*|v|", "echo", mass=0.2, options={"scale": "2"}, registry=reg)
    assert res.coefficients["z^3"] == 2e6
    with pytest.raises(InputError, match="unknown option 'scal' \\(did you mean 'scale'\\?\\)"):
        reg.create("echo", {"scal": 1})
    with pytest.raises(InputError, match="cannot estimate the mass"):
        identify(short_record, "z^3", "echo", registry=reg)


def test_broken_plugins_are_reported_and_do_not_take_others_down(make_plugin):
    make_plugin("good-plugin", "echo", "nlid_test_good", GOOD.format(name="echo"))
    make_plugin("import-broken", "broken", "nlid_test_broken", "raise ImportError('missing dependency xyz')\n")
    make_plugin(
        "hook-raises",
        "raiser",
        "nlid_test_raiser",
        "from nlid import hookimpl\n@hookimpl\ndef nlid_identifiers():\n    raise RuntimeError('boom')\n",
    )
    make_plugin(
        "misspelled",
        "typo",
        "nlid_test_typo",
        "from nlid import hookimpl\n@hookimpl\ndef nlid_identifierz():\n    return []\n",
    )
    make_plugin(
        "not-a-class",
        "bogus",
        "nlid_test_bogus",
        "from nlid import hookimpl\n@hookimpl\ndef nlid_identifiers():\n    return ['rfs']\n",
    )
    make_plugin("dup", "rfs-again", "nlid_test_dup", GOOD.format(name="rfs"))
    reg = load_registry()
    assert {"rfs", "echo"} <= set(reg.names())
    assert "missing dependency xyz" in reg.failures["broken"]
    assert "RuntimeError: boom" in reg.failures["raiser"]
    assert "nlid_identifierz" in reg.failures["typo"]
    assert "expected an identifier class" in reg.failures["bogus"]
    assert "already provided by plugin 'rfs'" in reg.failures["rfs-again"]
    with pytest.raises(PluginError, match="installed but unusable.*missing dependency xyz"):
        reg.get("broken")


def test_plugin_that_raises_during_identification_is_named(make_plugin, short_record):
    make_plugin(
        "crashy",
        "crashy",
        "nlid_test_crashy",
        GOOD.format(name="crashy").replace("truth = record", "1 / 0\n        truth = record"),
    )
    reg = load_registry()
    with pytest.raises(PluginError, match="identifier 'crashy' raised ZeroDivisionError"):
        identify(short_record, "z^3", "crashy", mass=0.2, registry=reg)


def test_unknown_method_suggests():
    with pytest.raises(InputError, match="unknown method 'rsf' \\(did you mean 'rfs'\\?\\)"):
        load_registry().get("rsf")
