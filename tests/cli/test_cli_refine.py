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
    status, out, err = cli(
        "discover",
        str(path),
        "--declared",
        "1, z, z^2, z^3, v, v*|v|",
        "--mass",
        "0.2",
        "--method",
        "rfs",
        "--max-steps",
        "0",
        "--refine",
        "--quiet",
    )
    assert status == 0, err
    assert "refined with oe" in out and "free-run RMS error held-out" in out


def test_a_structure_record_with_estimated_derivatives_is_refined_unless_told_not_to(cli, monkeypatch, tmp_path):
    """``nlid discover`` on displacements alone refines by default (the refit stubbed: it fails, and says so);
    ``--no-refine`` does not try."""
    import json

    import nlid.discovery.structure as structure
    from nlid.errors import IdentificationError

    def stub(*args):
        raise IdentificationError("stub refiner")

    monkeypatch.setattr(structure, "_refine", stub)
    monkeypatch.setattr(structure, "_refiner", lambda: "oe")  # as when oe is installed
    preset = get_preset("3dof-cubic").with_overrides(
        duration=4.0, elements="(z2-z3)^3", coefficients={"(z2-z3)^3": 5e9}
    )
    record = preset.simulate(1, noise={"z": 0.005}, channels=("z",))
    path = tmp_path / "chain.csv"
    write_csv(record, path)
    argv = ("discover", str(path), "--declared", "(z2-z3)^3", "--max-steps", "0", "--json", "--quiet")
    for flags, tried in (((), True), (("--no-refine",), False), (("--refine",), True)):
        status, out, err = cli(*argv, *flags)
        assert status == 0, err
        result = json.loads(out)
        assert result["info"]["derivatives_measured"] is False
        assert ("stub refiner" in (result["info"]["refine_failed"] or "")) is tried
        assert result["refined"] is None and result["model"] == "declared model"
