"""The benchmark sections of the docs are generated from the committed nlid bench output (docs/_data)."""

from __future__ import annotations

from pathlib import Path

import pytest

from nlid import InputError
from nlid.cli.bench_docs import render_docs, replace_block

DOCS = Path(__file__).resolve().parents[2] / "docs"


def test_committed_docs_equal_the_generators_output():
    pages = render_docs(DOCS, write=False)
    assert {p.name for p in pages} == {"results.md", "discover.md"}
    for path, text in pages.items():
        assert path.read_text(encoding="utf-8") == text, f"{path.name} differs: run nlid bench --render-docs"


def test_generated_pages_carry_the_leaderboard_and_rules():
    text = (DOCS / "results.md").read_text(encoding="utf-8")
    assert "Rule: `window:50`" in text and "Rule: `periodic:8192`" in text
    assert "PNLSS, degrees 3-5-7 (217 parameters)" in text  # the published row beside nlid's on the multisine
    discover = (DOCS / "discover.md").read_text(encoding="utf-8")
    assert "--holdout dataset:silverbox:arrow" not in discover  # no structure chosen on a test set


def test_replace_block():
    page = "a\n<!-- BEGIN nlid bench: x (generated ...) -->\nold\n<!-- END nlid bench: x -->\nb\n"
    new = replace_block(page, "x", "new body")
    assert (
        new.startswith("a\n<!-- BEGIN nlid bench: x (generated")
        and "\nnew body\n<!-- END nlid bench: x -->\nb\n" in new
    )
    assert replace_block(new, "x", "new body") == new
    with pytest.raises(InputError, match="has no generated block 'y'"):
        replace_block(page, "y", "z")
