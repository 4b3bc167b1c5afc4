"""``nlid discover --refine``: the final model refined by oe, errors before and after printed."""

from __future__ import annotations

from nlid.data.io import write_csv
from nlid.simulation.presets import get_preset


def test_the_command_line_refines_and_prints_both(cli, monkeypatch, tmp_path, rfs_oe_registry):
    """``nlid discover --refine`` (the registry made in-process: oe may not be installed here)."""
    monkeypatch.setattr("nlid.discovery.search.default_registry", rfs_oe_registry)
    preset = get_preset("paper-numerical").with_overrides(duration=6.0)
    record = preset.simulate(1, noise={"z": 0.02}, channels=("z",))
    path = tmp_path / "x.csv"
    write_csv(record, path)
    status, out, err = cli("discover", str(path), "--declared", "1, z, z^2, z^3, v, v*|v|", "--mass", "0.2",
                           "--method", "rfs", "--max-steps", "0", "--refine", "--quiet")
    assert status == 0, err
    assert "refined with oe" in out and "free-run RMS error held-out" in out
