"""k-step-ahead prediction (:func:`nlid.scoring.predict`, ``IdentifiedModel.predict``, ``score(..., horizon=k)``)."""

from __future__ import annotations

import numpy as np
import pytest

import nlid
from nlid.errors import InputError
from nlid.identified.model import IdentifiedModel
from nlid.simulation.presets import get_preset


def _truth(preset) -> IdentifiedModel:
    return IdentifiedModel(preset.model(), preset.truth()["coefficients"], preset.mass, "truth")


@pytest.fixture(scope="module")
def exact():
    """paper-numerical's true model and its own free run (force held, v recorded): no noise, no scheme error."""
    preset = get_preset("paper-numerical").with_overrides(duration=1.0)
    true = _truth(preset)
    return true, true.simulate(preset.force(3), preset.fs, force_hold="zoh", x0=(0.01, 0.0))


@pytest.mark.parametrize("k", [1, 3, 8])
def test_the_true_model_predicts_its_own_noise_free_run_exactly(exact, k):
    true, record = exact
    pred = true.predict(record, horizon=k)
    assert np.all(np.isnan(pred.z[:k])) and np.all(np.isfinite(pred.z[k:]))
    assert np.max(np.abs(pred.z[k:] - record.z[k:])) <= 1e-12 * np.std(record.z)
    assert pred.horizon == k and pred.scored_samples == record.n - k
    assert pred.rmse <= 1e-12 * np.std(record.z) and pred.fit_percent == pytest.approx(100.0, abs=1e-9)


def test_each_sample_is_predicted_from_the_state_k_samples_before(exact):
    """A wrong model's prediction at sample i depends on the data up to i - k only."""
    true, record = exact
    wrong = IdentifiedModel(true.model, {**true.coefficients, "v": 3.0}, true.mass, "wrong")
    k, i = 4, 500
    full = wrong.predict(record, k).z[i]
    cut = record[: i + 1]  # the same record up to sample i (z and v measured, the force held: nothing filtered)
    assert wrong.predict(cut, k).z[i] == pytest.approx(full, rel=1e-6)


def test_a_window_rule_leaves_its_window_unscored(exact):
    true, record = exact
    pred = true.predict(record, 2, rule="window:100")
    assert pred.scored_samples == record.n - 100 and pred.rule.startswith("initialisation window of 100 samples")


def test_bad_horizons_are_refused(exact):
    true, record = exact
    for k in (0, -1, 2.5, True, record.n):
        with pytest.raises(InputError, match="horizon="):
            true.predict(record, k)
    unknown = IdentifiedModel(true.model, true.coefficients, None, "no mass")
    with pytest.raises(InputError, match="mass"):
        unknown.predict(record, 1)


def test_a_chaotic_record_gets_a_finite_prediction_but_no_free_run():
    """paper-experimental is chaotic: its free run means nothing, its k-step prediction does."""
    preset = get_preset("paper-experimental").with_overrides(duration=20.0)
    record = preset.simulate(5, noise=0.02, channels=("z", "a"))
    true = _truth(preset)
    short = true.score(record, horizon=1)
    assert short.freerun_note.startswith("skipped: chaotic") and np.isnan(short.freerun_rmse)
    assert short.predict_horizon == 1
    assert np.isfinite(short.predict_rmse) and 0.0 < short.predict_fit_percent < 100.0
    longer = true.predict(record, 5)
    assert np.isfinite(longer.rmse) and 0.0 < longer.fit_percent < short.predict_fit_percent  # worse further ahead
    noise = 0.02 * np.std(preset.simulate(5, channels=("z",)).z)
    assert short.predict_rmse < 3.0 * noise  # one sample ahead the true model is within a few noise sds


def test_score_without_a_horizon_leaves_the_prediction_out(exact):
    true, record = exact
    scores = true.score(record, free_run=False)
    assert scores.predict_horizon is None and np.isnan(scores.predict_rmse)
    assert nlid.scoring.predict(true, record, 2).horizon == 2
