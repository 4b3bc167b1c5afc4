"""``nlid discover --refine``: the final model refined by oe, errors before and after printed."""

from __future__ import annotations

import pluggy

import nlid_oe
import nlid_rfs
from nlid import hookspecs
from nlid.io import write_csv
from nlid.presets import get_preset
from nlid.registry import load_registry


def _registry():
    """rfs and oe registered in-process (oe's entry point may not be installed in this environment)."""
    pm = pluggy.PluginManager(hookspecs.PROJECT)
    pm.add_hookspecs(hookspecs)
    pm.register(nlid_rfs, name="rfs")
    pm.register(nlid_oe, name="oe")
    return load_registry(pm)


def test_the_command_line_refines_and_prints_both(cli, monkeypatch, tmp_path):
    """``nlid discover --refine`` (the registry made in-process: oe may not be installed here)."""
    monkeypatch.setattr("nlid.discovery.loop.default_registry", _registry)
    preset = get_preset("paper-numerical").with_overrides(duration=6.0)
    record = preset.simulate(1, noise={"z": 0.02}, channels=("z",))
    path = tmp_path / "x.csv"
    write_csv(record, path)
    status, out, err = cli("discover", str(path), "--declared", "1, z, z^2, z^3, v, v*|v|", "--mass", "0.2",
                           "--method", "rfs", "--max-steps", "0", "--refine", "--quiet")
    assert status == 0, err
    assert "refined with oe" in out and "free-run RMS error held-out" in out
