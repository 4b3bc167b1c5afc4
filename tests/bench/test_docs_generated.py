"""The benchmark sections of the docs are generated from the committed nlid bench output (docs/_data)."""

from __future__ import annotations

from pathlib import Path

import pytest

from nlid import InputError
from nlid.cli.bench_docs import figures_outside_blocks, render_docs, replace_block

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"


def test_committed_docs_equal_the_generators_output():
    pages = render_docs(DOCS, write=False)
    assert {p.name for p in pages} == {"results.md", "discover.md", "data.md", "README.md"}
    for path, text in pages.items():
        assert path.read_text(encoding="utf-8") == text, f"{path.name} differs: run nlid bench --render-docs"


@pytest.mark.parametrize("page", [ROOT / "README.md", DOCS / "data.md"])
def test_readme_and_data_page_quote_no_figure_nlid_bench_did_not_produce(page):
    """Every free-run figure (mV, mm, m, dB) there sits in a block generated from docs/_data (or a transcript)."""
    assert not figures_outside_blocks(page.read_text(encoding="utf-8")), page.name


def test_the_figure_check_catches_a_figure_typed_by_hand():
    text = (
        "Silverbox: 0.96 mV (published), Bouc-Wen 2.95e-6 m, EMPS 1.27 mm and -98.3 dB.\n"
        "Files SNLS80mV.mat, gravity 9.81 m/s^2, 14 N/mm^3 are no figures.\n"
        "```\nnlid discover dataset:emps   14.4 mm\n```\n"
        "<!-- BEGIN nlid bench: x (generated) -->\n0.462 mV\n<!-- END nlid bench: x -->\n"
    )
    found = figures_outside_blocks(text)
    assert [f.split(" in:")[0] for f in found] == ["'0.96 mV'", "'2.95e-6 m'", "'1.27 mm'", "'98.3 dB'"]


def test_generated_pages_carry_the_leaderboard_and_rules():
    text = (DOCS / "results.md").read_text(encoding="utf-8")
    assert "Rule `window:50`" in text and "Rule `periodic:8192`" in text
    assert "PNLSS, degrees 3-5-7 (217 parameters)" in text  # the published row beside nlid's on the multisine
    assert "| # | row | knew |" in text and "mass given · terms given · shape given" in text  # what rows knew
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert "| benchmark / test (rule) | unit | best nlid row (knew) |" in readme
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
