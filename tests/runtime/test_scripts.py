"""Scripts as well as notebooks (issue 23 item 6): no ``__main__`` guard, stdin scripts, non-zero exit on failure.

nlid's children never import the user's ``__main__`` (their main module is
nlid's own), so a script's top-level code runs once, whichever start method.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

SCRIPT = textwrap.dedent(
    """
    from pathlib import Path

    import nlid

    print("TOP OF THE SCRIPT")
    Path("tiny.toml").write_text('''
    [study]
    name = "tiny"
    repetitions = 1
    identifiers = ["rfs"]

    [[datasets]]
    preset = "paper-numerical"
    overrides = { duration = 2 }
    ''')
    outcome = nlid.run_study("tiny.toml", out="tiny-study", jobs=1, progress=False)
    record = nlid.simulate("paper-numerical", seed=0, channels="z,a", duration=2)
    fit = nlid.identify(record, "z^3, z^2, v*|v|", method="rfs", mass=0.2, timeout=120)
    print("DONE", outcome.executed, fit.method)
    """
)


def _env() -> dict[str, str]:
    return dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))


def _readme_python() -> str:
    readme = (ROOT / "README.md").read_text()
    start = readme.index("## Python\n")
    end = readme.find("\n## ", start + 1)
    return "\n".join(re.findall(r"```python\n(.*?)```", readme[start : end if end > 0 else None], flags=re.S))


@pytest.mark.slow
def test_the_readme_python_section_runs_as_a_script_and_prints_once(tmp_path):
    (tmp_path / "readme.py").write_text(_readme_python())
    proc = subprocess.run(
        [sys.executable, "readme.py"], cwd=tmp_path, env=_env(), capture_output=True, text=True, timeout=900
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert proc.stdout.count("held-out epsilon") == 1, proc.stdout
    assert proc.stdout.count("['quadratic-damping', 'quadratic-stiffness']") == 1
    assert proc.stderr.count("nlid study small: 4 runs") == 1, proc.stderr
    assert "Traceback" not in proc.stderr and "FolderBusyError" not in proc.stderr
    assert (tmp_path / "small-study" / "results.csv").is_file()


@pytest.mark.slow
@pytest.mark.parametrize("how", ["file", "stdin"])
def test_a_script_without_a_main_guard_runs_studies_and_isolated_identifications(tmp_path, how):
    (tmp_path / "script.py").write_text(SCRIPT)
    with open(tmp_path / "script.py") as stdin:
        cmd = [sys.executable, "script.py"] if how == "file" else [sys.executable, "-"]
        proc = subprocess.run(cmd, cwd=tmp_path, env=_env(), stdin=stdin, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert proc.stdout.splitlines() == ["TOP OF THE SCRIPT", "DONE 1 rfs"], proc.stdout


def test_a_script_whose_runs_cannot_start_exits_non_zero(tmp_path):
    (tmp_path / "script.py").write_text(SCRIPT)
    env = dict(_env(), NLID_START_METHOD="threads")
    proc = subprocess.run([sys.executable, "script.py"], cwd=tmp_path, env=env, capture_output=True, text=True)
    assert proc.returncode != 0
    assert "NLID_START_METHOD='threads' is not a start method" in proc.stderr.strip().splitlines()[-1]
