"""The study row's columns are declared once (nlid.study.columns); producers and consumers go through them."""

from __future__ import annotations

import ast
import itertools
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from nlid.identified.compared import equilibrium_label
from nlid.plugin import FigureArray, Identifier, standard_figure_arrays
from nlid.study import columns as col
from nlid.study.report import tables
from nlid.study.report.figures import figure_arrays
from nlid.study.report.section import Section

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("family", col.FAMILIES, ids=lambda f: f.name)
def test_keys_and_labels_round_trip(family):
    label = {"run": None, "term": "v*|v|", "equilibrium": "s2"}[family.per]
    key = family.key(label)
    assert family.label_of(key) == (label or "") and col.family_of(key) is family and col.declared(key)
    with pytest.raises(ValueError):
        family.key("x" if not family.labelled else None)


def test_no_two_families_share_a_key():
    names = [f.name for f in col.FAMILIES]
    assert len(names) == len(set(names))
    for a, b in itertools.permutations(col.FAMILIES, 2):
        assert not b.matches(a.key({"run": None, "term": "z", "equilibrium": "s1"}[a.per])), (a.name, b.name)


def test_headers_and_titles():
    assert col.COEF_ERROR.header("z^3") == "z^3 (%)" and col.COEF.header("z^3", "N/m^3") == "z^3 (N/m^3)"
    assert col.FN.header("s1") == "fn s1 (Hz)" and col.ZETA.header("s1") == "zeta s1"
    assert col.EQ_ERROR.header("s2") == "z* s2 (%)" and col.SECONDS.header() == "time (s)"
    assert col.FN_ERROR.verdict_title("s1") == "fn s1 (|error| %)"
    assert col.EQ_ERROR_MAX.verdict_title() == "equilibria (largest |error| %)"
    assert col.EPS_HOLDOUT.verdict_title() == "eps held-out (%)" and col.RMS.header("v") == "v (N)"
    assert col.label_order("s10") > col.label_order("s9") and equilibrium_label(0) == "s1"
    assert col.SLICES.count(["slice0:z0", "slice1:z0", "slice3:z0"]) == 2
    with pytest.raises(ValueError, match="per must be one of"):
        col.ColumnFamily("x", per="well")


def _section(frame: pd.DataFrame) -> Section:
    return Section("d", "m", "", ["v"], ["a", "b"], frame, None)


def test_a_declared_scalar_column_reaches_its_table_with_no_table_code(monkeypatch):
    """Adding a column is one declaration plus its producer: the summary table shows it."""
    extra = col.ColumnFamily("made_up_pct", unit="%", title="made up", section=col.SECTION_RESIDUALS, lower_better=True)
    frame = pd.DataFrame(
        [
            {"run_id": f"{m}/{r}", "method": m, "repetition": r, "status": "ok", "eps_percent": 1.0, "made_up_pct": x}
            for m, r, x in (("a", 0, 1.0), ("a", 1, 2.0), ("b", 0, 5.0), ("b", 1, 6.0))
        ]
    )
    before = tables._residual_table(_section(frame))
    assert "made up (%)" not in before.header and tables._other_table(_section(frame)).header[-1] == "made_up_pct"
    monkeypatch.setattr(col, "FAMILIES", (*col.FAMILIES, extra))
    after = tables._residual_table(_section(frame))
    j = after.header.index("made up (%)")
    assert after.rows[0][j] == "1.50 [1.00, 2.00]" and (0, j) in after.best
    assert tables._other_table(_section(frame)) is None


@pytest.mark.parametrize("offset", [0.0, 1e-12, 1e-9])
def test_a_tie_marks_both_cells(offset):
    """Identical methods differ in the last bits of derived numbers: both are best, or the table contradicts the
    verdict's "tie" (issue 35)."""
    rng = np.random.default_rng(4)
    x = rng.uniform(1.0, 3.0, size=3)
    rows = [
        {"run_id": f"{m}/{r}", "method": m, "repetition": r, "status": "ok", "eps_percent": x[r] * (1 + rel)}
        for m, rel in (("a", 0.0), ("b", offset))
        for r in range(3)
    ]
    table = tables._residual_table(_section(pd.DataFrame(rows)))
    j = table.header.index(next(h for h in table.header if h.startswith("eps")))
    assert table.rows[0][j] == table.rows[1][j]
    assert {(0, j), (1, j)} <= table.best


def test_a_lower_median_alone_is_marked():
    rows = [
        {"run_id": f"{m}/{r}", "method": m, "repetition": r, "status": "ok", "eps_percent": x}
        for m, r, x in (("a", 0, 1.0), ("a", 1, 2.0), ("b", 0, 1.2), ("b", 1, 2.2))
    ]
    table = tables._residual_table(_section(pd.DataFrame(rows)))
    j = table.header.index(next(h for h in table.header if h.startswith("eps")))
    assert (0, j) in table.best and (1, j) not in table.best


# ----------------------------------------------------------------------------- no key spelled outside the declarations
_PRODUCERS_AND_CONSUMERS = [
    "nlid/study/metrics.py",
    "nlid/study/worker.py",
    "nlid/study/data.py",
    "nlid/bayes/study.py",
    "nlid/identified/reference.py",
    *sorted(str(p.relative_to(ROOT)) for p in (ROOT / "nlid" / "study" / "report").glob("*.py")),
]
#: Scalar keys that are also the compare frame's quantities (its own vocabulary).
_WORDS = {"seconds", "eps_percent", "force_residual_percent", "freerun_rmse"}


def _literals(path: Path):
    tree = ast.parse(path.read_text())
    docstrings = {
        id(node.body[0].value)
        for node in ast.walk(tree)
        if isinstance(node, (ast.Module, ast.FunctionDef, ast.ClassDef))
        and node.body
        and isinstance(node.body[0], ast.Expr)
        and isinstance(node.body[0].value, ast.Constant)
    }
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docstrings:
            yield node.lineno, node.value
        elif isinstance(node, ast.JoinedStr) and node.values and isinstance(node.values[0], ast.Constant):
            yield node.lineno, str(node.values[0].value)  # the fixed start of an f-string


@pytest.mark.parametrize("relative", _PRODUCERS_AND_CONSUMERS)
def test_no_column_key_is_spelled_outside_the_declarations(relative):
    identity = {f.name for f in (col.RUN_ID, col.DATASET, col.MODEL, col.METHOD, col.STATUS, col.ERROR)}
    identity |= {f.name for f in (col.REPETITION, col.SEED, col.WARNINGS)}
    prefixes = tuple(f"{f.name}:" for f in col.FAMILIES if f.labelled)
    scalars = {f.name for f in col.FAMILIES if not f.labelled} - identity - {"mass"}
    if relative == "nlid/identified/reference.py":
        scalars -= _WORDS  # the compare frame's own quantities share these names
    offenders = [
        f"{relative}:{line}: {text!r}"
        for line, text in _literals(ROOT / relative)
        if text.startswith(prefixes) or text in scalars
    ]
    assert not offenders, "\n".join(offenders)


# ----------------------------------------------------------------------------- the figure arrays a plugin declares
def test_figure_arrays_are_declared_by_the_identifier():
    f = np.linspace(1.0, 10.0, 4)
    arrays = {
        "frf": f + 0j,
        "frf_frequency_hz": f,
        "frf@well1": f + 1j,
        "frf_frequency_hz@well1": f,
        "coef_frequency_hz": f,
        "coef_spectrum:z^3": f + 0j,
        "coef_spectrum:v": f + 0j,
        "coef_spectrum:v@well1": f + 0j,
        "coef_frequency_hz@well1": f,
    }
    # the default: the keys Estimate documents, nothing else
    standard = standard_figure_arrays(arrays)
    assert [(a.kind, a.values) for a in standard] == [
        ("frf", "frf"),
        ("coefficient spectrum", "coef_spectrum:v"),
        ("coefficient spectrum", "coef_spectrum:z^3"),
    ]
    assert Identifier.figure_arrays(arrays) == standard
    # nsi-shift declares one FRF and spectra per well, labelled; reports read them without parsing names
    shift = figure_arrays("nsi-shift", arrays)
    assert [(a.values, a.label) for a in shift if a.kind == "frf"] == [("frf", "well 1"), ("frf@well1", "well 2")]
    second = FigureArray("coefficient spectrum", "coef_spectrum:v@well1", "coef_frequency_hz@well1", "well 2", "v")
    assert second in shift
    assert [a.label for a in figure_arrays("nsi-ip", arrays) if a.kind == "frf"] == ["", ""]
    # a method that is not installed is read with the documented keys
    assert figure_arrays("no-such-method", arrays) == standard
    # a declared array that is missing is left out
    assert figure_arrays("nsi-shift", {"frf": f + 0j}) == ()
    with pytest.raises(ValueError, match="needs its term"):
        FigureArray("coefficient spectrum", "x", "y")


# ----------------------------------------------------------------------------- fit %: one declaration and its producer
def test_the_free_run_fit_column_is_declared_produced_and_shown(short_record, numerical):
    """MATLAB compare's fit of the held-out free run: declared in nlid.study.columns, produced from Scores, in the
    table."""
    from nlid import identify, plugin
    from nlid.study.metrics import holdout_metrics

    fit = identify(short_record, "z^3, z^2, v*|v|", "rfs", mass=0.2)
    held = numerical.with_overrides(duration=10.0).simulate(7, noise={"z": 0.01}, channels=("z", "a"))
    scores = fit.score(held)
    x0 = plugin.initial_state(held)
    z, _, _ = plugin.free_run(fit.model, fit.theta, 0.2, held.f, held.fs, force_hold=held.force_hold, x0=x0)
    expected = 100 * (1 - np.linalg.norm(held.z - z) / np.linalg.norm(held.z - held.z.mean()))
    assert scores.freerun_fit_percent == pytest.approx(expected, rel=1e-12)
    assert scores.freerun_fit_percent == pytest.approx(100 - scores.freerun_nrmse_percent, abs=1e-9)
    assert scores.to_dict()["freerun_fit_percent"] == scores.freerun_fit_percent
    row = holdout_metrics(held, fit)
    assert row[col.FREERUN_FIT.key()] == scores.freerun_fit_percent and 90 < row[col.FREERUN_FIT.key()] < 100
    assert np.isnan(holdout_metrics(None, fit)[col.FREERUN_FIT.key()])
    frame = pd.DataFrame(
        [
            {"method": "a", "repetition": r, "status": "ok", "eps_percent": 1.0, **holdout_metrics(held, fit)}
            for r in range(2)
        ]
    )
    table = tables._residual_table(_section(frame))
    assert table.header[2:6] == ["eps (%)", "eps held-out (%)", "free-run NRMSE (%)", "free-run fit (%)"]
