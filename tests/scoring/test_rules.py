"""The transient rules of the free run (:mod:`nlid.scoring.rules`): each on a simulated record whose answer is known.

The true model scored under its record's own protocol must get the noise floor: its RMS free-run error is
the standard deviation ``sigma`` of the noise added to ``z``, within the statistical tolerance of an RMS of
``N`` independent samples (the RMS of ``N`` draws of ``N(0, sigma^2)`` has a relative standard deviation of
``1 / sqrt(2 N)``; the tests allow four of them).
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import nlid
from nlid import scoring
from nlid.base.jsonable import to_jsonable
from nlid.data.datasets import BOUC_WEN_REFERENCE
from nlid.data.record import Record
from nlid.discovery import Split
from nlid.errors import DataError, InputError
from nlid.identified.model import IdentifiedModel
from nlid.model.physics import equilibria
from nlid.model.terms import Model
from nlid.scoring import FromFirstSample, InitWindow, PeriodicSteadyState, default_rule, detect_period, rule_from_spec
from nlid.scoring.periods import multisine_lines
from nlid.simulation import random_force, simulate_segments
from nlid.simulation.presets import get_preset

FS = 750.0
NOISE = 0.02  # fraction of std(z)


def floor_tolerance(n: int) -> float:
    """Four standard deviations of the RMS of ``n`` independent noise samples, relative to the noise sd."""
    return 4.0 / np.sqrt(2.0 * n)


def assert_noise_floor(run: scoring.FreeRun, sigma: float) -> None:
    assert run.computed, run.note
    assert abs(run.rmse / sigma - 1.0) <= floor_tolerance(run.scored_samples), (run.rmse / sigma, run.rule)


@pytest.fixture(scope="module")
def bouc_wen() -> IdentifiedModel:
    """The Bouc-Wen benchmark's own model (m = 2 kg, nlid's terms, :data:`nlid.data.datasets.BOUC_WEN_REFERENCE`)."""
    coefficients = BOUC_WEN_REFERENCE["coefficients"]
    return IdentifiedModel(Model.from_spec(list(coefficients), defaults=False), coefficients, 2.0, "truth")


def _run(model: IdentifiedModel, force: np.ndarray) -> np.ndarray:
    """The free run from rest with the scoring's own scheme (force held, 8 sub-steps): no discretisation error."""
    state = np.zeros((1, 2 + sum(t.is_memory for t in model.model.terms)))
    return simulate_segments(
        model.model, model.theta, model.mass, force, FS, [0], state, force_hold="zoh", sensitivities=False
    ).z


def _multisine(period: int, seed: int) -> np.ndarray:
    """One period of a flat-spectrum random-phase multisine, 5-150 Hz, 40 N RMS."""
    bins = np.arange(period // 2 + 1) * FS / period
    spectrum = np.zeros(bins.size, complex)
    band = (bins > 5.0) & (bins < 150.0)
    spectrum[band] = np.exp(2j * np.pi * np.random.default_rng(seed).random(band.sum()))
    one = np.fft.irfft(spectrum, period)
    return one * (40.0 / one.std())


def _noisy(z: np.ndarray, seed: int) -> tuple[np.ndarray, float]:
    sigma = NOISE * float(np.std(z))
    return z + sigma * np.random.default_rng(seed).standard_normal(z.size), sigma


# --------------------------------------------------------------------------- spelling and defaults
@pytest.mark.parametrize(
    "spec, rule",
    [
        ("first-sample", FromFirstSample()),
        ("window:50", InitWindow(50)),
        (" Window:7 ", InitWindow(7)),
        ("periodic", PeriodicSteadyState()),
        ("periodic:8192", PeriodicSteadyState(8192)),
        ({"kind": "window", "samples": 20}, InitWindow(20)),
        ({"kind": "periodic", "period": 64, "max_periods": 5, "tol": 1e-3}, PeriodicSteadyState(64, 5, 1e-3)),
        (InitWindow(3), InitWindow(3)),
    ],
)
def test_rule_from_spec_reads_every_spelling(spec, rule):
    assert rule_from_spec(spec) == rule
    spelled = rule_from_spec(rule.to_spec())  # the short spelling keeps the rule's kind and its length
    assert type(spelled) is type(rule) and getattr(spelled, "period", None) == getattr(rule, "period", None)
    assert getattr(spelled, "samples", None) == getattr(rule, "samples", None)


@pytest.mark.parametrize(
    "spec",
    [
        "window",
        "window:0",
        "window:-3",
        "window:2.5",
        "periodic:1",
        "periodc",
        "",
        50,
        {"kind": "rest"},
        {"kind": "window"},
        {"kind": "window", "samples": 5, "tol": 1},
    ],
)
def test_rule_from_spec_refuses_anything_else(spec):
    with pytest.raises(InputError):
        rule_from_spec(spec)


def test_a_misspelled_rule_gets_a_suggestion():
    with pytest.raises(InputError, match="did you mean 'periodic'"):
        rule_from_spec("periodc")


def test_each_rule_describes_itself():
    assert FromFirstSample().describe() == "from the record's first sample"
    assert InitWindow(50).describe() == "initialisation window of 50 samples (state fitted to them; not scored)"
    assert PeriodicSteadyState(8192).describe() == "periodic steady state (period 8192 samples, declared)"
    assert "detected from the force" in PeriodicSteadyState().describe()


def test_detect_period_finds_a_repeated_force_and_nothing_else():
    one = _multisine(300, 0)
    assert detect_period(np.tile(one, 3)) == 300
    assert detect_period(np.tile(one, 2)) == 300
    assert detect_period(np.concatenate([one, one[:150]])) is None  # 1.5 periods
    assert detect_period(random_force(4000, FS, 1.0, np.random.default_rng(1))) is None
    assert detect_period(np.tile(one, 3) + 1e-3 * np.random.default_rng(2).standard_normal(900)) is None  # measured


def test_default_rule_of_each_kind_of_record(bouc_wen):
    preset = nlid.simulate("paper-numerical", seed=1, noise=0.02, duration=4)
    assert default_rule(preset) == FromFirstSample()  # simulated presets start at rest
    one = _multisine(256, 1)
    force = np.tile(one, 8)
    z = _run(bouc_wen, force)
    steady = Record(f=force[-3 * 256 :], z=z[-3 * 256 :], fs=FS, meta={"force_hold": "zoh"})
    assert default_rule(steady) == PeriodicSteadyState()  # detected: the period is found when scoring
    started = Record(f=force[: 3 * 256], z=z[: 3 * 256], fs=FS, meta={"force_hold": "zoh"})
    assert default_rule(started) == FromFirstSample()  # a periodic force from rest: not in steady state
    assert default_rule(steady.with_meta(periodic=False)) == FromFirstSample()
    assert default_rule(steady.with_meta(periodic=256)) == PeriodicSteadyState(256)
    assert default_rule(steady[:256].with_meta(periodic=True)) == PeriodicSteadyState(256)
    declared = steady.with_meta(protocol={"benchmark": "x", "rule": "window:20"})
    assert default_rule(declared) == InitWindow(20)


# --------------------------------------------------------------------------- the record's meta["periodic"]
def test_a_declared_period_survives_slicing_while_a_whole_period_remains():
    record = Record(f=np.tile(_multisine(100, 0), 4), z=np.sin(np.arange(400) / 7.0), fs=FS, meta={"periodic": 100})
    assert record[300:].meta["periodic"] is True  # one whole period: the part is its own period
    assert record[150:].meta["periodic"] == 100
    assert "periodic" not in record[350:].meta  # less than a period
    assert record[::2].meta["periodic"] == 50
    assert "periodic" not in record[::3].meta  # not a whole number of samples
    assert record.decimate(2).meta["periodic"] == 50
    whole = record.with_meta(periodic=True)
    estimation, held = whole.split(0.25)
    assert "periodic" not in held.meta and "periodic" not in estimation.meta  # 400 samples: no whole period left
    with pytest.raises(DataError, match="periodic"):
        record.with_meta(periodic=1000)
    with pytest.raises(DataError, match="periodic"):
        record.with_meta(periodic="yes")


def test_the_period_is_written_to_the_sidecar_and_read_back(tmp_path):
    from nlid.data.io import read_record, write_csv

    record = Record(f=np.tile(_multisine(100, 0), 3), z=np.cos(np.arange(300) / 5.0), fs=FS, meta={"periodic": 100})
    path = tmp_path / "x.csv"
    write_csv(record, path)
    assert json.loads((tmp_path / "x.csv.meta.json").read_text())["periodic"] == 100
    assert read_record(path).meta["periodic"] == 100


# --------------------------------------------------------------------------- each rule at the noise floor
def test_first_sample_gets_the_noise_floor_on_a_preset_record_from_rest():
    """A preset that starts at rest in its well, with z and v measured (2 % noise).

    The rule takes the state from the record's first (noisy) sample: its start-up error must fade quickly
    against the record, so the oscillator is well damped here (v = 10 N s/m: zeta ~ 0.35); a lightly damped
    one carries that error for seconds (then the window rule is the right one).
    """
    base = get_preset("paper-numerical")
    wells = equilibria(base.model(), base.model().vector(dict(base.coefficients)), (-0.1, 0.1)).stable
    coefficients = {**base.coefficients, "v": 10.0}
    preset = base.with_overrides(duration=20.0, force_rms=3.0, coefficients=coefficients, x0=(max(wells), 0.0))
    true = IdentifiedModel(preset.model(), preset.truth()["coefficients"], preset.mass, "truth")
    noisy = preset.simulate(11, noise={"z": NOISE, "v": NOISE}, channels=("z", "v"))
    clean = preset.simulate(11, channels=("z",))
    run = scoring.free_run_error(true, noisy)
    assert run.rule == "from the record's first sample" and run.scored_samples == noisy.n
    assert_noise_floor(run, NOISE * float(np.std(clean.z)))


@pytest.fixture(scope="module")
def cut_record(bouc_wen):
    """A Bouc-Wen record cut from the middle of a run: its displacement, velocity and hysteretic state are not 0."""
    force = random_force(9000, FS, 40.0, np.random.default_rng(0), band=(5.0, 150.0))
    z = _run(bouc_wen, force)
    cut = 3000
    noisy, sigma = _noisy(z[cut:], 1)
    return Record(f=force[cut:], z=noisy, fs=FS, meta={"force_hold": "zoh", "mass": 2.0}), sigma, force[:cut]


def test_init_window_gets_the_noise_floor_on_a_record_cut_from_a_run(bouc_wen, cut_record):
    record, sigma, before = cut_record
    start = simulate_segments(
        bouc_wen.model, bouc_wen.theta, 2.0, before, FS, [0], np.zeros((1, 3)), force_hold="zoh", sensitivities=False
    ).end_state[0]
    assert abs(start[2]) > 0.1 * np.std(record.z)  # the hysteretic state is far from 0 where the record starts
    run = scoring.free_run_error(bouc_wen, record, "window:200")
    assert run.scored_samples == record.n - 200
    assert run.rule == "initialisation window of 200 samples (state fitted to them; not scored)"
    assert_noise_floor(run, sigma)


def test_init_window_fits_every_initial_state(bouc_wen, cut_record):
    record, _, before = cut_record
    truth = simulate_segments(
        bouc_wen.model, bouc_wen.theta, 2.0, before, FS, [0], np.zeros((1, 3)), force_hold="zoh", sensitivities=False
    ).end_state[0]
    from nlid.scoring.rules import start

    fitted = start(bouc_wen, record, InitWindow(200), 8).state
    scale = np.array([np.std(record.z), np.std(np.diff(record.z)) * FS, np.std(record.z)])
    assert np.all(np.abs(fitted - truth) <= 0.05 * scale), (fitted, truth)


@pytest.fixture(scope="module")
def periodic_records(bouc_wen):
    """The Bouc-Wen model in periodic steady state under a multisine: three periods and the last one alone."""
    period = 1024
    force = np.tile(_multisine(period, 3), 12)
    z = _run(bouc_wen, force)
    noisy, sigma = _noisy(z[-3 * period :], 4)
    three = Record(f=force[-3 * period :], z=noisy, fs=FS, meta={"force_hold": "zoh", "mass": 2.0})
    return three, three[-period:].with_meta(periodic=True), sigma


def test_periodic_steady_state_gets_the_noise_floor_detected(bouc_wen, periodic_records):
    three, _, sigma = periodic_records
    run = scoring.free_run_error(bouc_wen, three)  # the default rule: the force repeats, the response too
    assert run.rule.startswith("periodic steady state (period 1024 samples, detected from the force; ")
    assert "preceding periods simulated" in run.rule and "not settled" not in run.rule
    assert_noise_floor(run, sigma)


def test_periodic_steady_state_gets_the_noise_floor_declared(bouc_wen, periodic_records):
    _, one, sigma = periodic_records
    run = scoring.free_run_error(bouc_wen, one)
    assert run.rule.startswith("periodic steady state (period 1024 samples, declared; ")
    assert_noise_floor(run, sigma)
    assert scoring.free_run_error(bouc_wen, one, "periodic:1024").rmse == run.rmse


def test_from_the_first_sample_a_steady_state_period_is_far_off(bouc_wen, periodic_records):
    _, one, sigma = periodic_records
    run = scoring.free_run_error(bouc_wen, one, "first-sample")
    assert run.rmse > 2.0 * sigma  # the hysteretic state starts at 0, the velocity from the record's edge


def test_one_period_of_a_multisine_is_scored_in_periodic_steady_state_and_says_so(bouc_wen, periodic_records):
    """A validation record that is one period of a multisine, not declared: its force's lines give it away."""
    three, _, sigma = periodic_records
    one = Record(f=three.f[-1024:], z=three.z[-1024:], fs=FS, meta={"force_hold": "zoh", "mass": 2.0})
    assert "periodic" not in one.meta and detect_period(one.f) is None
    assert multisine_lines(one.f) is not None
    assert default_rule(one) == PeriodicSteadyState(None)
    run = scoring.free_run_error(bouc_wen, one)
    assert run.rule.startswith("periodic steady state (period 1024 samples, whole periods of a multisine, detected")
    assert_noise_floor(run, sigma)
    assert scoring.free_run_error(bouc_wen, one, "first-sample").rmse > 2.0 * sigma  # what scoring from rest gave


@pytest.mark.parametrize(
    "force",
    [
        random_force(4096, FS, 1.0, np.random.default_rng(7)),  # white
        random_force(4096, FS, 1.0, np.random.default_rng(8), band=(5.0, 150.0)),  # band-limited
        np.sin(2 * np.pi * (5.0 + 20.0 * np.arange(4096) / FS) * np.arange(4096) / FS),  # a sweep
        np.tile(_multisine(1024, 3), 2)[:1536],  # a multisine cut at 1.5 periods
        np.sin(2 * np.pi * 10.3 * np.arange(1000) / 1000),  # a sine cut at 10.3 periods
    ],
    ids=["white", "band-limited", "sweep", "1.5 periods", "sine off the grid"],
)
def test_a_force_that_is_not_whole_periods_of_a_multisine_is_not_called_one(force):
    assert multisine_lines(force) is None
    record = Record(f=force, z=np.sin(np.arange(force.size) / 7.0), fs=FS)
    assert default_rule(record) == FromFirstSample()


def test_whole_periods_of_a_multisine_are_recognised_generated_or_measured():
    odd = np.zeros(2049, complex)
    odd[1:800:2] = np.exp(2j * np.pi * np.random.default_rng(9).random(400))
    force = np.fft.irfft(odd, 4096)
    assert multisine_lines(force) == 400
    noisy = force + 1e-3 * force.std() * np.random.default_rng(10).standard_normal(force.size)
    assert multisine_lines(noisy) == 400  # a measured one: its empty bins at the noise floor, 60 dB down


def test_periodic_needs_a_period(bouc_wen, cut_record):
    record, _, _ = cut_record
    with pytest.raises(InputError, match="neither repeats"):
        scoring.free_run_error(bouc_wen, record, "periodic")
    with pytest.raises(InputError, match="whole period"):
        scoring.free_run_error(bouc_wen, record[:500], "periodic:600")
    with pytest.raises(InputError, match="too little"):
        scoring.free_run_error(bouc_wen, record[:300], "window:299")


def test_scores_state_their_rule(bouc_wen, periodic_records):
    three, _, _ = periodic_records
    scores = bouc_wen.score(three, rule="window:100")
    assert scores.freerun_rule.startswith("initialisation window of 100 samples")
    assert scores.freerun_scored_samples == three.n - 100
    assert bouc_wen.score(three, free_run=False).freerun_rule == ""
    text = json.dumps({**bouc_wen.to_dict(), "scores": to_jsonable(scores.to_dict())})
    again = IdentifiedModel.from_dict(json.loads(text)).scores
    assert again.freerun_rule == scores.freerun_rule and again.freerun_scored_samples == scores.freerun_scored_samples
    assert again.freerun_rmse == scores.freerun_rmse and again.predict_horizon is None  # JSON null stays "none"


# --------------------------------------------------------------------------- discover and the study
def test_discover_holds_out_whole_periods_of_a_periodic_record(periodic_records):
    three, _, _ = periodic_records
    estimation, held, text = Split(0.25).divide(three)
    assert (estimation.n, held.n) == (2048, 1024)
    assert held.meta["periodic"] is True and estimation.meta["periodic"] == 1024
    assert text == "last period of the record (1024 samples; period 1024 samples, detected from the force)"
    assert default_rule(held) == PeriodicSteadyState(1024)


def test_study_and_compare_take_the_rule(bouc_wen, periodic_records):
    from nlid.identified.reference import compare
    from nlid.study import metrics

    three, _, _ = periodic_records
    row = metrics.holdout_metrics(three, bouc_wen, True, "window:100")
    assert row["freerun_rule"].startswith("initialisation window of 100") and row["freerun_scored_samples"] == 2972
    frame = compare(bouc_wen, None, three).to_frame()
    note = frame.loc[frame["quantity"] == "freerun_rmse", "note"].item()
    assert note.startswith("free run: periodic steady state (period 1024 samples, detected")
    frame = compare(bouc_wen, None, three, rule="first-sample").to_frame()  # every rule is stated, this one too
    assert frame.loc[frame["quantity"] == "freerun_rmse", "note"].item() == "free run: from the record's first sample"


@pytest.mark.parametrize("rule", ["window:50", "periodic:8192", "first-sample"])
def test_a_study_dataset_takes_a_freerun_rule(rule):
    from nlid.study import parse_study

    text = f"""
[study]
name = "r"
identifiers = ["rfs"]
[[datasets]]
name = "num"
preset = "paper-numerical"
freerun_rule = "{rule}"
"""
    ds = parse_study(text).datasets[0]
    assert ds.freerun_rule == rule
    assert type(ds).from_dict(ds.to_dict()).freerun_rule == rule


def test_a_study_refuses_a_bad_rule():
    from nlid.study import parse_study
    from nlid.study.values import ConfigError

    text = '[study]\nname = "r"\nidentifiers = ["rfs"]\n[[datasets]]\nname = "n"\npreset = "paper-numerical"\n'
    with pytest.raises(ConfigError, match="freerun_rule"):
        parse_study(text + 'freerun_rule = "rest"\n')
    assert "freerun_rule" not in parse_study(text).datasets[0].to_dict()  # run digests as before


# --------------------------------------------------------------------------- the Bouc-Wen benchmark
def test_bouc_wen_true_model_on_the_held_out_last_period_is_at_the_noise_floor(data_dir, bouc_wen):
    """The training multisine: 5 periods of 8192 samples; the noise sd from the period-to-period differences."""
    record = nlid.load("dataset:bouc-wen")
    period = 8192
    blocks = record.z.reshape(-1, period)
    sigma = float(np.sqrt(np.mean(np.diff(blocks, axis=0) ** 2)) / np.sqrt(2.0))
    estimation, held, text = Split(0.25).divide(record)
    assert held.n == period and text.startswith("last period of the record")
    run = scoring.free_run_error(bouc_wen, held)
    assert run.rule.startswith("periodic steady state (period 8192 samples, declared;")
    assert run.rmse <= 1.2 * sigma, (run.rmse, sigma)
    assert_noise_floor(run, sigma)
