"""simulation.simulate_segments: free runs of segments and their forward sensitivities (output-error fits)."""

from __future__ import annotations

import numpy as np
import pytest

from nlid.errors import InputError
from nlid.model.terms import Model, Term
from nlid.scoring import predictability_horizon
from nlid.scoring.scores import HORIZON_STARTS, SENSITIVITY_DELTA, SENSITIVITY_LIMIT, initial_state
from nlid.simulation import fine_force, free_run, sensitivity_columns, simulate_segments
from nlid.simulation.presets import get_preset

CASES = [
    ("z^3, z^2, v*|v|", {"z^3": 1e6, "z^2": 5e3, "z": 200.0, "v": 1.0, "v*|v|": 5.0, "1": 1.0}, 0.2, 500.0, 20.0),
    (
        "z^3, sign(v)*exp(-(v/0.05)^2), tanh(v/0.01), sign(v)*|px(z)|",
        {
            "z^3": 1e6,
            "z": -300.0,
            "v": 1.0,
            "1": 0.0,
            "sign(v)*exp(-(v/0.05)^2)": 2.0,
            "tanh(v/0.01)": 1.0,
            "sign(v)*|px(z)|": 0.5,
        },
        0.2,
        500.0,
        20.0,
    ),
    ("bouc_wen(800, -1100)", {"z": 5e4, "v": 10.0, "bouc_wen(800, -1100)": 5e4, "1": 0.0}, 2.0, 750.0, 50.0),
    (
        "dahl(0.001), gap(z, 0.002), stop(v, -0.1)",
        {"z": 300.0, "v": 2.0, "1": 0.0, "dahl(0.001)": 3.0, "gap(z, 0.002)": 1e4, "stop(v, -0.1)": 5.0},
        0.2,
        500.0,
        20.0,
    ),
]


def _with_shapes_exact(term: Term, values) -> Term:
    """``term`` with other shape parameters, not rounded (finite differences need small steps)."""
    if term.memory is not None:
        return Term(memory=(term.memory[0], tuple(values)))
    special = tuple((k, var, float(v), m) for (k, var, _, m), v in zip(term.special, values, strict=True))
    return Term(z=term.z, v=term.v, px=term.px, special=special)


def _model(spec):
    model = Model.from_spec(spec)
    if model.uses_px:
        model = model.with_px_roots((-0.03, 0.025))
    return model


@pytest.mark.parametrize("spec, coefficients, mass, fs, amplitude", CASES, ids=[c[0] for c in CASES])
def test_one_segment_is_the_free_run(spec, coefficients, mass, fs, amplitude):
    model = _model(spec)
    force = np.random.default_rng(0).standard_normal(1000) * amplitude
    memory = sum(t.is_memory for t in model.terms)
    for hold in ("sampled", "zoh"):
        z, v, a = free_run(model, coefficients, mass, force, fs, force_hold=hold, x0=(0.001, 0.01))
        x0 = np.zeros((1, 2 + memory))
        x0[0, :2] = (0.001, 0.01)
        run = simulate_segments(model, coefficients, mass, force, fs, [0], x0, force_hold=hold)
        for mine, ref in ((run.z, z), (run.v, v), (run.a, a)):
            assert np.max(np.abs(mine - ref)) <= 1e-9 * np.max(np.abs(ref))


@pytest.mark.parametrize("spec, coefficients, mass, fs, amplitude", CASES, ids=[c[0] for c in CASES])
def test_sensitivities_are_the_derivatives_of_the_discrete_free_run(spec, coefficients, mass, fs, amplitude):
    """Every column against central differences of the simulated displacement, velocity and acceleration."""
    model = _model(spec)
    force = np.random.default_rng(1).standard_normal(300) * amplitude
    memory = sum(t.is_memory for t in model.terms)
    x0 = np.zeros((2, 2 + memory))
    x0[:, 0] = 0.001
    x0[:, 1] = 0.02  # not 0: sign(v) is not differentiable there
    starts = [0, 150]
    theta = model.vector(coefficients)
    run = simulate_segments(model, theta, mass, force, fs, starts, x0, oversample=4)
    columns = sensitivity_columns(model)
    assert run.sensitivities.shape == (3, 300, len(columns))
    shapes = [s for t in model.terms for s in t.shapes]
    base = [*theta, mass, *shapes, *x0[0]]
    for j, name in enumerate(columns):
        h = 1e-7 * max(abs(base[j]), 1e-3) if base[j] != 0 or j >= len(theta) else 1e-7 * amplitude

        def sim(delta, j=j, name=name):
            th, m, x, terms = theta.copy(), mass, x0.copy(), list(model.terms)
            if j < len(theta):
                th[j] += delta
            elif name == "mass":
                m += delta
            elif j >= len(columns) - 2 - memory:
                x[:, j - (len(columns) - 2 - memory)] += delta
            else:
                term_name, shape = name.rsplit(":", 1)
                i = model.names.index(term_name)
                values = list(terms[i].shapes)
                values[terms[i].shape_names.index(shape)] += delta
                terms[i] = _with_shapes_exact(terms[i], values)
                other = Model(tuple(terms), model.px_roots)
                order = [other.terms.index(t) for t in terms]
                th2 = np.empty_like(th)
                th2[order] = th
                out = simulate_segments(other, th2, m, force, fs, starts, x, oversample=4, sensitivities=False)
                return np.array([out.z, out.v, out.a])
            out = simulate_segments(model, th, m, force, fs, starts, x, oversample=4, sensitivities=False)
            return np.array([out.z, out.v, out.a])

        fd = (sim(h) - sim(-h)) / (2 * h)
        err = np.max(np.abs(fd[:2] - run.sensitivities[:2, :, j])) / np.max(np.abs(fd[:2]))
        assert err < 1e-4, f"{name}: relative error {err:.2e}"


def test_segments_start_from_their_own_states_and_report_their_ends():
    p = get_preset("paper-numerical")
    model = p.model()
    force = np.random.default_rng(0).standard_normal(400) * 50
    whole = simulate_segments(
        model,
        dict(p.coefficients),
        p.mass,
        force,
        2048.0,
        [0],
        np.zeros((1, 2)),
        force_hold="zoh",
        oversample=1,
        sensitivities=False,
    )
    x0 = np.array([[0.0, 0.0], [whole.z[200], whole.v[200]]])
    split = simulate_segments(
        model, dict(p.coefficients), p.mass, force, 2048.0, [0, 200], x0, force_hold="zoh", oversample=1
    )
    assert np.array_equal(split.z, whole.z)  # the second segment starts from the first one's state
    assert np.array_equal(split.end_state[0], x0[1])
    assert split.end_sensitivities.shape == (2, 2, len(split.columns))


@pytest.mark.parametrize("spec, coefficients, mass, fs, amplitude", CASES, ids=[c[0] for c in CASES])
def test_runs_without_some_columns_are_the_run_with_all_to_the_bit(spec, coefficients, mass, fs, amplitude):
    """No sensitivities, or the initial state's alone: the same states and columns as the run with every column
    (each kernel forms the products and sums of the full one, in its order)."""
    model = _model(spec)
    force = np.random.default_rng(2).standard_normal(600) * amplitude
    memory = sum(t.is_memory for t in model.terms)
    x0 = np.zeros((3, 2 + memory))
    x0[:, 0] = (0.001, -0.002, 0.0005)
    x0[:, 1] = (0.01, 0.0, -0.02)
    starts = [0, 150, 400]
    full = simulate_segments(model, coefficients, mass, force, fs, starts, x0, oversample=3)
    plain = simulate_segments(model, coefficients, mass, force, fs, starts, x0, oversample=3, sensitivities=False)
    states = simulate_segments(model, coefficients, mass, force, fs, starts, x0, oversample=3, sensitivities="states")
    own = len(full.columns) - (2 + memory)
    assert states.columns == full.columns[own:] == ("z0", "v0", *(f"w0:{t.name}" for t in model.terms if t.is_memory))
    for run in (plain, states):
        for x in ("z", "v", "a", "end_state"):
            assert np.array_equal(getattr(run, x), getattr(full, x))
    assert plain.sensitivities is None
    assert np.array_equal(states.sensitivities, full.sensitivities[:, :, own:])
    assert np.array_equal(states.end_sensitivities, full.end_sensitivities[:, :, own:])
    with pytest.raises(InputError, match="sensitivities"):
        simulate_segments(model, coefficients, mass, force, fs, starts, x0, sensitivities="globals")


def test_bad_segments_are_refused():
    model = Model.from_spec("z^3")
    coefficients = {"z^3": 1e6, "z": 100.0, "v": 1.0, "1": 0.0}
    force = np.zeros(100)
    with pytest.raises(InputError, match="starts"):
        simulate_segments(model, coefficients, 0.2, force, 100.0, [10, 50], np.zeros((2, 2)))
    with pytest.raises(InputError, match="initial_states"):
        simulate_segments(model, coefficients, 0.2, force, 100.0, [0, 50], np.zeros((1, 2)))


def test_predictability_horizon_tells_chaotic_from_predictable_free_runs():
    """paper-experimental (the rig analogue) is chaotic; a single well driven softly is not."""
    chaotic = get_preset("paper-experimental").with_overrides(duration=30.0)
    record = chaotic.simulate(0)
    horizon = predictability_horizon(chaotic.model(), dict(chaotic.coefficients), chaotic.mass, record, oversample=1)
    assert horizon is not None and 0.1 < horizon < 15.0
    calm = get_preset("paper-numerical").with_overrides(duration=10.0, force_rms=5.0)
    record = calm.simulate(0)
    assert predictability_horizon(calm.model(), dict(calm.coefficients), calm.mass, record, oversample=1) is None


@pytest.mark.parametrize("hold", ["sampled", "zoh"])
@pytest.mark.parametrize("spec, coefficients, mass, fs, amplitude", CASES, ids=[c[0] for c in CASES])
def test_a_run_continued_from_its_end_state_is_the_same_run_to_the_bit(spec, coefficients, mass, fs, amplitude, hold):
    """What predictability_horizon relies on to read every window of its reference run off one run."""
    model = _model(spec)
    force = np.random.default_rng(3).standard_normal(700) * amplitude
    memory = sum(t.is_memory for t in model.terms)
    x0 = np.zeros((1, 2 + memory))
    x0[0, :2] = (0.001, -0.01)
    fine = fine_force(force, hold, 4)
    whole = simulate_segments(
        model, coefficients, mass, force, fs, [0], x0, oversample=4, sensitivities=False, fine=fine
    )
    head = simulate_segments(
        model, coefficients, mass, force[:311], fs, [0], x0, oversample=4, sensitivities=False, fine=fine[: 311 * 4]
    )
    tail = simulate_segments(
        model, coefficients, mass, force[311:], fs, [0], head.end_state.copy(), oversample=4, sensitivities=False,
        fine=fine[311 * 4 :],
    )  # fmt: skip
    assert np.array_equal(np.concatenate([head.z, tail.z]), whole.z)
    assert np.array_equal(tail.end_state, whole.end_state)


def test_predictability_horizon_is_the_median_of_its_pairs_each_run_on_its_own():
    """The definition, run pair by pair (a reference and a displaced run from each start), gives the same horizon."""
    preset = get_preset("paper-experimental").with_overrides(duration=20.0)
    record = preset.simulate(1)
    model, coefficients, mass = preset.model(), dict(preset.coefficients), preset.mass
    horizon = predictability_horizon(model, coefficients, mass, record, oversample=1)
    half, scale = record.n // 2, float(np.std(record.z))
    fine = fine_force(record.f, record.force_hold, 1)
    first = simulate_segments(
        model, coefficients, mass, record.f, record.fs, [0], np.array([initial_state(record)]), oversample=1,
        sensitivities=False, fine=fine,
    )  # fmt: skip
    times = []
    for start in np.unique(np.linspace(0, half, HORIZON_STARTS, endpoint=False).astype(int)):
        state = np.array([[first.z[start], first.v[start]]])
        window = slice(start, start + half)
        runs = []
        for shift in (0.0, SENSITIVITY_DELTA * scale):
            x0 = state + np.array([[shift, 0.0]])
            run = simulate_segments(
                model, coefficients, mass, record.f[window], record.fs, [0], x0, oversample=1, sensitivities=False,
                fine=fine[window],
            )  # fmt: skip
            runs.append(run.z)
        apart = np.flatnonzero(np.abs(runs[0] - runs[1]) > SENSITIVITY_LIMIT * scale)
        times.append(apart[0] / record.fs if apart.size else np.inf)
    expected = float(np.median(times))
    assert horizon is not None and np.isfinite(expected)
    assert horizon == pytest.approx(expected, rel=1e-9)
