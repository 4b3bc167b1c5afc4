"""A study's outputs are written again only when stale, and only the figures whose inputs changed are redrawn."""

from __future__ import annotations

import json
import shutil
from types import SimpleNamespace

import pytest

from nlid.study import ResultStore, parse_study, plan_study, run_study
from nlid.study.report import report_digest, stored_digest, write_report


def _stamps(folder):
    """``{file name: modification time}`` of the text outputs and figures."""
    files = [folder / n for n in ("report.html", "summary.md", "summary.txt", "summary.csv", "results.csv")]
    files += sorted((folder / "figures").glob("*.png"))
    return {p.name: p.stat().st_mtime_ns for p in files}


@pytest.fixture(scope="module")
def finished(small_study, registry, tmp_path_factory):
    """A finished small study (rfs and echo, 2 repetitions), run once for the module."""
    config = parse_study(small_study('["rfs", "echo"]', repetitions=2, duration=4.0), registry=registry)
    return config, run_study(config, tmp_path_factory.mktemp("stale") / "out", progress=False)


@pytest.fixture
def study(finished, tmp_path):
    """A copy of the finished study's folder (times kept) for one test to change."""
    config, outcome = finished
    folder = tmp_path / "out"
    shutil.copytree(outcome.folder, folder)
    copy = SimpleNamespace(folder=folder, runs=outcome.runs, summary=outcome.summary, report=folder / "report.html")
    return config, copy


def test_a_run_with_nothing_new_keeps_every_output(study):
    config, first = study
    before = _stamps(first.folder)
    assert any(name.startswith("kz_") for name in before)
    again = run_study(config, first.folder, progress=False)
    assert (again.executed, again.skipped) == (0, len(first.runs))
    assert _stamps(first.folder) == before, "a fresh report was written again"
    assert again.summary == first.summary and again.report == first.report
    records, digests = ResultStore(first.folder).snapshot(first.runs)
    assert stored_digest(first.folder) == report_digest(config, first.runs, digests)


def test_new_rows_rewrite_the_report_and_redraw_only_what_changed(study):
    config, first = study
    before = _stamps(first.folder)
    index = json.loads((first.folder / "figures" / "index.json").read_text())
    again = run_study(config, first.folder, progress=False, rerun=True)
    assert again.executed == len(first.runs)
    after = _stamps(first.folder)
    # the rows changed (their times): the text outputs and the summary figure (it shows the times) are new
    for name in ("report.html", "summary.md", "summary.txt", "results.csv", "summary_short_main.png"):
        assert after[name] != before[name], name
    # the runs are deterministic: the coefficients, arrays and RMS contributions are the same, so are those figures
    for name in ("kz_short_main.png", "rms_short_main.png", "sv_short_main_echo.png", "coef_short_main_echo.png"):
        assert after[name] == before[name], name
    new_index = json.loads((first.folder / "figures" / "index.json").read_text())
    assert new_index.keys() == index.keys()
    assert new_index["summary_short_main"] != index["summary_short_main"]
    assert new_index["kz_short_main"] == index["kz_short_main"]


def test_a_changed_result_redraws_its_figures(study):
    config, first = study
    store = ResultStore(first.folder)
    runs = plan_study(config)
    run = next(r for r in runs if r.spec.method == "echo")
    record = store.load(run.run_id)
    record["result"]["coefficients"] = {k: 1.01 * v for k, v in record["result"]["coefficients"].items()}
    store.path(run.run_id).write_text(json.dumps(record))
    before = _stamps(first.folder)
    write_report(config, runs, store)
    after = _stamps(first.folder)
    for name in ("report.html", "kz_short_main.png", "coef_short_main_echo.png", "frf_short_main_echo.png"):
        assert after[name] != before[name], name
    assert after["rms_short_main.png"] == before["rms_short_main.png"]  # its column is unchanged


@pytest.mark.parametrize("missing", ["summary.md", "figures/kz_short_main.svg"])
def test_a_missing_output_makes_the_report_stale(study, missing):
    config, first = study
    (first.folder / missing).unlink()
    write_report(config, plan_study(config), ResultStore(first.folder))
    assert (first.folder / missing).is_file()


def test_force_redraws_every_figure(study):
    config, first = study
    before = _stamps(first.folder)
    write_report(config, plan_study(config), ResultStore(first.folder), force=True)
    after = _stamps(first.folder)
    assert all(after[name] != before[name] for name in before), "force=True kept an output"


def test_a_report_of_an_older_nlid_is_stale(study):
    config, first = study
    path = first.folder / "report.html"
    path.write_text(path.read_text().replace('<meta name="nlid-report-digest"', '<meta name="other"'))
    assert stored_digest(first.folder) is None
    write_report(config, plan_study(config), ResultStore(first.folder))
    assert stored_digest(first.folder) is not None
