"""The verdict of a study section: best, margin, spread, record-by-record count, identical methods, why."""

from __future__ import annotations

import pandas as pd
import pytest

from nlid.study.report.section import Section
from nlid.study.report.verdict import build_verdict


def _section(values: dict[str, list[float]], coefs: dict[str, list[float]] | None = None, diagnostics=None) -> Section:
    rows = []
    for method, errors in values.items():
        for rep, err in enumerate(errors):
            row = {"method": method, "repetition": rep, "status": "ok", "coef_error_pct:v": err, "seconds": 1.0}
            if coefs:
                row["coef:v"] = coefs[method][rep]
            rows.append(row)
    frame = pd.DataFrame(rows)
    return Section("d", "m", "", ["v"], list(values), frame, None, diagnostics=diagnostics or {})


def test_best_margin_spread_and_records():
    section = _section({"a": [1.0, 1.2, 1.1], "b": [2.0, 1.1, 2.2], "c": [9.0, 9.5, 9.9]})
    v = build_verdict(section)
    f = next(f for f in v.findings if f.key == "coef_error_pct:v")
    assert f.best.name == "a" and f.runner_up.name == "b"
    assert f.margin == pytest.approx(2.0 - 1.1)
    assert f.spread == pytest.approx(2.2 - 1.1)  # b's range is the larger
    assert f.within_spread  # 0.9 < 1.1
    assert f.paired == (2, 3)  # a lower than b on records 0 and 2, not on 1
    assert "within the spread" in f.sentence() and "lower on 2 of 3 records" in f.sentence()
    assert [name for name, _, _ in v.ranking] == ["a", "b", "c"]


def test_a_clear_difference_is_called_clear():
    section = _section({"a": [1.0, 1.1, 1.2], "b": [5.0, 5.1, 5.3]})
    f = next(f for f in build_verdict(section).findings if f.key == "coef_error_pct:v")
    assert not f.within_spread and f.judgement().startswith("clear")
    assert f.margin_text() == "4.00 (4.6x)"  # 5.1 - 1.1, 5.1 / 1.1


def test_identical_methods_are_one_entry_and_say_so():
    section = _section(
        {"rfs": [4.0, 5.0, 6.0], "sindy": [4.0, 5.0, 6.0], "nsi": [1.0, 2.0, 3.0]},
        coefs={"rfs": [1.04, 1.05, 1.06], "sindy": [1.04, 1.05, 1.06], "nsi": [1.01, 1.02, 1.03]},
        diagnostics={"sindy": [{"kept_terms": ["v"], "library": ["v", "v^3"], "_model_terms": ["v"]}] * 3},
    )
    v = build_verdict(section)
    f = next(f for f in v.findings if f.key == "coef_error_pct:v")
    assert [e.name for e in f.entries] == ["nsi", "rfs = sindy"]
    why = " ".join(v.reasons["sindy"])
    assert "coefficients identical to rfs's on every record" in why
    assert "kept exactly the model's 1 terms on 3 of 3 records" in why
    assert "v biased +5.0 %" in " ".join(v.reasons["rfs"])
