"""plot_freerun and plot_frf of an identified model, read from the drawn artists (issue 23)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from matplotlib.collections import PolyCollection
from matplotlib.figure import Figure

from nlid import identify
from nlid.base.formatting import sig
from nlid.errors import InputError
from nlid.simulation.presets import get_preset


@pytest.fixture(scope="module")
def preset():
    return get_preset("paper-numerical").with_overrides(duration=2.0)


@pytest.fixture(scope="module")
def record(preset):
    """2 s of paper-numerical (two wells), 1 % noise on z."""
    return preset.simulate(3, noise=0.01, channels=("z",))


@pytest.fixture(scope="module")
def fit(preset, record):
    return identify(record, preset.model(), "rfs", mass=preset.mass)


def _line(ax, label: str):
    return next(line for line in ax.get_lines() if line.get_label() == label)


def _legend_title(ax) -> str:
    """The title of the axes' legend, or of the figure's (nlid's own figures put it below the panels)."""
    legend = ax.get_legend() or ax.figure.legends[0]
    return " ".join(legend.get_title().get_text().split())


def test_freerun_draws_measured_simulated_error_rule_and_unscored_window(fit, record):
    ax = fit.plot_freerun(record, rule="window:100")
    scores = fit.score(record, rule="window:100")
    fig = ax.figure
    assert isinstance(fig, Figure) and len(fig.axes) == 2
    below = fig.axes[1]
    np.testing.assert_array_equal(_line(ax, "measured z").get_ydata(), record.z)
    z_sim = np.asarray(_line(ax, "free run z_sim").get_ydata())
    error = np.asarray(_line(below, "z_sim - z").get_ydata())
    np.testing.assert_allclose(error, z_sim - record.z)
    # the run drawn is the run scored: its RMS error over the scored samples is the score's
    assert np.sqrt(np.mean(error[100:] ** 2)) == pytest.approx(scores.freerun_rmse, rel=1e-9)
    assert _legend_title(ax) == f"transient rule: {scores.freerun_rule}"
    span = next(p for p in ax.patches if p.get_label().startswith("not scored"))
    box = span.get_bbox()  # the span's extent in data units along x
    assert (box.x0, box.x1) == pytest.approx((record.t[0], record.t[100]))
    assert f"NRMSE {sig(scores.freerun_nrmse_percent, 3)} %" in ax.get_title()
    np.testing.assert_array_equal(_line(ax, "measured z").get_xdata(), record.t)


def test_freerun_on_given_axes_draws_the_error_as_a_band(fit, record):
    from nlid.report.plotting import new_figure

    _, given = new_figure()
    ax = fit.plot_freerun(record, ax=given)
    assert ax is given and len(ax.figure.axes) == 1
    band = [c for c in ax.collections if isinstance(c, PolyCollection) and c.get_label() == "error z_sim - z"]
    assert len(band) == 1
    assert not any(p.get_label().startswith("not scored") for p in ax.patches)  # every sample scored
    assert _legend_title(ax) == f"transient rule: {fit.score(record).freerun_rule}"


def test_freerun_and_frf_need_the_mass(fit, record):
    massless = dataclasses.replace(fit, mass=None)
    with pytest.raises(InputError, match="mass"):
        massless.plot_freerun(record)
    with pytest.raises(InputError, match="mass"):
        massless.plot_frf()


def test_frf_peaks_at_each_wells_natural_frequency(fit):
    ax = fit.plot_frf()
    stable = fit.equilibria.stable
    assert len(stable) == 2 and len(fit.modal) == 2
    curves = [line for line in ax.get_lines() if line.get_label().startswith("linearised at")]
    assert len(curves) == len(stable)
    phase_ax = ax.figure.axes[1]
    phases = [line for line in phase_ax.get_lines() if len(line.get_xdata()) > 2]
    for k, m in enumerate(sorted(fit.modal, key=lambda m: m.equilibrium)):
        line = next(c for c in curves if c.get_label().startswith(f"linearised at z* = {sig(m.equilibrium, 3)} m"))
        f, h = np.asarray(line.get_xdata()), np.asarray(line.get_ydata())
        step = f[1] - f[0]
        peak = f[np.argmax(h)]
        # the receptance peaks at fn sqrt(1 - 2 zeta^2), within one frequency step
        assert abs(peak - m.fn_hz * np.sqrt(1 - 2 * m.zeta**2)) <= step, k
        # and its phase passes -90 degrees at fn
        phase = next(p for p in phases if p.get_color() == line.get_color())
        assert np.interp(m.fn_hz, f, phase.get_ydata()) == pytest.approx(-90.0, abs=1.0)
        assert f"fn {sig(m.fn_hz, 3)} Hz" in line.get_label()


def test_frf_of_nsi_overlays_its_identified_frf(preset, record):
    nsi = identify(record, preset.model(), "nsi-ip", mass=preset.mass)
    ax = nsi.plot_frf(phase=False)
    assert len(ax.figure.axes) == 1
    own = next(line for line in ax.get_lines() if "identified underlying-linear system" in line.get_label())
    np.testing.assert_allclose(own.get_ydata(), np.abs(nsi.arrays["frf"]))
    np.testing.assert_allclose(own.get_xdata(), nsi.arrays["frf_frequency_hz"])
    assert sum(line.get_label().startswith("linearised at") for line in ax.get_lines()) == len(nsi.equilibria.stable)
