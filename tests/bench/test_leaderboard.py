"""The leaderboard says what each row knew, shows a figure per test set, and is a sortable, self-contained page."""

from __future__ import annotations

import json
import re

import pytest

from nlid.benchmarking import BenchJob, Prior, leaderboard_rows, parse_pipelines, parse_protocol, write_leaderboard
from nlid.benchmarking.board_figures import write_figures
from nlid.benchmarking.data import load_estimation, load_test
from nlid.benchmarking.leaderboard import COLUMNS, badges, markdown_tables, read_leaderboard
from nlid.benchmarking.pipelines import fit_pipelines
from nlid.benchmarking.prior import LEGEND
from nlid.scoring import range_excess, value_range

#: The toy benchmark with its truth declared (and means kept, so the true model is the record's own).
TRUTH = """
[truth]
coefficients = { "1" = 1.962, "z" = 2000.0, "z^3" = 5e6, "v" = 2.0 }
mass = 0.2
source = "the single-well case of nlid.discovery.cases"
"""


def _protocol(text: str, **replace: str):
    text = text.replace("remove_means = true", "remove_means = false") + TRUTH
    for old, new in replace.items():
        text = text.replace(old, new)
    return parse_protocol(text)


@pytest.fixture(scope="module")
def toy_rows(toy):
    """The leaderboard rows of the toy benchmark for one pipeline of each kind (run in this process)."""
    text, est, test, _ = toy
    protocol = _protocol(text)
    job = BenchJob.make(
        protocol,
        tuple(parse_pipelines("rfs, linear, pysindy, linear-ss, truth")),
        files={"toy:estimation": str(est), "toy:independent": str(test)},
    )
    payload = job.execute()
    assert payload["row"]["status"] == "ok", payload["row"]["error"] + str(payload.get("traceback"))
    records = [{"row": payload["row"], "result": payload["result"]}]
    return protocol, leaderboard_rows({protocol.name: protocol}, records)


def test_every_row_kind_states_its_prior_knowledge(toy_rows):
    _, rows = toy_rows
    by = {(r["kind"], r["pipeline"]): r for r in rows}
    expected = {
        ("nlid", "rfs"): ("given", "declared", "none"),  # the toy gives the mass (0.2 kg) and the terms
        ("nlid", "linear"): ("given", "declared", "none"),
        ("peer", "pysindy"): ("none", "library", "none"),
        ("peer", "linear-ss"): ("none", "black box", "none"),
        ("truth", "true system"): ("given", "true model", "given"),
        ("published", "a made-up figure"): ("none", "black box", "none"),
    }
    for key, (mass, structure, shape) in expected.items():
        r = by[key]
        assert (r["prior_mass"], r["prior_structure"], r["prior_shape"]) == (mass, structure, shape), key
        assert r["prior"] == Prior(mass, structure, shape).text(), key
    assert by[("nlid", "rfs")]["prior"] == "mass given · terms given"
    assert by[("truth", "true system")]["prior"] == "true model"
    assert {"prior", "prior_mass", "prior_structure", "prior_shape"} <= set(COLUMNS)


def test_the_prior_follows_the_benchmark_file_not_a_hand_typed_label(toy):
    """Estimate the mass and give a shape in the terms: the same pipeline's prior changes accordingly."""
    text, est, _, _ = toy
    protocol = _protocol(
        text, **{"mass = 0.2\nholdout": 'mass = "estimate"\nholdout', 'terms = "z^3"': 'terms = "z^3, tanh(v/0.5)"'}
    )
    record, _ = load_estimation(protocol, path=est)
    rfs, linear = fit_pipelines(record, protocol, parse_pipelines("rfs, linear"))
    assert (rfs.prior.mass, rfs.prior.structure, rfs.prior.shape) == ("estimated", "declared", "given")
    assert "tanh(v/0.5)" in rfs.prior.detail and rfs.prior.badges() == ["terms given", "shape given"]
    assert (linear.prior.mass, linear.prior.shape) == ("estimated", "none") and linear.model.terms == ("1", "z", "v")


def test_a_missing_peer_or_truth_is_a_note_not_a_failure(toy):
    text, est, _, _ = toy
    protocol = parse_protocol(text)  # no [truth]
    record, _ = load_estimation(protocol, path=est)
    (truth,) = fit_pipelines(record, protocol, parse_pipelines("truth"))
    assert truth == "benchmark toy declares no true model"


def test_tables_show_badges_once_explained_and_the_rule_once(toy_rows):
    protocol, rows = toy_rows
    md = "\n".join(markdown_tables({protocol.name: protocol}, rows, figures="figures"))
    assert md.count("Rule `window:20`") == 1  # once per table, not per row
    assert md.count("initialisation window of 20 samples") == 1
    assert "![RMSE of every row, log axis](figures/toy--independent.png)" in md
    table = [line for line in md.splitlines() if line.startswith("| ")]
    assert table[0].startswith("| # | row | knew | RMSE (mm)")
    assert any("**nlid** `rfs` | mass given · terms given |" in line for line in table)
    assert any("*true model* | true model |" in line for line in table)
    legend = [line for line in md.splitlines() if line.startswith("Knew: ")]
    assert len(legend) == 1 and all(f"**{b}**: {LEGEND[b]}" in legend[0] for r in rows for b in badges(r))


def test_the_html_page_is_sortable_styled_and_self_contained(toy_rows, tmp_path):
    protocol, rows = toy_rows
    write_leaderboard(tmp_path, {protocol.name: protocol}, rows)
    page = (tmp_path / "leaderboard.html").read_text()
    assert page.count('<table class="board">') == 1 and "<style>" in page
    assert '<th scope="col">' in page and 'addEventListener("click"' in page and "aria-sort" in page
    assert re.search(r"<(script|link|img)[^>]+(src|href)=", page) is None  # nothing fetched from elsewhere
    assert "<figure><svg" in page  # the figure, inline
    assert 'class="badge b-mass-given"' in page and 'class="kind-truth"' in page
    assert page.count("<b>Rule</b>") == 1
    # numbers sort by value: every RMSE cell carries it
    assert re.search(r'<td class="num" data-v="[0-9.e+-]+">', page)


def test_each_test_set_gets_a_figure_and_the_same_rows_give_the_same_svg(toy_rows, tmp_path):
    protocol, rows = toy_rows
    first = write_figures(tmp_path / "a", {protocol.name: protocol}, rows)
    write_figures(tmp_path / "b", {protocol.name: protocol}, rows)
    assert set(first) == {("toy", "independent")}
    assert (tmp_path / "a" / "toy--independent.png").stat().st_size > 1000
    svg_a, svg_b = ((tmp_path / d / "toy--independent.svg").read_text() for d in "ab")
    assert svg_a == svg_b
    svg = first[("toy", "independent")]
    for label in ("nlid rfs", "peer pysindy", "published a made-up figure", "true model", "log axis"):
        assert label in svg, label


def test_the_csv_round_trips_the_prior_columns(toy_rows, tmp_path):
    protocol, rows = toy_rows
    write_leaderboard(tmp_path, {protocol.name: protocol}, rows)
    back = read_leaderboard(tmp_path / "leaderboard.csv")
    assert [(r["pipeline"], r["prior"]) for r in back] == [(r["pipeline"], r["prior"] or "") for r in rows]
    assert json.dumps([badges(r) for r in back]) == json.dumps([badges(r) for r in rows])


def test_a_test_set_beyond_the_estimation_range_is_said_once_per_table(toy_rows, toy, tmp_path):
    protocol, rows = toy_rows
    text, est_file, test_file, _ = toy
    estimation, offsets = load_estimation(_protocol(text), path=str(est_file))
    test = load_test(_protocol(text), protocol.test("independent"), offsets, path=str(test_file))
    expected = range_excess(value_range(estimation.z), test.z).describe("the test")
    job_rows = [r for r in rows if r["kind"] in ("nlid", "peer", "truth")]
    assert job_rows and {r["extrapolation"] for r in job_rows} == {expected}  # the job's own measure
    said = "The test reaches 31 % of the estimation range beyond it (2 % of its samples lie outside)"
    beyond = [dict(r, extrapolation=said[:1].lower() + said[1:]) if r in job_rows else r for r in rows]
    md = "\n".join(markdown_tables({protocol.name: protocol}, beyond))
    assert md.count(f"Range: {said}.") == 1
    write_leaderboard(tmp_path, {protocol.name: protocol}, beyond)
    assert (tmp_path / "leaderboard.html").read_text().count("<b>Range</b> The test reaches 31 %") == 1
    back = {r["pipeline"]: r["extrapolation"] for r in read_leaderboard(tmp_path / "leaderboard.csv")}
    assert back["rfs"] == said[:1].lower() + said[1:] and back["a made-up figure"] == ""
    inside = [dict(r, extrapolation="") for r in rows]
    assert "Range:" not in "\n".join(markdown_tables({protocol.name: protocol}, inside))
