"""The corrected estimate's covariance is the sum of the parts ``indirect_inference`` reports (issue 35).

``benchmarks/calibration_sandwich.py`` compares each part with the spread of
the estimates over replicates; the parts must add up to the covariance the
posterior samples, and asking for them must not change it.
"""

import numpy as np

import nlid
from nlid.bayes.bias import indirect_inference
from nlid.bayes.likelihood import sandwich
from nlid.estimation.balance import regression_data
from nlid.model.terms import Model


def test_the_parts_add_up_to_the_covariance_and_leave_it_unchanged():
    record = nlid.simulate("paper-numerical", seed=3, duration=10.0, noise=0.02, channels=("z", "v"))
    model = Model.from_spec("z^3, z^2, v*|v|")
    data = regression_data(record, model)
    _, theta_hat, V, _, _ = sandwich(data.G, data.restoring_force(record.mass), model.names)
    plain = indirect_inference(record, model, theta_hat, record.mass, data, V, rng=np.random.default_rng(1))
    parts: dict = {}
    centre, cov, _ = indirect_inference(
        record, model, theta_hat, record.mass, data, V, rng=np.random.default_rng(1), parts=parts
    )
    assert np.array_equal(centre, plain[0]) and np.array_equal(cov, plain[1])
    assert parts["level_moves"], "the velocity's level is estimated: its move is a part"
    total = parts["sampling"] + (1.0 + 1.0 / 4) * parts["spread"]
    total = total + sum(np.outer(m, m) for m in parts["level_moves"])
    assert np.allclose(0.5 * (total + total.T), cov, rtol=1e-12, atol=0.0)
    assert parts["spread_dof"] == 2 + 2 + 4 - 3  # the pairs of the three steps less one mean per step


def _benchmark():
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[2] / "benchmarks" / "calibration_sandwich.py"
    spec = importlib.util.spec_from_file_location("calibration_sandwich", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_benchmarks_variance_dof_is_the_batch_count_for_gaussian_scores_and_fewer_for_bursts():
    variance_dof = _benchmark().variance_dof
    rng = np.random.default_rng(5)
    white = rng.standard_normal((40_000, 1))
    nu = variance_dof(white, np.eye(1), 400)  # 100 batches
    assert 60 < nu[0] < 160  # K = 100 up to the scatter of a fourth moment estimated from 100 sums
    # about 12 scores 100 times the others: the batches holding one carry the variance, ~10-22 dof over seeds
    bursts = white * np.where(rng.random((40_000, 1)) < 0.0003, 100.0, 1.0)
    assert variance_dof(bursts, np.eye(1), 400)[0] < 30
