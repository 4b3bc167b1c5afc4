"""Docs that contradicted each other or the code (issue 35, item 5): each claim checked against its source."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pytest

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
_NUMBER_WORDS = {3: "Three", 4: "Four", 5: "Five", 6: "Six", 7: "Seven"}


def _entry_points() -> list[str]:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    return list(project["entry-points"]["nlid.identifiers"])


def test_methods_page_counts_the_identifiers_that_ship():
    names = _entry_points()
    text = (DOCS / "methods.md").read_text()
    assert text.splitlines()[2].startswith(f"{_NUMBER_WORDS[len(names)]} identifiers ship with nlid.")
    for name in names:  # each in the decision table
        assert f"**`{name}`**" in text, name


def test_index_says_structures_are_in_scope():
    first = (DOCS / "index.md").read_text().split("\n\n")[1]
    assert "single-degree-of-freedom" not in first and "several" in first and "structures.md" in first


def test_rfs_standard_errors_are_described_as_the_code_computes_them():
    """rfs reports batch-means sandwich errors (plugins/nlid_rfs); no page or report calls them independent."""
    source = (ROOT / "plugins" / "nlid_rfs" / "identifier.py").read_text()
    assert "sandwich" in source
    report = (ROOT / "nlid" / "discovery" / "report.py").read_text()
    footnote = re.search(r"Standard errors are the identifier's.*?no posterior was available", report, re.S)
    assert footnote and "sandwich" in footnote.group(0) and "independent" not in footnote.group(0)
    for page in ("discover.md", "rfs.md"):
        text = " ".join((DOCS / page).read_text().split())
        claim = re.search(r"Standard errors in the report are the identifier's \(rfs: [^)]*\)", text) or re.search(
            r"`result.standard_errors` are \*\*batch-means sandwich\*\*", text
        )
        assert claim and "optimistic" not in claim.group(0), page


def test_data_page_names_the_loader_of_every_benchmark():
    from nlid.data import names

    text = (DOCS / "data.md").read_text()
    assert "none yet" not in text and "no loader" not in text
    for spelling in names.spellings():
        assert f"`{spelling}`" in text, spelling


_FIGURE = re.compile(r"(\d+(?:\.\d+)?(?:e-?\d+)?(?:-\d+(?:\.\d+)?)?) ?(mV|mm|m)\b")


def _unsourced() -> list[tuple[str, str]]:
    """(figure, benchmark) of every figure a built-in benchmark file lists as without a source."""
    out = []
    for path in sorted((ROOT / "nlid" / "benchmarking" / "protocols").glob("*.toml")):
        for entry in tomllib.loads(path.read_text()).get("not_comparable", []):
            if "source" in entry["why"]:
                out += [(" ".join(m.groups()), path.stem) for m in _FIGURE.finditer(entry["what"])]
    return out


def test_the_unsourced_figures_exist():
    assert len(_unsourced()) >= 3  # 14 mV, 1 mV, 0.96-2.7 mV, 2e-4 m


@pytest.mark.parametrize("figure", sorted({f for f, _ in _unsourced()}))
def test_no_unsourced_figure_is_called_published(figure):
    """A figure the leaderboard says has no source is never quoted as published (docs, README, study files)."""
    number, unit = figure.split(" ")
    pattern = re.compile(rf"(?<![\d.]){re.escape(number)} ?{unit}\b")
    files = [ROOT / "README.md", *DOCS.glob("*.md"), *(ROOT / "studies").glob("*.toml")]
    for path in files:
        # a paragraph (or a block of comment lines) that says "published" must not quote it, unless it says it is
        # unsourced
        text = path.read_text()
        blocks = re.split(r"\n\s*\n|\n(?!#)", text) if path.suffix == ".toml" else text.split("\n\n")
        for block in blocks:
            if "published" in block and pattern.search(block):
                assert "no source" in block or "no published source" in block, (path.name, figure, block[:300])


def test_the_bouc_wen_record_quotes_only_listed_published_figures():
    """The record's metadata quotes the leaderboard's figures (to their 3 digits), no unsourced one."""
    from nlid.benchmarking.protocol import load_protocol
    from nlid.data.datasets import BOUC_WEN_REFERENCE

    listed = [p.rmse for p in load_protocol("bouc-wen").published]
    for name, value in BOUC_WEN_REFERENCE["published_rms_error_m"].items():
        assert any(abs(value - x) <= 0.005 * x for x in listed), name
