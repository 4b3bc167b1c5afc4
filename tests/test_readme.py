"""The README's Python examples run as written, and its example plugin passes the compliance checks."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from nlid.testing import check_identifier

README = (Path(__file__).resolve().parents[1] / "README.md").read_text()


def _section(title: str) -> str:
    start = README.index(f"## {title}\n")
    end = README.find("\n## ", start + 1)
    return README[start : end if end > 0 else None]


def _python_blocks(text: str) -> list[str]:
    return re.findall(r"```python\n(.*?)```", text, flags=re.S)


@pytest.mark.slow
def test_python_section_runs_as_written(tmp_path, monkeypatch):
    blocks = _python_blocks(_section("Python"))
    assert len(blocks) >= 3
    monkeypatch.chdir(tmp_path)
    namespace: dict = {"__name__": "readme"}
    for block in blocks:
        exec(compile(block, "README.md", "exec"), namespace)  # noqa: S102 - our own documentation
    # the claims the text makes
    found, fit, same = namespace["found"], namespace["fit"], namespace["same"]
    assert [s.effect for s in found.steps] == ["quadratic-stiffness", "quadratic-damping"]
    assert same.terms == fit.terms and same.method == "rfs"
    assert {"load", "simulate", "identify", "compare", "posterior", "discover", "run_study"} <= {
        m for m in re.findall(r"nlid\.(\w+)\(", _section("Python"))
    }
    assert (tmp_path / "small-study" / "results.csv").is_file()
    assert fit.method == "rfs"


def test_example_plugin_passes_the_compliance_checks():
    blocks = [b for b in _python_blocks(_section("Writing an identifier plugin")) if "class MyMethod" in b]
    assert len(blocks) == 1
    namespace: dict = {"__name__": "my_package.plugin"}
    exec(compile(blocks[0], "README.md", "exec"), namespace)  # noqa: S102
    check_identifier(namespace["MyMethod"], accuracy=1e-3)
