"""The built-in studies ship inside the package, so every kind of install finds them (issue 18, group 7).

``studies/*.toml`` at the top of the repository are the source; ``nlid/studies/*.toml``
are the copies that ship as package data (read with ``importlib.resources``). A copy
is the simplest scheme that works with every build backend and installer (no build
step to run or to forget); this test fails as soon as the two differ.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from nlid.study import builtin_studies

ROOT = Path(__file__).resolve().parents[1]


def test_package_studies_are_identical_copies_of_the_repository_studies():
    source = {p.name: p.read_bytes() for p in sorted((ROOT / "studies").glob("*.toml"))}
    shipped = {p.name: p.read_bytes() for p in sorted((ROOT / "nlid" / "studies").glob("*.toml"))}
    assert source, "no studies/*.toml"
    assert sorted(shipped) == sorted(source), "run: cp studies/*.toml nlid/studies/ (and remove stale copies)"
    different = [name for name in source if shipped[name] != source[name]]
    assert not different, f"nlid/studies differ from studies/ for {different}: cp studies/*.toml nlid/studies/"


def test_builtin_studies_are_found_as_package_data():
    studies = builtin_studies()
    assert {"paper-numerical", "noise-sweep", "paper-experimental", "emps", "silverbox"} <= set(studies)
    for path in studies.values():
        assert path.parent == ROOT / "nlid" / "studies"


@pytest.mark.slow
def test_pip_install_target_lists_the_builtin_studies(tmp_path):
    """``pip install --target DIR .`` then ``PYTHONPATH=DIR DIR/bin/nlid study list``."""
    src = tmp_path / "src"
    src.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / name, src / name)
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", "*.egg-info")
    for name in ("nlid", "plugins", "studies"):
        shutil.copytree(ROOT / name, src / name, ignore=ignore)
    target = tmp_path / "target"
    pip = [sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--target", str(target), str(src)]
    try:
        import wheel  # noqa: F401 - the build needs it without isolation

        pip.insert(4, "--no-build-isolation")
    except ImportError:
        pass  # an isolated build fetches setuptools and wheel
    built = subprocess.run(pip, capture_output=True, text=True, timeout=600)
    assert built.returncode == 0, built.stderr[-3000:]
    assert sorted(p.name for p in (target / "nlid" / "studies").glob("*.toml")) == sorted(
        p.name for p in (ROOT / "studies").glob("*.toml")
    )
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["PYTHONPATH"] = str(target)
    where = subprocess.run(
        [sys.executable, "-c", "import nlid; print(nlid.__file__)"],
        env=env,
        capture_output=True,
        text=True,
        cwd=tmp_path,
    )
    assert where.stdout.strip().startswith(str(target)), where.stdout + where.stderr
    listed = subprocess.run(
        [str(target / "bin" / "nlid"), "study", "list"],
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
        cwd=tmp_path,
    )
    assert listed.returncode == 0, listed.stderr
    names = [line.split()[0] for line in listed.stdout.splitlines() if line.strip()]
    assert {"paper-numerical", "noise-sweep", "paper-experimental", "emps", "silverbox"} <= set(names), listed.stdout
    ran = subprocess.run(
        [str(target / "bin" / "nlid"), "study", "run", "paper-numerical", "--out", str(tmp_path / "x"), "--jobs", "0"],
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
        cwd=tmp_path,
    )
    assert "unknown study" not in ran.stderr, ran.stderr  # found; refused only for --jobs 0
    assert ran.returncode == 2 and "jobs" in ran.stderr
