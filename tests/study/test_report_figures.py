"""Regression tests of the study figures and the verdict text, read from the drawn artists (issue 23)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from nlid.study.report.figures import draw_summary
from nlid.study.report.section import Section
from nlid.study.report.verdict import build_verdict

SECONDS = {"rfs": [0.08, 0.09, 0.087], "sindy": [1.3, 1.4, 1.5]}


def _tied_section(seconds: dict[str, list[float]] = SECONDS) -> Section:
    """rfs and sindy with identical coefficients on every record (a tie) but their own times."""
    rows = []
    for method, times in seconds.items():
        for rep, t in enumerate(times):
            coef = 1.0 + 0.01 * (rep + 1)
            rows.append(
                {
                    "method": method,
                    "repetition": rep,
                    "status": "ok",
                    "coef:v": coef,
                    "coef_error_pct:v": 100 * (coef - 1.0),
                    "seconds": t,
                }
            )
    return Section("d", "m", "", ["v"], list(seconds), pd.DataFrame(rows), None)


def _bars(ax) -> list[tuple[str, float]]:
    """``(label of the bar's container, height)`` of every bar (Rectangle patch) drawn on ``ax``."""
    from matplotlib.container import BarContainer

    out = [(c.get_label(), float(p.get_height())) for c in ax.containers if isinstance(c, BarContainer) for p in c]
    assert len(out) == len(ax.patches)  # every patch of the axes is one of these bars
    return out


def test_summary_draws_one_bar_per_method_with_its_own_time():
    fig = draw_summary(_tied_section())
    time_ax = next(ax for ax in fig.axes if ax.get_title().startswith("time"))
    bars = dict(_bars(time_ax))
    assert set(bars) == {"rfs", "sindy"}  # no merged "rfs = sindy" bar
    assert bars["rfs"] == pytest.approx(np.median(SECONDS["rfs"]))
    assert bars["sindy"] == pytest.approx(np.median(SECONDS["sindy"]))
    coef_ax = next(ax for ax in fig.axes if ax.get_title().startswith("coefficients"))
    coef = dict(_bars(coef_ax))
    assert coef["rfs"] == pytest.approx(coef["sindy"]) == pytest.approx(2.0)  # identical: equal bars
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    assert legend == ["rfs", "sindy (= rfs)"]


def test_summary_panel_titles_are_not_clipped():
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig = draw_summary(_tied_section())
    FigureCanvasAgg(fig).draw()
    box = fig.bbox
    for ax in fig.axes:
        title = ax.title.get_window_extent()
        assert box.x0 <= title.x0 and title.x1 <= box.x1, ax.get_title()


def test_a_tie_is_called_a_tie_in_the_verdict():
    v = build_verdict(_tied_section())
    text = v.text()
    assert "No method has a scored metric yet" not in text
    assert "the only method with a value" not in text
    assert v.headline().startswith("Overall: rfs and sindy tie")
    f = next(f for f in v.findings if f.key == "coef_error_pct:v")
    assert "rfs and sindy tie" in f.sentence() and f.cells()[-1] == "rfs and sindy tie: identical on every record"
    assert "Tied (identical on every record): rfs and sindy on 1 metric(s)." in v.separation()
    time = next(f for f in v.findings if f.key == "seconds")
    assert [e.name for e in time.entries] == ["rfs", "sindy"]  # the cost keeps each method's own value


def test_equal_mean_ranks_are_a_tie_and_a_lone_method_is_not_called_unscored():
    rows = [
        {"method": m, "repetition": r, "status": "ok", "coef_error_pct:v": e, "coef_error_pct:x": x, "seconds": 1.0}
        for m, errs in {"a": [(1.0, 5.0), (1.1, 5.1)], "b": [(5.0, 1.0), (5.1, 1.1)]}.items()
        for r, (e, x) in enumerate(errs)
    ]
    section = Section("d", "m", "", ["v", "x"], ["a", "b"], pd.DataFrame(rows), None)
    assert build_verdict(section).headline().startswith("Overall: a and b tie (mean rank")
    alone = Section("d", "m", "", ["v", "x"], ["a"], pd.DataFrame([r for r in rows if r["method"] == "a"]), None)
    headline = build_verdict(alone).headline()
    assert headline.startswith("Overall: only a has scored metrics")
