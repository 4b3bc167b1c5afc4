"""``nlid --help`` starts fast: no heavy module is imported to print help (issue 14).

The time itself is measured by ``benchmarks/bench_import.py``; the test checks
the cause (what ends up in ``sys.modules``) in a fresh interpreter, which is
steady under any machine load.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

import nlid

#: Imported only by the code that uses them, never to print help.
HEAVY = ("numpy", "scipy", "pandas", "matplotlib", "numba", "emcee", "pysindy", "sklearn", "dask", "pluggy")

_PROBE = """
import json, sys
from nlid.cli.main import main
try:
    main({argv!r})
except SystemExit:
    pass
sys.stdout.write("\\n" + json.dumps(sorted(m for m in {heavy!r} if m in sys.modules)))
"""


def _imported(argv: list[str]) -> list[str]:
    root = Path(nlid.__file__).resolve().parent.parent
    path = os.pathsep.join([str(root), str(root / "plugins"), os.environ.get("PYTHONPATH", "")])
    out = subprocess.run(
        [sys.executable, "-c", _PROBE.format(argv=argv, heavy=HEAVY)],
        capture_output=True,
        text=True,
        check=True,
        env={**os.environ, "PYTHONPATH": path},
        timeout=60,
    )
    return json.loads(out.stdout.splitlines()[-1])


@pytest.mark.parametrize(
    "argv",
    [["--help"], ["--version"], ["study", "--help"], ["identify", "--help"], ["simulate", "--help"]],
    ids=" ".join,
)
def test_help_imports_no_heavy_module(argv):
    assert _imported(argv) == []


def test_import_nlid_imports_no_heavy_module():
    root = Path(nlid.__file__).resolve().parent.parent
    code = f"import sys, nlid; print([m for m in {HEAVY!r} if m in sys.modules])"
    out = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        check=True,
        env={**os.environ, "PYTHONPATH": str(root)},
        timeout=60,
    )
    assert out.stdout.strip() == "[]"
