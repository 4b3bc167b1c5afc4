"""A structure's mass matrix: one reading for identify and discover (an array, text, a file, or the sidecar's)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import nlid
from nlid.base.validate import parse_mass
from nlid.cli.main import main
from nlid.data.io import write_csv
from nlid.errors import InputError
from nlid.model.structure import structure_mass
from nlid.simulation.presets import get_preset

M = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 2.0]]


@pytest.mark.parametrize(
    "text, expected",
    [
        ("0.2", 0.2),
        ("estimate", "estimate"),
        ("[[1,0,0],[0,1,0],[0,0,2]]", M),
        ("[[1., 0, 0], [0, 1, 0], [0, 0, 2e0]]", M),
        ("diag(1, 1, 2)", M),
        ("[1, 1, 2]", [1, 1, 2]),
    ],
)
def test_parse_mass_reads_numbers_literals_and_diag(text, expected):
    assert parse_mass(text) == expected


@pytest.mark.parametrize("text", ["abc", "diag()", "[[1,0],[0,__import__('os')]]", "[[1, 2]", "missing.npy"])
def test_parse_mass_refuses_in_one_line(text, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(InputError, match="mass=") as info:
        parse_mass(text)
    assert "\n" not in str(info.value)


def test_parse_mass_reads_files_but_no_pickle(tmp_path):
    (tmp_path / "m.csv").write_text("1,0,0\n0,1,0\n0,0,2\n")
    (tmp_path / "m.txt").write_text("1 0 0\n0 1 0\n0 0 2\n")
    (tmp_path / "m.json").write_text(json.dumps({"mass": M}))
    np.save(tmp_path / "m.npy", np.array(M))
    for name in ("m.csv", "m.txt", "m.json", "m.npy"):
        assert np.array_equal(parse_mass(str(tmp_path / name)), M), name
    np.save(tmp_path / "objects.npy", np.array([{"a": 1}], dtype=object), allow_pickle=True)
    with pytest.raises(InputError, match="is not a matrix of numbers"):
        parse_mass(str(tmp_path / "objects.npy"))


@pytest.fixture(scope="module")
def chain():
    return get_preset("3dof-cubic").with_overrides(duration=3.0, M=tuple(map(tuple, M))).simulate(0)


@pytest.mark.parametrize(
    "value, message",
    [
        ("diag(1, 2)", "3x3 matrix"),
        ([[1, 0.5, 0], [0, 1, 0], [0, 0, 2]], "symmetric"),
        ([[1, 2, 0], [2, 1, 0], [0, 0, 2]], "positive definite"),
        (-1.0, "3x3 matrix"),
    ],
)
def test_structure_mass_is_checked_at_the_boundary(chain, value, message):
    with pytest.raises(InputError, match=f"mass= must be .*{message}"):
        structure_mass(value, chain)


def test_structure_mass_given_sidecar_or_estimated(chain):
    assert np.array_equal(structure_mass(None, chain), M)  # the record's meta['mass']
    assert np.array_equal(structure_mass("diag(1,1,2)", chain), M)
    assert np.array_equal(structure_mass(np.array([1.0, 1.0, 2.0]), chain), M)  # a vector is lumped
    assert structure_mass("estimate", chain) is None
    assert structure_mass(None, chain.with_meta(mass=None)) is None


def test_identify_takes_the_sidecar_mass_as_discover_does(chain, tmp_path, capsys):
    path = write_csv(chain, tmp_path / "chain.csv")
    assert json.loads((tmp_path / "chain.csv.meta.json").read_text())["mass"] == M
    fit = nlid.identify(str(path), "z3^3", "rfs")
    assert not fit.mass_estimated and np.array_equal(fit.M, M)
    assert main(["identify", str(path), "--method", "rfs", "--terms", "z3^3", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["structure"]["M"] == M and out["mass_estimated"] is False
    assert main(["identify", str(path), "--method", "rfs", "--terms", "z3^3", "--mass", "estimate", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["mass_estimated"] is True and np.allclose(out["structure"]["M"], M, rtol=1e-4, atol=1e-4)
    status = main(["identify", str(path), "--method", "rfs", "--terms", "z3^3", "--mass", "diag(1,2)"])
    err = capsys.readouterr().err
    assert status == 2 and "--mass must be an 3x3 matrix" in err and len(err.strip().splitlines()) == 1
