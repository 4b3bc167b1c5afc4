"""nlid compare leaves the refining identifiers (oe) out unless named, as the built-in studies do (issue 35)."""

from __future__ import annotations

import nlid
from nlid.cli.main import build_parser
from nlid.contract import methods
from nlid.contract.registry import default_registry


def test_the_refiners_are_left_out_by_default(rfs_oe_registry):
    registry = rfs_oe_registry()
    assert set(registry.names()) == {"rfs", "oe"}
    assert methods.comparison_methods(registry) == ["rfs"]


def test_every_installed_non_refiner_is_compared():
    registry = default_registry()
    chosen = methods.comparison_methods(registry)
    assert chosen and all(not getattr(registry.identifiers[n], "refines", False) for n in chosen)
    assert set(chosen) | {n for n in registry.names() if registry.identifiers[n].refines} == set(registry.names())


def test_compare_runs_the_default_methods(short_record, monkeypatch):
    monkeypatch.setattr(methods, "comparison_methods", lambda registry=None: ["rfs"])
    frame = nlid.compare(short_record, "z^3, z^2, v*|v|", mass=0.2)
    assert set(frame["method"]) == {"rfs"}


def test_the_help_says_so():
    sub = next(a for a in build_parser()._subparsers._group_actions).choices["compare"]
    text = " ".join(sub.format_help().split())
    assert "except those that refine another's fit" in text and "refining ones (oe)" in text


def test_a_structure_record_as_the_holdout_of_a_one_dof_comparison_is_refused(short_record):
    import pytest

    from nlid.errors import InputError

    structure = nlid.simulate("3dof-cubic", seed=1, duration=1.0)
    with pytest.raises(InputError, match="holdout="):
        nlid.compare(short_record, "z^3, z^2, v*|v|", mass=0.2, methods=["rfs"], holdout=structure)
