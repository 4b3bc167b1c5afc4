"""The discover report a newcomer reads (issue 35): one explanation of a wrong sign, figures at a readable size."""

from __future__ import annotations

import re

import pytest

from nlid.discovery import discover
from nlid.discovery.library import SIGN_WHY
from nlid.discovery.report import PAGE_PX, write_report


@pytest.fixture(scope="module")
def report(short_record, tmp_path_factory):
    """A discovery whose candidates include sign rejections (damping terms fitted on a model that has them)."""
    result = discover(short_record, "1, z, v, z^2, z^3", "rfs", mass=0.2, max_steps=1)
    out = tmp_path_factory.mktemp("discover")
    write_report(result, out)
    return result, out


def test_a_wrong_sign_is_explained_once_per_table(report):
    result, out = report
    rankings = [*(step.ranking for step in result.steps), result.final_ranking]
    rejected = [ev for ranking in rankings for ev in ranking if SIGN_WHY in ev.reason]
    assert len(rejected) >= 2  # the case this test is about: several rows rejected for their sign
    for name in ("report.md", "report.html"):
        text = (out / name).read_text()
        tables = text.count("| candidate |") if name.endswith(".md") else text.count("<th>candidate</th>")
        assert text.count(SIGN_WHY) <= tables, name  # at most once per ranking table, never once per row
    assert SIGN_WHY in (out / "report.md").read_text()  # said, once


def test_figures_are_shown_at_their_own_size(report):
    _, out = report
    html = (out / "report.html").read_text()
    style = re.search(r"<style>(.*?)</style>", html, re.S).group(1)
    assert "figure img{max-width:100%;height:auto}" in style and "flex-direction:column" in style
    assert "width:100%}" not in style.replace("max-width:100%", "")  # never stretched to a column's width
    import matplotlib.image

    for png in (out / "figures").glob("residual_*.png"):
        width = matplotlib.image.imread(png).shape[1]
        assert width <= PAGE_PX  # the page shows it at its own size, without shrinking
