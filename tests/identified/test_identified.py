"""The identified model: immutable, complete, and the same numbers whichever layer asks."""

from __future__ import annotations

import dataclasses
import json
from html.parser import HTMLParser

import numpy as np
import pytest

import nlid
from nlid import IdentifiedModel
from nlid.model import physics
from nlid.scoring import free_run_error


@pytest.fixture(scope="module")
def record():
    return nlid.simulate("paper-numerical", seed=2, noise=0.02, channels="z,a", duration=12)


@pytest.fixture(scope="module")
def fit(record):
    return nlid.identify(record, "z^3, z^2, v*|v|", "rfs", mass=0.2)


def test_immutable(fit):
    with pytest.raises(dataclasses.FrozenInstanceError):
        fit.mass = 1.0  # type: ignore[misc]
    with pytest.raises(TypeError):
        fit.coefficients["z"] = 0.0  # type: ignore[index]
    with pytest.raises(TypeError):
        fit.diagnostics["x"] = 1  # type: ignore[index]
    with pytest.raises(ValueError):
        fit.theta[0] = 1.0


def test_binds_model_coefficients_and_physics(fit, record):
    assert fit.terms == ("1", "z", "z^2", "z^3", "v", "v*|v|") and fit.method == "rfs"
    assert fit.mass == 0.2 and not fit.mass_estimated and fit.options == {"cutoff": None, "decimate": 1}
    assert len(fit.equilibria.stable) == 2 and len(fit.equilibria.unstable) == 1
    for mode, z0 in zip(fit.modal, fit.equilibria.stable, strict=True):
        assert mode.equilibrium == z0 and 8 < mode.fn_hz < 14 and 0.02 < mode.zeta < 0.06
    z = np.linspace(-0.03, 0.03, 7)
    v = np.linspace(-1, 1, 7)
    np.testing.assert_allclose(fit.restoring_force(z, v), fit.elastic(z) + fit.damping(z, v))
    np.testing.assert_allclose(fit.elastic(z), physics.elastic(fit.model, fit.coefficients, z))
    # the potential's minima are the stable equilibria (Eq. 7)
    grid = np.linspace(-0.035, 0.025, 6001)
    u = fit.potential(grid)
    minima = grid[1:-1][(u[1:-1] < u[:-2]) & (u[1:-1] < u[2:])]
    np.testing.assert_allclose(minima, fit.equilibria.stable, atol=2e-5)
    assert fit.coefficient("v*abs(v)") == fit.coefficients["v*|v|"]


def test_scores_are_the_scoring_path(fit, record):
    assert fit.eps_percent == fit.scores.eps_percent == fit.score(record, free_run=False).eps_percent
    held = nlid.simulate("paper-numerical", seed=3, noise=0.02, channels="z,a", duration=12)
    scores = fit.score(held)
    run = free_run_error(fit, held)
    assert (scores.freerun_rmse, scores.freerun_note) == (run.rmse, run.note) or (
        np.isnan(scores.freerun_rmse) and scores.freerun_note == run.note
    )
    residual = fit.residual(held)
    rms = np.sqrt(np.mean(residual.r**2)) / np.sqrt(np.mean(residual.restoring**2))
    assert 100 * rms == pytest.approx(scores.eps_percent, rel=1e-9)


def test_json_round_trip(fit):
    text = json.dumps(fit.to_dict(), allow_nan=False)
    again = IdentifiedModel.from_dict(json.loads(text))
    assert again.to_dict() == fit.to_dict()
    assert again.equilibria == fit.equilibria and again.modal[0].fn_hz == fit.modal[0].fn_hz
    with pytest.raises(nlid.InputError, match="terms"):
        IdentifiedModel.from_dict({"coefficients": {}})
    with pytest.raises(nlid.InputError, match="layout"):
        IdentifiedModel.from_dict({**fit.to_dict(), "schema": "something/9"})


def test_px_model_round_trip_keeps_its_roots():
    rec = nlid.simulate("paper-experimental", seed=1, noise=0.02, channels="z,a", duration=30)
    fit = nlid.identify(rec, "z^3, z^2, sign(v)*|px(z)|", "rfs", mass=0.265)
    again = IdentifiedModel.from_dict(json.loads(json.dumps(fit.to_dict())))
    assert again.px_roots == fit.px_roots is not None
    np.testing.assert_allclose(again.restoring_force(0.01, 0.3), fit.restoring_force(0.01, 0.3))


def test_frame_summary_and_repr(fit):
    frame = fit.to_frame()
    assert list(frame.index) == list(fit.terms) and frame.loc["z^3", "unit"] == "N/m^3"
    assert frame.loc["v*|v|", "family"] == "damping" and np.isfinite(frame["std_error"]).all()
    text = str(fit.summary())
    assert text.startswith("method: rfs") and "epsilon (Eq. 26)" in text and "equilibria (m)" in text
    assert max(len(line) for line in text.splitlines()) <= 100
    assert repr(fit).startswith("<IdentifiedModel 'rfs'") and len(repr(fit)) < 120


def test_html_repr_renders(fit):
    class Cells(HTMLParser):
        def __init__(self):
            super().__init__()
            self.cells, self.stack = [], []

        def handle_starttag(self, tag, attrs):
            self.stack.append(tag)

        def handle_endtag(self, tag):
            assert self.stack.pop() == tag, f"unbalanced </{tag}>"

        def handle_data(self, data):
            if self.stack and self.stack[-1] in ("td", "code"):
                self.cells.append(data)

    parser = Cells()
    parser.feed(fit._repr_html_())
    assert not parser.stack
    assert "v*|v|" in parser.cells and "N*s^2/m^2" in parser.cells


def test_simulate_gives_a_record_the_model_reproduces(fit, record):
    sim = fit.simulate(record.f[:4000], record.fs, x0=(float(record.z[0]), 0.0), force_hold="zoh")
    assert isinstance(sim, nlid.Record) and sim.n == 4000 and sim.channels == ("f", "z", "v", "a")
    assert sim.meta["truth"]["coefficients"] == dict(fit.coefficients)
    refit = nlid.identify(sim, fit.model, "rfs", mass=fit.mass)
    for name, value in fit.coefficients.items():
        assert refit.coefficients[name] == pytest.approx(value, rel=1e-4, abs=1e-6), name


def test_plots_draw_on_given_axes(fit, record):
    from nlid.report.plotting import new_figure

    fig, axes = new_figure(2, 2)
    assert fit.plot_stiffness(ax=axes[0, 0]) is axes[0, 0]
    assert len(axes[0, 0].lines) >= 3  # K(z), zero line, equilibria
    fit.plot_surface(record, ax=axes[0, 1])
    fit.plot_residual(record, against="v", ax=axes[1, 0])
    fit.plot_damping_slice(record, fit.equilibria.stable[0], ax=axes[1, 1])
    assert all(ax.get_xlabel() for ax in axes.ravel())
    own = fit.plot_stiffness(potential=True)
    assert own.get_ylabel() == "U(z) (J)"
    with pytest.raises(nlid.InputError, match="against"):
        fit.plot_residual(record, against="t")
