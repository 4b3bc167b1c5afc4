"""The output-error problem (nlid_oe.problem): the reduced problem the optimiser sees is the full one."""

from __future__ import annotations

import numpy as np
import pytest

from nlid.simulation import fine_force
from nlid.simulation.presets import get_preset
from nlid_oe.problem import Parameter, Problem


def _problem(segment_samples: int, window_tail: bool = True) -> Problem:
    preset = get_preset("paper-numerical").with_overrides(duration=2.0)
    record = preset.simulate(1, noise={"z": 0.02, "a": 0.02}, channels=("z", "a"))
    model = preset.model()
    truth = preset.truth()["coefficients"]
    theta = model.vector(truth) * (1 + 0.03 * np.cos(np.arange(len(model.terms))))  # off the truth
    starts = np.arange(0, record.n, segment_samples)
    if window_tail and record.n - starts[-1] < segment_samples // 2:
        starts = starts[:-1]
    v = np.gradient(record.z, 1 / record.fs)
    states = np.column_stack([record.z, v])[starts]
    params = [Parameter("theta", i, name=n) for i, n in enumerate(model.names)] + [Parameter("mass", name="mass")]
    scales = np.append(np.abs(theta), preset.mass)
    return Problem(
        model,
        record,
        params,
        theta,
        preset.mass,
        starts,
        states,
        ("z", "a"),
        1,
        fine_force(record.f, record.force_hold, 1),
        scales,
        np.array([np.std(record.z), np.std(v)]),
        1.0,
    )


@pytest.mark.parametrize("segment_samples", [4096, 1000, 300])  # one segment; a longer last one; a shorter
def test_the_reduced_problem_has_the_full_problems_cost_and_steps(segment_samples):
    problem = _problem(segment_samples)
    problem.dense_limit = 10**9
    u = problem.start() * (1 + 1e-3 * np.sin(np.arange(problem.size)))
    r, J = problem.residual(u), problem.jacobian(u)
    rr, Jr = problem.reduced(u)
    assert rr.size == problem.reduced_rows < r.size
    assert rr @ rr == pytest.approx(r @ r, rel=1e-10)
    np.testing.assert_allclose(Jr.T @ rr, J.T @ r, rtol=1e-8, atol=1e-8 * np.abs(J.T @ r).max())
    np.testing.assert_allclose(Jr.T @ Jr, J.T @ J, rtol=1e-8, atol=1e-8 * np.abs(J.T @ J).max())
    rng = np.random.default_rng(0)
    for _ in range(3):  # the linearised cost of any step: what the trust-region solver minimises
        p = rng.normal(size=problem.size)
        full, reduced = J @ p + r, Jr @ p + rr
        assert reduced @ reduced == pytest.approx(full @ full, rel=1e-9)


def test_a_diverging_point_costs_as_much_in_the_reduced_problem():
    problem = _problem(700)
    u = problem.start()
    u[0] *= -1e6  # a linear stiffness far negative: the free run diverges
    r, rr = problem.residual(u), problem.reduced_residual(u)
    assert problem.diverged
    assert rr @ rr == pytest.approx(r @ r)


def test_fitting_the_states_on_windows_lowers_every_segments_cost():
    problem = _problem(700)
    u0 = problem.start()
    u1 = problem.fit_states(u0)
    assert np.array_equal(u1[: problem.G], u0[: problem.G])  # the global parameters are held
    seg = np.repeat(problem.segment_of, problem.C)
    cost0 = np.bincount(seg, problem.residual(u0)[: problem.rows_data] ** 2)
    cost1 = np.bincount(seg, problem.residual(u1)[: problem.rows_data] ** 2)
    assert np.all(cost1 <= cost0 * (1 + 1e-12))
    assert cost1.sum() < 0.5 * cost0.sum()
