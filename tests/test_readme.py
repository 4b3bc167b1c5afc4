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
    assert [s.effect for s in found.steps] == ["quadratic-damping", "quadratic-stiffness"]
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


# --------------------------------------------------------------------------- the command-line examples
NUMBER = re.compile(r"[-+]?\d+(?:\.\d+)?(?:e[-+]?\d+)?")


def _cli_blocks(text: str) -> list[list[tuple[str, list[str]]]]:
    """Every fenced block with ``$ nlid`` lines: [(command, expected output lines), ...] per block."""
    blocks = []
    for body in re.findall(r"```[a-z]*\n(.*?)```", text, flags=re.S):
        if "$ nlid " not in body:
            continue
        steps: list[tuple[str, list[str]]] = []
        for line in body.splitlines():
            if line.startswith("$ nlid "):
                steps.append((line[2:], []))
            elif steps:
                steps[-1][1].append(line)
        blocks.append(steps)
    return blocks


def _same_number(expected: str, actual: str) -> bool:
    """``actual`` equals ``expected`` to within one unit of the last digit ``expected`` shows."""
    mantissa, _, exponent = expected.lower().partition("e")
    decimals = len(mantissa.split(".")[1]) if "." in mantissa else 0
    unit = 10.0 ** (-decimals + (int(exponent) if exponent else 0))
    return abs(float(actual) - float(expected)) <= unit * (1 + 1e-9)


def _compare(command: str, expected: list[str], actual: list[str]) -> list[str]:
    """Differences between the README's output and the command's (numbers to their printed digits)."""
    problems = []
    if len(expected) != len(actual):
        return [f"{command}: {len(expected)} lines in the README, {len(actual)} printed:\n" + "\n".join(actual)]
    for want, got in zip(expected, actual, strict=True):
        text_want, text_got = NUMBER.split(want), NUMBER.split(got)
        nums_want, nums_got = NUMBER.findall(want), NUMBER.findall(got)
        if [" ".join(t.split()) for t in text_want] != [" ".join(t.split()) for t in text_got]:
            problems.append(f"{command}:\n  README: {want}\n  prints: {got}")
            continue
        if want.startswith("time:"):
            continue  # wall time: the machine's, not the method's
        if not all(_same_number(w, g) for w, g in zip(nums_want, nums_got, strict=True)):
            problems.append(f"{command}:\n  README: {want}\n  prints: {got}")
    return problems


def test_every_cli_block_has_commands():
    blocks = _cli_blocks(README)
    commands = [c for b in blocks for c, _ in b]
    assert any(c.startswith("nlid identify x.csv --method rfs") for c in commands)
    assert any(c.startswith("nlid discover dataset:emps") for c in commands)
    assert "--noise 0.02" in next(c for c in commands if c.startswith("nlid simulate")), "the example is noisy"
    for line in README.splitlines():
        assert 'install "nlid[' not in line, "a clone installs extras as '.[extra]'"


@pytest.mark.slow
@pytest.mark.parametrize("index", range(len(_cli_blocks(README))))
def test_cli_block_prints_what_the_readme_shows(index, tmp_path):
    """Each ``$ nlid ...`` block, run in a fresh folder, prints the README's output (numbers to their digits)."""
    import os
    import shlex
    import subprocess
    import sys

    block = _cli_blocks(README)[index]
    data = Path(os.environ.get("NLID_DATA_DIR", ""))
    if any("dataset:" in c for c, _ in block) and not (data / "emps" / "DATA_EMPS.mat").is_file():
        pytest.skip(f"measured data not found in NLID_DATA_DIR={data}")
    problems = []
    for command, expected in block:
        argv = shlex.split(command)[1:]
        proc = subprocess.run(
            [sys.executable, "-m", "nlid.cli.main", *argv], cwd=tmp_path, capture_output=True, text=True, timeout=600
        )
        assert proc.returncode == 0, f"{command}: {proc.stderr[-2000:]}"
        problems += _compare(command, expected, proc.stdout.rstrip("\n").splitlines() if proc.stdout.strip() else [])
    assert not problems, "\n".join(problems)


# --------------------------------------------------------------------------- numbers the README states
def _test_section() -> str:
    start = README.index("Install the test dependencies")
    return README[start : README.index("\n## ", start)]


@pytest.mark.slow
def test_the_stated_number_of_tests_is_the_collected_one():
    """The README's "N tests" is within 10 % of what ``pytest --collect-only`` finds (docs that cannot go stale)."""
    import subprocess
    import sys

    stated = [int(n) for n in re.findall(r"\b(\d+) tests\b", _test_section())]
    assert len(stated) == 1, f"the README's test section states {stated} test counts; one is checked"
    root = Path(__file__).resolve().parents[1]
    proc = subprocess.run(
        [sys.executable, "-m", "pytest", "--collect-only", "-q", "-n", "0", "-p", "no:cacheprovider", "tests"],
        cwd=root,
        capture_output=True,
        text=True,
        timeout=600,
    )
    found = re.search(r"^(\d+) tests? collected", proc.stdout, re.M)
    assert found, proc.stdout[-2000:] + proc.stderr[-2000:]
    collected = int(found.group(1))
    assert abs(stated[0] - collected) <= 0.1 * collected, (
        f"the README says {stated[0]} tests, pytest collects {collected}: update README.md"
    )


def test_dataset_lines_say_what_nlid_data_says():
    """Each benchmark's layout line names its files, and says "no loader yet" exactly when ``nlid data`` does."""
    from nlid.data.datasets import BENCHMARKS

    section = _section("Measured data")
    layout = re.search(r"```\n(\$NLID_DATA_DIR/.*?)```", section, flags=re.S)
    assert layout, "the layout block of the Measured data section"
    lines = {line.split("/")[1]: line for line in layout.group(1).splitlines() if line.strip()}
    for name, bench in BENCHMARKS.items():
        folders = {f.path.split("/")[0] for f in bench.files}
        assert len(folders) == 1, name
        folder = folders.pop()
        assert folder in lines, f"README lists no $NLID_DATA_DIR/{folder}/ line for {name}"
        line = lines[folder]
        for f in bench.files:
            assert f.path.split("/", 1)[1] in line, f"README's {folder} line lacks {f.path}"
        assert ("no loader yet" in line) is (not bench.loader), f"README's {folder} line: {line!r}"
