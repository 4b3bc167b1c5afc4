"""One Summary type: the same content as text, Markdown and HTML; every result returns one."""

from __future__ import annotations

from html.parser import HTMLParser

import numpy as np
import pytest

import nlid
from nlid.base.formatting import text_table
from nlid.report.summary import Column, Fields, Summary, Table, Text


class _Balanced(HTMLParser):
    """Checks that every tag is closed in order and collects the text of each cell."""

    def __init__(self):
        super().__init__()
        self.stack, self.cells = [], []

    def handle_starttag(self, tag, attrs):
        self.stack.append(tag)

    def handle_endtag(self, tag):
        assert self.stack.pop() == tag, f"unbalanced </{tag}>"

    def handle_data(self, data):
        if self.stack and self.stack[-1] in ("td", "th"):
            self.cells.append(data)


def _html_cells(text: str) -> list[str]:
    parser = _Balanced()
    parser.feed(text)
    assert not parser.stack
    return parser.cells


@pytest.fixture
def summary():
    out = Summary("a fit")
    out.add_fields([("method", "rfs"), ("mass", "0.2 kg (given)")])
    out.add_table(
        [Column("term"), Column("coefficient", "right", 14), Column("unit")],
        [["z^3", "1e+06", "N/m^3"], ["v*|v|", "5.1", "N*s^2/m^2"]],
    )
    out.add_text("at z* = 0.01 m: fn = 10 Hz", indent="  ")
    out.add_fields([("epsilon", "1 %"), ("force residual", "2 %")], separator="   ", gap=True)
    return out


def test_text_lays_out_fields_tables_and_gaps(summary):
    assert (
        str(summary)
        == summary.as_text()
        == "\n".join(
            [
                "a fit",
                "method: rfs",
                "mass: 0.2 kg (given)",
                "",
                "term      coefficient  unit",
                "z^3             1e+06  N/m^3",
                "v*|v|             5.1  N*s^2/m^2",
                "  at z* = 0.01 m: fn = 10 Hz",
                "",
                "epsilon: 1 %   force residual: 2 %",
            ]
        )
    )
    assert "force residual: 2 %" in summary and "nothing like this" not in summary


def test_an_empty_block_keeps_its_gap():
    out = Summary().add_fields([("method", "rfs")]).add_fields([], separator="   ", gap=True)
    assert out.as_text() == "method: rfs\n"


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("width", [30, 60, 100])
def test_a_ruled_table_is_laid_out_as_text_table(seed, width):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 9))
    headers = ["label"] + [f"column {j}" + "x" * int(rng.integers(0, 8)) for j in range(1, n)]
    rows = [[f"row {i}"] + [f"{x:.4g}" for x in rng.normal(size=n - 1) * 10.0 ** rng.integers(-3, 7)] for i in range(4)]
    columns = [Column(h, "left" if j == 0 else "right") for j, h in enumerate(headers)]
    table = Table(tuple(columns), tuple(tuple(r) for r in rows), rule=True, width=width)
    assert "\n".join(table.text_lines()) == text_table(headers, rows, width=width)


def test_markdown_escapes_cells_and_aligns_columns(summary):
    md = summary.as_markdown()
    assert md.startswith("### a fit\n\n- **method**: rfs\n- **mass**: 0.2 kg (given)\n\n")
    assert "| term | coefficient | unit |\n| :--- | ---: | :--- |\n" in md
    assert "| v\\*\\|v\\| | 5.1 | N\\*s^2/m^2 |" in md
    assert "at z\\* = 0.01 m" in md and md.endswith("\n")


def test_html_is_balanced_and_escaped():
    out = Summary("<b>bold</b> & co").add_table(["term", Column("value", "right")], [["v*|v|", "<1>"]])
    page = out.as_html()
    assert out._repr_html_() == page
    assert "&lt;b&gt;bold&lt;/b&gt; &amp; co" in page and "<td style='text-align:right'>&lt;1&gt;</td>" in page
    assert _html_cells(page) == ["term", "value", "v*|v|", "<1>"]


def test_plain_data_tables_and_repr(summary):
    data = summary.to_dict()
    assert data["title"] == "a fit" and [b["kind"] for b in data["blocks"]] == ["fields", "table", "text", "fields"]
    assert data["blocks"][1]["rows"][1] == ["v*|v|", "5.1", "N*s^2/m^2"]
    frame = summary.tables[0].to_frame()
    assert list(frame.columns) == ["term", "coefficient", "unit"] and frame.iloc[0, 0] == "z^3"
    assert repr(summary) == "<Summary 'a fit': 2 fields, 1 table, 1 text>"
    assert isinstance(summary.blocks[0], Fields) and isinstance(summary.blocks[2], Text)


def test_a_row_must_fit_the_columns():
    with pytest.raises(ValueError, match="row 0 has 1 cells for 2 columns"):
        Summary().add_table(["a", "b"], [["only one"]])
    with pytest.raises(ValueError, match="align must be"):
        Column("a", "centre")  # type: ignore[arg-type]


# ---------------------------------------------------------------- the results
@pytest.fixture(scope="module")
def record():
    return nlid.simulate("paper-numerical", seed=4, noise=0.02, channels="z,a", duration=10)


def test_the_identified_model_renders_one_summary(record):
    fit = nlid.identify(record, "z^3, z^2, sign(v)*|px(z)|", "rfs", mass=0.2)
    summary = fit.summary()
    assert isinstance(summary, Summary)
    text = str(summary)
    assert text.startswith("method: rfs\nmass: 0.2 kg (given)\nforce between samples: zoh: held over each sample [")
    assert "[from simulation]\n\nterm " in text  # the force-hold assumption and who said it (issue 35)
    assert "\npx(z) roots: z- = " in text and "\nequilibria (m): stable " in text and "\n  at z* = " in text
    assert "\n\nepsilon (Eq. 26): " in text and "   force residual: " in text
    assert fit._repr_html_() == summary.as_html()
    assert "sign(v)*|px(z)|" in _html_cells(fit._repr_html_())
    assert "| sign(v)\\*\\|px(z)\\| |" in summary.as_markdown()


def test_the_posterior_renders_one_summary_and_keeps_its_numbers(record):
    from nlid.bayes import sample_posterior

    fit = nlid.identify(record, "z^3, z^2, v*|v|", "rfs", mass=0.2)
    post = sample_posterior(record, fit, params="damping", seed=0, walkers=16, max_steps=3000)
    summary = post.summary()
    assert isinstance(summary, Summary) and str(summary) == post.format_table()
    numbers = post.summary_dict()
    assert list(numbers) == ["v", "v*|v|"] and set(numbers["v"]) == {"mean", "sd", "q05", "q50", "q95"}
    assert post.to_dict()["params"] == numbers
    rows = summary.tables[0].rows
    assert [r[0] for r in rows] == ["v", "v*|v|"] and rows[0][1] == f"{numbers['v']['mean']:.5g}"
    assert str(summary).startswith("posterior of 2 coefficient(s); start: rfs, mass 0.2 kg\n\nterm ")
    assert post._repr_html_() == summary.as_html()
