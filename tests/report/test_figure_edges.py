"""Figures a newcomer misread (issue 35, item 5): no elastic force without a spring; legends off the data."""

from __future__ import annotations

import numpy as np
import pytest

import nlid
from nlid.report.plotting import new_figure


@pytest.fixture(scope="module")
def friction_fit(short_record):
    """A model without a spring (as EMPS's): v, sign(v) and the constant 1."""
    return nlid.identify(short_record, "v, sign(v)", "rfs", mass=0.2, without="z")


def test_no_spring_no_elastic_force(friction_fit):
    assert "z" not in friction_fit.terms and "1" in friction_fit.terms
    for potential in (False, True):
        ax = friction_fit.plot_stiffness(potential=potential)
        assert not ax.lines  # nothing drawn as K(z) or U(z)
        note = [t for t in ax.texts if t.get_gid() == "no-spring"]
        assert note and "no spring" in note[0].get_text() and "constant term 1" in note[0].get_text()
        assert "elastic force" not in ax.get_title().replace("no elastic force", "")


def test_a_spring_is_still_drawn(short_record):
    fit = nlid.identify(short_record, "z^3, z^2, v*|v|", "rfs", mass=0.2)
    _, ax = new_figure()
    fit.plot_stiffness(ax=ax)
    assert ax.lines and ax.get_title().endswith("elastic force")
    np.testing.assert_allclose(ax.lines[0].get_ydata(), fit.elastic(ax.lines[0].get_xdata()))


def _overlaps(a, b) -> bool:
    return a.x0 < b.x1 and b.x0 < a.x1 and a.y0 < b.y1 and b.y0 < a.y1


def _legend_clear_of_axes(fig) -> None:
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    FigureCanvasAgg(fig).draw()
    legends = [*fig.legends, *(ax.get_legend() for ax in fig.axes if ax.get_legend() is not None)]
    assert legends
    for legend in legends:
        box = legend.get_window_extent()
        assert all(not _overlaps(box, ax.get_window_extent()) for ax in fig.axes), "a legend covers the data"
        assert box.x0 >= fig.bbox.x0 - 0.5 and box.x1 <= fig.bbox.x1 + 0.5 and box.y0 >= fig.bbox.y0 - 0.5


@pytest.fixture(scope="module")
def cubic(short_record):
    return nlid.identify(short_record, "z^3, z^2, v*|v|", "rfs", mass=0.2)


def test_free_run_legend_is_off_the_curves(cubic, short_record):
    ax = cubic.plot_freerun(short_record, rule="window:100")  # nlid's own figure: the legend below the panels
    _legend_clear_of_axes(ax.figure)
    _, ax = new_figure(width=7.0, height=3.0)  # the user's axes: the legend beside them
    cubic.plot_freerun(short_record, ax=ax)
    _legend_clear_of_axes(ax.figure)


def test_frf_legend_is_off_the_curves(cubic):
    _legend_clear_of_axes(cubic.plot_frf().figure)


def test_study_frf_legend_is_below_the_panels(tmp_path):
    from types import SimpleNamespace

    from nlid.study.report import figures

    f = np.linspace(1.0, 60.0, 200)
    h = 1.0 / (800.0 - 0.2 * (2 * np.pi * f) ** 2 + 1j * 2 * np.pi * f)
    drawn = []
    cache = SimpleNamespace(fresh=lambda stem, key: False, save=lambda fig, stem, key: drawn.append(fig))
    rec = {
        "run_id": "paper-numerical/0",
        "result": {"mass": 0.2, "diagnostics": {}, "modal": [{"equilibrium": 0.01, "fn_hz": 10.0, "stiffness": 800.0}]},
    }
    section = SimpleNamespace(dataset="d", model="m")
    arrays = {"frf_frequency_hz": f, "frf": h}
    assert figures._frf_figure(section, "nsi-ip", rec, arrays, tmp_path, cache, "k") is not None
    _legend_clear_of_axes(drawn[0])
