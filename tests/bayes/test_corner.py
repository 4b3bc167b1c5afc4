"""The posterior's corner plot, read from its drawn artists: the title fits, the record's truth is drawn (issue 23)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import to_rgba
from matplotlib.text import Text

from nlid import identify
from nlid.bayes import sample_posterior
from nlid.bayes.plots import corner_figure
from nlid.simulation.presets import get_preset


@pytest.fixture(scope="module")
def posterior():
    """A posterior of the damping terms on 8 s of paper-numerical, whose record carries its truth."""
    preset = get_preset("paper-numerical").with_overrides(duration=8.0)
    record = preset.simulate(11, noise=0.02, channels=("z", "a"))
    fit = identify(record, preset.model(), "rfs", mass=preset.mass)
    return sample_posterior(record, fit, params="damping", seed=3)


def _suptitle(fig) -> Text:
    return next(c for c in fig.get_children() if isinstance(c, Text) and c.get_text() == fig.get_suptitle())


def _title_inside(fig) -> bool:
    FigureCanvasAgg(fig).draw()
    title = _suptitle(fig).get_window_extent()
    box = fig.bbox
    return title.x0 >= box.x0 and title.x1 <= box.x1 and title.y0 >= box.y0 and title.y1 <= box.y1


def _constant_lines(ax, axis: str) -> list[float]:
    """Positions of the black straight lines across ``ax`` (``axvline``: ``axis="x"``, ``axhline``: ``"y"``)."""
    out = []
    for line in ax.get_lines():
        data = np.asarray(line.get_xdata() if axis == "x" else line.get_ydata(), dtype=float)
        other = np.asarray(line.get_ydata() if axis == "x" else line.get_xdata(), dtype=float)
        if (
            data.size == 2
            and data[0] == data[1]
            and list(other) == [0, 1]
            and to_rgba(line.get_color()) == (0, 0, 0, 1)
        ):
            out.append(float(data[0]))
    return out


def test_the_corner_plot_draws_the_truth_the_record_carries(posterior):
    truth = posterior.reference
    assert set(posterior.names) <= set(truth)  # from record.meta["reference"]
    fig = corner_figure(posterior)
    d = len(posterior.names)
    axes = np.asarray(fig.axes).reshape(d, d)
    for i, name in enumerate(posterior.names):
        assert _constant_lines(axes[i, i], "x") == [pytest.approx(truth[name])]
        for j in range(i):
            assert _constant_lines(axes[i, j], "x") == [pytest.approx(truth[posterior.names[j]])]
            assert _constant_lines(axes[i, j], "y") == [pytest.approx(truth[name])]
        lo, hi = axes[i, i].get_xlim()
        assert lo < truth[name] < hi  # in view
    assert "black: truth" in fig.get_suptitle()
    assert _title_inside(fig)


@pytest.mark.parametrize("d", [1, 2, 4])
def test_the_corner_title_is_not_clipped(d):
    rng = np.random.default_rng(0)
    names = tuple(f"z^{k + 1}" for k in range(d))
    fake = SimpleNamespace(
        samples=rng.normal(size=(500, d)), names=names, start=dict.fromkeys(names, 0.0), reference={}
    )
    fig = corner_figure(fake)
    assert "truth" not in fig.get_suptitle()
    assert not any(_constant_lines(ax, "x") for ax in fig.axes)  # no truth, no black line
    assert _title_inside(fig)


def _inside(fig, artist) -> bool:
    box, extent = fig.bbox, artist.get_window_extent()
    return extent.x0 >= box.x0 - 0.5 and extent.x1 <= box.x1 + 0.5 and extent.y0 >= box.y0 - 0.5


@pytest.mark.parametrize("d", [1, 2, 4])
def test_the_corner_axes_say_their_units_and_no_label_is_cut(d):
    """Long friction terms (paper-experimental) with their units: every label and tick label is on the figure."""
    rng = np.random.default_rng(1)
    names = ("sign(v)*|px(z)|", "v*|px(z)|", "v*|v|*|px(z)|", "v^3*|px(z)|")[:d]
    units = dict(zip(names, ("N", "N*s/m", "N*s^2/m^2", "N*s^3/m^3"), strict=False))
    fake = SimpleNamespace(
        samples=rng.normal(size=(500, d)) * 1e3,
        names=names,
        start=dict.fromkeys(names, 0.0),
        reference={},
        unit=units.__getitem__,
    )
    fig = corner_figure(fake)
    FigureCanvasAgg(fig).draw()
    bottom = [ax for ax in fig.axes if ax.get_visible() and ax.get_xlabel()]
    assert [" ".join(ax.get_xlabel().split()) for ax in bottom] == [f"{n} ({units[n]})" for n in names]
    texts = [ax.xaxis.label for ax in bottom] + [ax.yaxis.label for ax in fig.axes if ax.get_ylabel()]
    for ax in bottom:  # the tick labels drawn: those inside the axis' view
        lo, hi = sorted(ax.get_xlim())
        texts += [t for t in ax.get_xticklabels() if t.get_text() and lo <= t.get_position()[0] <= hi]
    assert texts and all(_inside(fig, t) for t in texts)


def test_the_damping_title_fits_one_slice():
    from nlid.bayes.plots import damping_figure
    from nlid.bayes.result import DampingBand

    rng = np.random.default_rng(2)
    v = np.linspace(-2.0, 2.0, 50)
    band = DampingBand(0.0, 0.004, v, v - 0.1, v, v + 0.1, rng.uniform(-2, 2, 300), rng.normal(size=300))
    for bands in ([band], [band, band, band]):
        fig = damping_figure(bands, band_hz=41.0)
        assert _title_inside(fig)


def _orange_vlines(ax) -> list[float]:
    return [
        float(line.get_xdata()[0])
        for line in ax.get_lines()
        if to_rgba(line.get_color()) == to_rgba("tab:orange") and list(line.get_ydata()) == [0, 1]
    ]


@pytest.mark.parametrize("far", [1e3, -1e3])
def test_an_estimate_far_off_the_axes_is_drawn_at_the_edge_with_its_value(far):
    """Issue 35: Silverbox's estimate was 2 700 sd from the posterior; it is shown pointing out of the axes."""
    rng = np.random.default_rng(4)
    names = ("v", "z")
    fake = SimpleNamespace(samples=rng.normal(size=(2000, 2)), names=names, start={"v": far, "z": 0.5}, reference={})
    fig = corner_figure(fake)
    FigureCanvasAgg(fig).draw()
    axes = np.asarray(fig.axes).reshape(2, 2)
    lo, hi = axes[0, 0].get_xlim()
    assert hi - lo < 20  # the posterior keeps its axis: the estimate did not stretch it
    arrows = [t for t in axes[0, 0].texts if t.get_gid() == "estimate-off"]
    assert len(arrows) == 1 and f"{far:.4g}" in arrows[0].get_text()
    assert arrows[0].xy[0] == pytest.approx(hi if far > 0 else lo)  # the arrow's head is on the edge it points past
    assert _inside(fig, arrows[0])
    assert _orange_vlines(axes[0, 0]) == []  # no line at a position the axes do not show
    # below the diagonal: a triangle on the edge pointing out, at the other coordinate's value
    (mark,) = [line for line in axes[1, 0].get_lines() if line.get_gid() == "estimate-off"]
    assert mark.get_marker() == (">" if far > 0 else "<")
    assert float(mark.get_xdata()[0]) == pytest.approx(hi if far > 0 else lo)
    assert float(mark.get_ydata()[0]) == pytest.approx(0.5)
    assert "off the axes" in " ".join(fig.get_suptitle().split())
    # the estimate of z is in view as before
    assert _orange_vlines(axes[1, 1]) == [pytest.approx(0.5)]


def test_an_estimate_just_outside_the_posterior_is_brought_into_view():
    rng = np.random.default_rng(5)
    fake = SimpleNamespace(samples=rng.normal(size=(2000, 1)), names=("v",), start={"v": 6.0}, reference={})
    fig = corner_figure(fake)
    ax = fig.axes[0]
    lo, hi = ax.get_xlim()
    assert lo < 6.0 < hi and _orange_vlines(ax) == [pytest.approx(6.0)]
    assert not [t for t in ax.texts if t.get_gid() == "estimate-off"] and "off the" not in fig.get_suptitle()
