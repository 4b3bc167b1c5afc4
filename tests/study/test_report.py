"""Study outputs: the summary's numbers against individual identifications, figures, report.html in a browser."""

from __future__ import annotations

import re
import shutil
import subprocess

import numpy as np
import pandas as pd
import pytest

from nlid import identify
from nlid.presets import get_preset
from nlid.study import LocalExecutor, parse_study, run_study

TERMS = "z^3, z^2, v*|v|"


@pytest.fixture(scope="module")
def finished(small_study, registry, tmp_path_factory):
    """A finished small study (rfs and the echo test plugin, 3 repetitions)."""
    out = tmp_path_factory.mktemp("report") / "small"
    config = parse_study(small_study('["rfs", "echo"]', repetitions=3, duration=8.0), registry=registry)
    outcome = run_study(config, out, executor=LocalExecutor(jobs=2), progress=False)
    return outcome


def _table(summary: str, title: str) -> dict[str, dict[str, str]]:
    """Parse the first Markdown table after a heading starting with ``title``: {row label: {column: cell}}."""
    lines = summary.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(f"### {title}"))
    rows = []
    for line in lines[start + 2 :]:
        if not line.startswith("|"):
            break
        rows.append([c.strip().replace("\\|", "|") for c in re.split(r"(?<!\\)\|", line)[1:-1]])
    header, body = rows[0], rows[2:]
    return {r[0]: dict(zip(header, r, strict=True)) for r in body}


def _median_cell(values) -> str:
    x = np.abs(np.asarray(values, dtype=float))
    return f"{np.median(x):.3g} [{x.min():.3g}, {x.max():.3g}]"


def test_summary_numbers_match_individual_identify_results(finished):
    frame = pd.read_csv(finished.folder / "results.csv")
    seeds = sorted(frame.loc[frame["method"] == "rfs", "seed"])
    assert len(set(seeds)) == 3, "each repetition must have its own record"
    preset = get_preset("paper-numerical").with_overrides(duration=8.0)
    truth = preset.truth()["coefficients"]
    results = []
    for seed in seeds:
        record = preset.simulate(int(seed), noise={"z": 0.02}, channels=("z",))
        results.append(identify(record, TERMS, "rfs", mass=0.2))
    summary = finished.summary

    coefs = _table(summary, "Coefficients")
    for term in ("z^3", "z^2", "z", "v", "v*|v|", "1"):
        errors = [100 * (r.coefficients[term] - truth[term]) / abs(truth[term]) for r in results]
        assert coefs["rfs"][term] == _median_cell(errors), term
        assert coefs["echo"][term] == "0 [0, 0]"
    assert coefs["reference"]["z^3"] == "1e+06"

    ref = preset.truth()
    model = preset.model()
    from nlid import physics

    modal = _table(summary, "Modal parameters")
    true_eq = physics.equilibria(model, ref["coefficients"], (-0.05, 0.05)).stable
    true_modal = physics.modal(model, ref["coefficients"], 0.2, points=true_eq)
    for k, (z_ref, m_ref) in enumerate(zip(true_eq, true_modal, strict=True)):
        where = f" at {z_ref:.3g} m"
        eq_err, fn_err, zeta_err = [], [], []
        for r in results:
            stable = r.equilibria.stable
            z = stable[int(np.argmin(np.abs(np.asarray(stable) - z_ref)))]
            m = next(m for m in r.modal if m.equilibrium == z)
            eq_err.append(100 * (z - z_ref) / z_ref)
            fn_err.append(100 * (m.fn_hz - m_ref.fn_hz) / m_ref.fn_hz)
            zeta_err.append(100 * (m.zeta - m_ref.zeta) / m_ref.zeta)
        assert modal["rfs"][f"z*{where}"] == _median_cell(eq_err), k
        assert modal["rfs"][f"fn{where}"] == _median_cell(fn_err), k
        assert modal["rfs"][f"zeta{where}"] == _median_cell(zeta_err), k
    assert modal["rfs"]["stable equilibria found"] == "2"

    resid = _table(summary, "Residuals")
    eps = [r.eps_percent for r in results]
    assert resid["rfs"]["eps (Eq. 26) %"] == _median_cell(eps)
    assert resid["rfs"]["runs"] == "3/3"


def test_outputs_and_figures_are_written(finished):
    folder = finished.folder
    for name in ("results.csv", "summary.md", "summary.csv", "report.html", "study.toml"):
        assert (folder / name).is_file(), name
    names = {p.name for p in (folder / "figures").iterdir()}
    for stem in (
        "kz_short_main",
        "bars_short_main",
        "rms_short_main",
        "sv_short_main_echo",
        "frf_short_main_echo",
        "coef_short_main_echo",
    ):
        assert {f"{stem}.png", f"{stem}.svg"} <= names, stem
    assert not any(n.startswith(("sv_", "frf_", "coef_")) and "_rfs" in n for n in names)
    long = pd.read_csv(folder / "summary.csv")
    row = long[(long["method"] == "rfs") & (long["metric"] == "eps_percent")].iloc[0]
    assert row["n"] == 3 and row["min"] <= row["median"] <= row["max"]
    html = (folder / "report.html").read_text()
    assert html.count("data:image/png;base64,") == 6
    assert 'src="http' not in html and 'href="http' not in html  # self-contained


def _browser() -> str | None:
    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        path = shutil.which(name)
        if path:
            return path
    return None


def test_report_renders_in_a_headless_browser(finished, tmp_path):
    browser = _browser()
    if browser is None:
        pytest.skip("no headless browser installed (Debian: apt-get install chromium); .ci/run installs it")
    report = finished.folder / "report.html"
    args = [
        browser,
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-background-networking",
        "--disable-component-update",
        "--no-first-run",
        f"--user-data-dir={tmp_path / 'profile'}",
        "--virtual-time-budget=10000",
    ]
    dom = subprocess.run([*args, "--dump-dom", report.as_uri()], capture_output=True, text=True, timeout=120)
    assert dom.returncode == 0, dom.stderr[-2000:]
    assert 'data-images="6/6"' in dom.stdout, "every embedded figure must decode in the browser"
    assert "<td>rfs</td>" in dom.stdout and "Study small" in dom.stdout
    shot = tmp_path / "report.png"
    subprocess.run(
        [*args, "--window-size=1200,2000", f"--screenshot={shot}", report.as_uri()], capture_output=True, timeout=120
    )
    assert shot.is_file() and shot.stat().st_size > 10_000
