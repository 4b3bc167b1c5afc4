"""The scripts in examples/ run to completion (in a temporary folder) and say what the docs say they do."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _run(name: str, cwd: Path) -> str:
    env = dict(os.environ)
    env.setdefault("MPLBACKEND", "Agg")
    proc = subprocess.run(
        [sys.executable, str(EXAMPLES / name)], cwd=cwd, env=env, capture_output=True, text=True, timeout=600
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    return proc.stdout


def test_every_example_is_tested():
    expected = {"simulate_identify_compare.py", "own_csv.py", "emps.py", "structure.py"}
    assert {p.name for p in EXAMPLES.glob("*.py")} == expected


@pytest.mark.slow
def test_simulate_identify_compare(tmp_path):
    out = _run("simulate_identify_compare.py", tmp_path)
    assert "method: nsi-ip" in out and "posterior of 2 coefficient(s)" in out
    assert (tmp_path / "example-output" / "compare.csv").is_file()
    assert (tmp_path / "example-output" / "fit.png").stat().st_size > 10_000


def test_own_csv(tmp_path):
    out = _run("own_csv.py", tmp_path)
    assert "sign(v)*|px(z)|" in out and "px(z) roots" in out


def test_emps(tmp_path):
    out = _run("emps.py", tmp_path)
    if "EMPS data not available" in out:
        pytest.skip("measured data not found (NLID_DATA_DIR)")
    assert "+ coulomb: sign(v)" in out


def test_structure(tmp_path):
    out = _run("structure.py", tmp_path)
    assert "record: 3 DOFs" in out and "nsi-ip: z3^3" in out and "rfs: z3^3" in out
    # the cubic element within 1 % of the truth for both methods, as docs/structures.md says
    errors = [float(line.split("(")[1].split(" %")[0]) for line in out.splitlines() if ": z3^3 = " in line]
    assert len(errors) == 2 and all(abs(e) < 1.0 for e in errors), out
    assert (tmp_path / "example-output" / "structure_frf.png").stat().st_size > 10_000
