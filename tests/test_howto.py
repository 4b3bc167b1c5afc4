"""docs/howto.md runs as written: its Python blocks in order, its benchmark file read by the bench's reader."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

HOWTO = Path(__file__).resolve().parents[1] / "docs" / "howto.md"


def _blocks(language: str) -> list[str]:
    return re.findall(rf"```{language}\n(.*?)```", HOWTO.read_text(), flags=re.S)


def test_the_page_has_its_three_recipes():
    text = HOWTO.read_text()
    for title in ("## Cut a record into estimation and test parts", "## Remove a mean", "## Write a benchmark file"):
        assert title in text
    assert len(_blocks("python")) == 3 and len(_blocks("toml")) == 1


def test_the_python_blocks_run_in_order(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "rig.toml").write_text(_blocks("toml")[0])  # the page's benchmark file, as the reader saves it
    namespace: dict = {}
    for block in _blocks("python"):
        exec(compile(block, str(HOWTO), "exec"), namespace)  # noqa: S102 - the documentation's own code
    printed = capsys.readouterr().out
    assert "free run" in printed and "rig ['run2'] mm" in printed
    assert namespace["fit"].coefficients["z^3"] == pytest.approx(
        namespace["record"].meta["reference"]["coefficients"]["z^3"], rel=0.05
    )


def test_the_benchmark_file_is_complete():
    """Every key the page's file uses is read (a misspelled key would be refused), the test set's rule too."""
    from nlid.benchmarking.protocol import parse_protocol

    protocol = parse_protocol(_blocks("toml")[0], "docs/howto.md")
    assert protocol.name == "rig" and protocol.estimation_file is not None
    assert [t.name for t in protocol.tests] == ["run2"] and protocol.tests[0].file is not None
