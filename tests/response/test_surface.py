"""The result object, the methods on the identified model, argument checks, and the command line."""

from __future__ import annotations

import json

import numpy as np
import pytest

from nlid.errors import InputError
from nlid.response import FrequencyResponse, Settings, force_response, frequency_response
from nlid.response.result import FRAME_COLUMNS


@pytest.fixture(scope="module")
def response(duffing):
    return duffing.frequency_response([0.5, 1.0], (12, 28))


def test_the_result_is_tidy_plain_and_drawn(response):
    assert isinstance(response, FrequencyResponse) and len(response.curves) == 2
    frame = response.to_frame()
    assert tuple(frame.columns) == FRAME_COLUMNS and len(frame) == sum(len(c) for c in response.curves)
    data = json.loads(json.dumps(response.to_dict(), allow_nan=False))
    assert data["schema"].startswith("nlid.FrequencyResponse") and len(data["folds"]) == 4
    text = str(response.summary())
    assert "fold" in text and "backbone" in text
    ax = response.plot()
    assert ax.get_xlabel() == "frequency (Hz)" and len(ax.lines) > 4


def test_the_plot_draws_on_given_axes(response):
    from nlid.report.plotting import new_figure

    _, ax = new_figure()
    assert response.plot(ax=ax, quantity="peak") is ax


def test_continuation_in_the_force_amplitude(duffing):
    resp = force_response(duffing, 18.5, (0.05, 3.0))
    (curve,) = resp.curves
    assert (
        curve.parameter == "force" and curve.force[0] == pytest.approx(0.05) and curve.force[-1] == pytest.approx(3.0)
    )
    assert len(curve.folds) == 2  # above the linear resonance the hardening curve folds twice in the force too
    assert not curve.stable[curve.folds[0].index + 1 : curve.folds[1].index].any()


def test_the_response_saves_its_files(response, tmp_path):
    paths = response.save(tmp_path / "out")
    names = sorted(p.name for p in paths)
    assert names == ["response.csv", "response.json", "response.md", "response.png"]


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"force": -1.0, "band": (10, 20)}, "force="),
        ({"force": 1.0, "band": (20, 10)}, "band="),
        ({"force": 1.0, "band": "a:b"}, "band="),
        ({"force": 1.0, "band": (10, 20), "harmonics": 0}, "harmonics="),
        ({"force": "1,x", "band": (10, 20)}, "force="),
        ({"force": 1.0, "band": (10, 20), "starts": [[1.0, 2.0]]}, "starts="),
        ({"force": 1.0, "band": (10, 20), "settings": Settings(step=0.0)}, "step"),
        ({"force": 1.0, "band": (10, 20), "dof": 2}, "dof="),
    ],
)
def test_bad_arguments_name_the_parameter(duffing, kwargs, match):
    with pytest.raises(InputError, match=match):
        frequency_response(duffing, **kwargs)


def test_a_model_without_mass_is_refused(duffing):
    import dataclasses

    with pytest.raises(InputError, match="mass"):
        frequency_response(dataclasses.replace(duffing, mass=None), 1.0, (10, 20))


def test_the_command_line(duffing, tmp_path, cli):
    model = tmp_path / "model.json"
    model.write_text(json.dumps(duffing.to_dict()))
    status, out, _ = cli("response", str(model), "--force", "1", "--band", "12:28", "--no-verify", "--json")
    assert status == 0
    data = json.loads(out)
    assert len(data["curves"]) == 1 and len(data["folds"]) == 2
    status, _, err = cli("response", str(model), "--force", "1", "--band", "28:12")
    assert status == 2 and "--band" in err and "Traceback" not in err
    status, _, err = cli("response", str(model), "--band", "12:28")
    assert status == 2 and "--force" in err


def test_the_command_line_scores_a_measured_stepped_sine(duffing, tmp_path, cli):
    import pandas as pd

    from nlid.simulation import SineTest, simulate

    f, _ = SineTest("stepped", 1.0, (14.0, 20.0), steps=7, periods=40, directions="up").force(512.0)
    z, _, _ = simulate(duffing.model, duffing.theta, duffing.mass, f, 512.0)
    data = tmp_path / "stepped.csv"
    pd.DataFrame({"t": np.arange(f.size) / 512.0, "load": f, "x": z}).to_csv(data, index=False)
    model = tmp_path / "model.json"
    model.write_text(json.dumps(duffing.to_dict()))
    status, out, _ = cli(
        "response", str(model), "--measured", str(data), "--measured-columns", "f=load,z=x", "--no-verify", "--json"
    )
    assert status == 0
    measured = json.loads(out)["measured"]
    assert len(measured["frequency_hz"]) == 7 and measured["error_percent"] < 1.0
