"""The declared argument rules of nlid.base.validate: good values pass, each bad kind fails with one line naming it."""

from __future__ import annotations

import numpy as np
import pytest

import nlid
from nlid.base.validate import (
    MAX_SEED,
    Interval,
    Options,
    check_cutoff,
    check_mass,
    check_noise,
    check_noise_sd,
    check_samples,
    check_seed,
    did_you_mean,
)
from nlid.errors import InputError
from nlid.simulation.presets import get_preset


def _fails(call, *args, match: str, **kwargs) -> str:
    """The message of the InputError that ``call`` raises: one line, matching ``match``."""
    with pytest.raises(InputError, match=match) as info:
        call(*args, **kwargs)
    text = str(info.value)
    assert "\n" not in text and "--" not in text, text  # one line, Python names (no command-line flags)
    return text


# --------------------------------------------------------------------------- the rule types
def test_an_interval_says_what_it_wants_and_what_it_got():
    rule = Interval(0, 10, "left", "a number from 0 to below 10")
    assert rule.check(0, "x") == 0.0 and isinstance(rule.check(3, "x"), float)
    assert rule.reason(np.float64(9.5)) is None
    assert rule.reason(10) == "must be a number from 0 to below 10, got 10"
    for bad in (-1, 10, float("nan"), float("inf"), "3", None, True, np.array([1.0])):
        assert not rule.accepts(bad), bad
    assert _fails(rule.check, 1e9, "x", match="^x must be") == "x must be a number from 0 to below 10, got 1e+09"


def test_an_integer_interval_refuses_floats_and_bools_and_keeps_big_integers_exact():
    rule = Interval(1, 5, "both", "an integer from 1 to 5", integer=True)
    assert rule.check(np.int64(5), "n") == 5 and isinstance(rule.check(np.int64(5), "n"), int)
    for bad in (1.0, 1.5, True, 6, 0):
        assert not rule.accepts(bad), bad
    assert Interval(0, 1, "both", "0 or 1", integer=True).reason(10**30) == f"must be 0 or 1, got {10**30}"


def test_options_suggest_the_closest_word():
    rule = Options(("fixed", "marginal"))
    assert rule.check("fixed", "others") == "fixed"
    text = _fails(rule.check, "margnal", "others", match="others must be one of fixed, marginal")
    assert text.endswith("got 'margnal' (did you mean 'marginal'?)")
    _fails(rule.check, 3, "others", match="got 3$")


def test_did_you_mean_is_empty_when_nothing_is_close():
    assert did_you_mean("rsf", ["rfs", "sindy"]) == " (did you mean 'rfs'?)"
    assert did_you_mean("zzz", ["rfs", "sindy"]) == ""
    assert did_you_mean(3, {"3x": 1}) == " (did you mean '3x'?)"  # any value, any iterable of choices


# --------------------------------------------------------------------------- mass
@pytest.mark.parametrize("good", [0.2, 1, np.float32(95.1), 1e-9])
def test_mass_accepts_finite_positive_numbers(good):
    assert check_mass(good) == float(good)


@pytest.mark.parametrize(
    "bad, shown",
    [
        (-1, "-1"),
        (0, "0"),
        (float("nan"), "nan"),
        (float("inf"), "inf"),
        ("x", "'x'"),
        ("0.2", "'0.2'"),
        (True, "True"),
    ],
)
def test_mass_refuses_the_rest_naming_mass(bad, shown):
    text = _fails(check_mass, bad, match=r"^mass= must be a positive number of kg")
    assert text.endswith(f"got {shown}")


def test_mass_none_means_estimate_it():
    assert check_mass(None) is None


def test_identify_and_the_identified_model_check_the_mass():
    record = nlid.simulate(duration=2.0, channels="z,a")
    _fails(nlid.identify, record, "z^3", mass=-1, match="^mass= must be a positive number of kg, got -1$")
    fit = nlid.identify(record, "z^3", mass=0.2)
    # the model file is checked against its schema (nlid.identified.fileformat), which names the field
    _fails(nlid.IdentifiedModel.from_dict, {**fit.to_dict(), "mass": float("nan")}, match="mass: must be a positive")


# --------------------------------------------------------------------------- cutoff
def test_cutoff_lies_between_0_and_the_nyquist_frequency():
    assert check_cutoff(None, 100.0) is None
    assert check_cutoff(49, 100.0) == 49.0 and check_cutoff(np.float64(0.1), 100.0) == 0.1
    for bad in (0, -1, 50, 50.0001, float("nan"), float("inf"), "5", True):
        text = _fails(check_cutoff, bad, 100.0, match=r"^cutoff= must be a positive number of Hz below the Nyquist")
        assert "Nyquist frequency 50 Hz, got" in text


def test_cutoff_without_a_record_is_only_positive():
    assert check_cutoff(1e9) == 1e9
    _fails(check_cutoff, float("nan"), match=r"^cutoff= must be a positive number of Hz, got nan$")
    _fails(check_cutoff, 0, match=r"^cutoff= must be a positive number of Hz, got 0$")


def test_every_core_entry_refuses_a_cutoff_above_nyquist():
    from nlid.bayes import PosteriorSampler
    from nlid.signal import derivatives

    record = nlid.simulate(duration=1.0, channels="z")  # fs 2048 Hz
    _fails(derivatives.lowpass, record.z, record.fs, 5000.0, match="Nyquist frequency 1024 Hz, got 5000")
    _fails(nlid.identify, record, "z^3", mass=0.2, cutoff=5000.0, match="^cutoff= .* got 5000$")
    _fails(PosteriorSampler, cutoff=float("nan"), match="^cutoff= must be")
    _fails(derivatives.complementary, record.z, record.z, record.fs, 2000.0, match="^crossover must be")


# --------------------------------------------------------------------------- seeds
@pytest.mark.parametrize("good", [0, 7, np.int64(3), MAX_SEED])
def test_seeds_are_integers_from_0_to_2_63_minus_1(good):
    assert check_seed(good) == int(good) and type(check_seed(good)) is int


@pytest.mark.parametrize("bad", [1.5, 1.0, True, -1, 99999999999999999999, MAX_SEED + 1, "1", None])
def test_other_seeds_are_refused_not_truncated(bad):
    _fails(check_seed, bad, match=r"^seed must be an integer from 0 to 2\*\*63 - 1, got ")
    _fails(nlid.simulate, seed=bad, duration=1.0, match=r"^seed must be an integer")


# --------------------------------------------------------------------------- durations and sampling frequencies
def test_preset_durations_and_sampling_frequencies_within_the_limits():
    preset = get_preset("paper-numerical")
    assert preset.with_overrides(duration=1.0, fs=100.0).n == 100
    assert check_samples(1.0, 64.0) == 64
    cases = [
        ({"fs": 0.0}, "fs must be a positive number of Hz, at most 1e+07, got 0"),
        ({"fs": 1e9}, "fs must be a positive number of Hz, at most 1e+07, got 1e+09"),
        ({"fs": float("nan")}, "fs must be a positive number of Hz"),
        ({"duration": -1.0}, "duration must be a positive number of seconds, got -1"),
        ({"duration": float("inf")}, "duration must be a positive number of seconds, got inf"),
        ({"duration": 1e9}, "more than the limit of 2e+07"),
        ({"duration": 0.01}, "at least 64 are needed"),
        ({"mass": -0.2}, "mass must be a positive number of kg, got -0.2"),
    ]
    for overrides, message in cases:
        text = _fails(preset.with_overrides, **overrides, match="^preset 'paper-numerical': ")
        assert message in text, text


# --------------------------------------------------------------------------- simulated noise
def test_simulated_noise_is_one_fraction_or_one_per_recorded_channel():
    assert check_noise(0.02, ("z", "a")) == {"z": 0.02, "a": 0.02}
    assert check_noise({"a": 0.01}, ("z", "a")) == {"z": 0.0, "a": 0.01}
    assert check_noise(0, ("z",)) == {"z": 0.0} and check_noise(1e-12, ("z",)) == {"z": 1e-12}


@pytest.mark.parametrize(
    "noise, message",
    [
        (-0.02, "^noise must be 0 or a fraction from 1e-12 to below 10 \\(0.02 = 2 %\\), got -0.02$"),
        (10, "got 10$"),
        (float("nan"), "got nan$"),
        (1e-300, "got 1e-300$"),  # lost in the rounding of the signal: a typo or a unit mistake
        (True, "got True$"),
        ("0.02", "got '0.02'$"),
        ({"z": -1}, "^noise on z must be 0 or a fraction"),
        ({"v": 0.02}, "^noise is given for channel 'v', which is not recorded \\(the channels are z, a\\)$"),
        ({"q": 0.02}, "channel 'q', which is not recorded"),
    ],
)
def test_bad_simulated_noise_is_refused(noise, message):
    _fails(check_noise, noise, ("z", "a"), match=message)
    _fails(nlid.simulate, noise=noise, channels="z,a", duration=1.0, match=message)


def test_a_study_checks_noise_and_seed_with_the_same_rules():
    from nlid.study.config import parse_study

    for text, message in [
        ("[study]\nseed = 99999999999999999999\n", "my.toml: study.seed: must be an integer from 0 to 2**63 - 1"),
        ("[study]\nseed = 1.5\n", "study.seed: must be an integer"),
        ("[[datasets]]\npreset = 'paper-numerical'\nnoise = 1e-300\n", "datasets[0].noise: must be 0 or a fraction"),
        (
            "[[datasets]]\npreset = 'paper-numerical'\nnoise = { v = 0.02 }\nchannels = ['a']\n",
            "datasets[0].noise: noise is given for channel 'v', which is not recorded",
        ),
        ("[posterior]\ncutoff = -1\n", "posterior.cutoff: must be a positive number of Hz, got -1"),
    ]:
        if "[[datasets]]" not in text:
            text += "[[datasets]]\npreset = 'paper-numerical'\n"
        with pytest.raises(InputError) as info:
            parse_study(text, source="my.toml")
        assert message in str(info.value), str(info.value)


# --------------------------------------------------------------------------- the posterior's known noise
def test_known_noise_levels_are_non_negative_numbers_of_z_and_v():
    assert check_noise_sd(None) == {}
    assert check_noise_sd({"z": 4e-4, "v": 0}) == {"z": 4e-4, "v": 0.0}
    _fails(check_noise_sd, {"z": -1}, match=r"^noise on z must be a non-negative number \(m\), got -1$")
    _fails(check_noise_sd, {"v": float("inf")}, match=r"^noise on v must be a non-negative number \(m/s\), got inf$")
    _fails(check_noise_sd, {"a": 1.0}, match="only z and v")
    _fails(check_noise_sd, 4e-4, match="^noise must map channels to standard deviations")


def test_a_known_noise_level_too_small_to_mean_anything_is_refused_against_the_record():
    from nlid.bayes.noise import channel_noise

    assert check_noise_sd({"z": 1e-300}) == {"z": 1e-300}  # no record yet: nothing to compare with
    text = _fails(check_noise_sd, {"z": 1e-300}, scales={"z": 0.01}, match="^noise on z is 1e-300 m, less than 1e-12")
    assert "give 0 for a noise-free channel" in text
    assert check_noise_sd({"z": 0.0}, scales={"z": 0.01}) == {"z": 0.0}  # exactly 0 is a noise-free channel
    record = nlid.simulate(duration=1.0, channels="z")
    model = nlid.Model.from_spec("z^3")
    _fails(channel_noise, record, model, {"z": 1e-300}, match="^noise on z is 1e-300 m")
    assert channel_noise(record, model, {"z": 1e-6})["z"].sd == 1e-6
