"""Study outputs: the summary's numbers against individual identifications, figures, report.html in a browser."""

from __future__ import annotations

import re
import shutil
import subprocess

import numpy as np
import pandas as pd
import pytest

from nlid import identify
from nlid.simulation.presets import get_preset
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
        rows.append([c.strip().replace("\\|", "|").strip("*") for c in re.split(r"(?<!\\)\|", line)[1:-1]])
    header, body = rows[0], rows[2:]
    return {r[0]: dict(zip(header, r, strict=True)) for r in body}


def _numbers(cell: str) -> list[str]:
    return re.findall(r"-?\d+(?:\.\d+)?(?:e[+-]\d+)?", cell)


def _printed(text: str, value: float) -> bool:
    """``text`` is ``value`` rounded to the digits it shows (half a unit of its last digit)."""
    mantissa, _, exponent = text.partition("e")
    decimals = len(mantissa.split(".")[1]) if "." in mantissa else 0
    unit = 10.0 ** (-decimals + (int(exponent) if exponent else 0))
    return abs(float(text) - value) <= 0.5 * unit * (1 + 1e-9)


def _matches(cell: str, values) -> bool:
    """A ``median [min, max]`` cell shows the statistics of ``values`` (|values|), to its printed digits."""
    x = np.abs(np.asarray(values, dtype=float))
    printed = _numbers(cell)
    expected = [np.median(x), x.min(), x.max()] if len(printed) == 3 else [np.median(x)]
    return len(printed) == len(expected) and all(_printed(t, v) for t, v in zip(printed, expected, strict=True))


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
    summary = (finished.folder / "summary.md").read_text()
    assert summary == finished.summary + "\n"

    coefs = _table(summary, "Coefficients")
    for term in ("z^3", "z^2", "z", "v", "v*|v|", "1"):
        errors = [100 * (r.coefficients[term] - truth[term]) / abs(truth[term]) for r in results]
        assert _matches(coefs["rfs"][f"{term} (%)"], errors), (term, coefs["rfs"][f"{term} (%)"], errors)
        assert coefs["echo"][f"{term} (%)"] == "0"
    assert "reference" not in coefs, "SI reference values are not in a table of percentages"
    refs = _table(summary, "Reference values")
    assert refs["coefficient of z^3"]["value"] == "1e+06" and refs["coefficient of z^3"]["unit"] == "N/m^3"
    values = _table(summary, "Identified coefficients")
    assert values["reference"]["z^3 (N/m^3)"] == "1e+06"
    z3 = _numbers(values["rfs"]["z^3 (N/m^3)"])
    assert len({float(t) for t in z3}) == 3, f"the digits must tell min, median and max apart: {z3}"

    ref = preset.truth()
    model = preset.model()
    from nlid.model import physics

    modal = _table(summary, "Modal parameters")
    true_eq = physics.equilibria(model, ref["coefficients"], (-0.05, 0.05)).stable
    true_modal = physics.modal(model, ref["coefficients"], 0.2, points=true_eq)
    for k, (z_ref, m_ref) in enumerate(zip(true_eq, true_modal, strict=True)):
        label = f"s{k + 1}"
        assert _printed(refs[f"{label}: stable equilibrium"]["value"], z_ref)
        eq_err, fn_err, zeta_err = [], [], []
        for r in results:
            stable = r.equilibria.stable
            z = stable[int(np.argmin(np.abs(np.asarray(stable) - z_ref)))]
            m = next(m for m in r.modal if m.equilibrium == z)
            eq_err.append(100 * (z - z_ref) / z_ref)
            fn_err.append(100 * (m.fn_hz - m_ref.fn_hz) / m_ref.fn_hz)
            zeta_err.append(100 * (m.zeta - m_ref.zeta) / m_ref.zeta)
        assert _matches(modal["rfs"][f"z* {label} (%)"], eq_err), k
        assert _matches(modal["rfs"][f"fn {label} (%)"], fn_err), k
        assert _matches(modal["rfs"][f"zeta {label} (%)"], zeta_err), k
    assert modal["rfs"]["wells found (of 2)"] == "2"

    resid = _table(summary, "Residuals")
    eps = [r.eps_percent for r in results]
    assert _matches(resid["rfs"]["eps (%)"], eps)
    assert resid["rfs"]["runs"] == "3/3"


def test_the_verdict_comes_first_and_agrees_with_the_tables(finished):
    summary = finished.summary
    assert summary.index("## Verdict") < summary.index("## short / main")
    lines = summary.splitlines()
    start = lines.index("## Verdict")
    header = next(i for i in range(start, len(lines)) if lines[i].startswith("| metric"))
    rows = {}
    for line in lines[header + 2 :]:
        if not line.startswith("|"):
            break
        cells = [c.strip().replace("\\|", "|") for c in re.split(r"(?<!\\)\|", line)[1:-1]]
        rows[cells[0]] = cells
    # the echo plugin returns the truth: it must be the best on every coefficient, with error 0
    coefs = _table(summary, "Coefficients")
    for term in ("z^3", "v"):
        best, nxt = rows[f"{term} (|error| %)"][1:3]
        assert best == "echo 0" and nxt.startswith("rfs ")
        assert nxt == f"rfs {coefs['rfs'][term + ' (%)']}", "the verdict quotes the table's cell"
    # the best cell of each error column is marked in the Markdown table
    assert re.search(r"\| \*\*0\*\* \|", summary)
    text = (finished.folder / "summary.txt").read_text()
    assert max(len(line) for line in text.splitlines()) <= 100
    assert text.index("VERDICT") < text.index("Coefficients: |relative error|")
    assert "rfs: velocity from a low-passed derivative of z" in " ".join(text.split())
    assert "see docs/rfs.md" in text


def test_outputs_and_figures_are_written(finished):
    folder = finished.folder
    for name in ("results.csv", "summary.md", "summary.csv", "report.html", "study.toml"):
        assert (folder / name).is_file(), name
    names = {p.name for p in (folder / "figures").iterdir()}
    for stem in (
        "kz_short_main",
        "summary_short_main",
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
    page = dom.stdout
    assert page.index('class="verdict"') < page.index("<h4>"), "the verdict comes before every table"
    assert '<td class="best">' in page
    shot = tmp_path / "report.png"
    subprocess.run(
        [*args, "--window-size=1200,2000", f"--screenshot={shot}", report.as_uri()], capture_output=True, timeout=120
    )
    assert shot.is_file() and shot.stat().st_size > 10_000
    from matplotlib.image import imread

    pixels = (imread(shot)[..., :3] * 255).round().astype(int)
    border = np.all(pixels == (0x44, 0xAA, 0x77), axis=-1)  # the verdict box's border colour, #4a7
    rows = np.flatnonzero(border.any(axis=1))
    assert rows.size and rows.min() < 400, "the verdict box is drawn at the top of the page"
