"""Noise levels of the channels the bias correction simulates (issue 15)."""

import pickle

import numpy as np
import pytest

from nlid.bayes.noise import UnknownNoiseError, channel_noise, velocity_noise
from nlid.data.record import Record
from nlid.errors import DataError, InputError
from nlid.signal import derivatives
from nlid.simulation.presets import get_preset


@pytest.fixture(scope="module")
def numerical():
    return get_preset("paper-numerical").with_overrides(duration=30.0)


@pytest.fixture(scope="module")
def clean(numerical):
    return numerical.simulate(7, channels=("z", "v", "a"))


@pytest.fixture(scope="module")
def noisy(numerical):
    """30 s of paper-numerical, 2 % noise on z, v and a."""
    return numerical.simulate(7, noise=0.02, channels=("z", "v", "a"))


def true_sd(clean, channel, fraction=0.02):
    return fraction * getattr(clean, channel).std()


def test_the_velocity_floor_holds_motion_on_paper_numerical(clean, noisy):
    # the cause of issue 15: the white force leaves motion in v's band 0.35-0.45 fs, several times the noise
    assert derivatives.noise_sd(noisy.v, noisy.fs) > 3 * true_sd(clean, "v")
    # while z's floor is noise
    assert derivatives.noise_sd(noisy.z, noisy.fs) == pytest.approx(true_sd(clean, "z"), rel=0.05)


def test_channel_noise_reads_v_from_its_consistency_with_dz_dt(numerical, clean, noisy):
    levels = channel_noise(noisy, numerical.model())
    assert set(levels) == {"z", "v"}
    assert levels["z"].source == "noise floor" and levels["z"].relative_se is None
    v = levels["v"]
    assert v.source == "v - dz/dt" and 0 < v.relative_se < 0.3
    # the variance is right within 3 of its standard errors
    assert abs(v.sd**2 / true_sd(clean, "v") ** 2 - 1) < 3 * v.relative_se
    fit = velocity_noise(noisy.z, noisy.v, noisy.fs)
    assert fit.worst_band() is None and 0.7 < fit.chi2 < 1.5
    assert fit.z_sd == pytest.approx(true_sd(clean, "z"), rel=0.05)


@pytest.mark.parametrize("fraction", [0.01, 0.05])
def test_velocity_noise_follows_the_level(numerical, clean, fraction):
    record = numerical.simulate(7, noise=fraction, channels=("z", "v"))
    fit = velocity_noise(record.z, record.v, record.fs)
    assert abs(fit.v_sd**2 / true_sd(clean, "v", fraction) ** 2 - 1) < 3 * fit.v_relative_se


def test_only_the_channels_the_regressors_use(numerical, noisy):
    assert set(channel_noise(noisy.without("v"), numerical.model())) == {"z"}
    stiffness_only = numerical.model().with_terms(remove=["v", "v*|v|"])
    assert set(channel_noise(noisy, stiffness_only)) == {"z"}


def test_given_levels_win(numerical, noisy):
    levels = channel_noise(noisy, numerical.model(), {"v": 0.01, "z": 1e-4})
    assert {c: (x.sd, x.source) for c, x in levels.items()} == {"z": (1e-4, "given"), "v": (0.01, "given")}


def test_a_noise_free_velocity_is_not_guessed(numerical, clean):
    # v - dz/dt holds (almost) nothing: no level can be read, the user must give it
    with pytest.raises(UnknownNoiseError, match=r"velocity's noise level cannot be established.*noise=\{'v'"):
        channel_noise(clean, numerical.model())
    assert channel_noise(clean, numerical.model(), {"v": 0.0, "z": 0.0})["v"].sd == 0.0


def test_inconsistent_sensors_are_refused(numerical, noisy):
    # a velocity sensor 3 % off in gain leaves 3 % of the motion in v - dz/dt
    with pytest.raises(UnknownNoiseError, match="v - dz/dt is not white noise") as info:
        channel_noise(noisy.replace(v=1.03 * noisy.v), numerical.model())
    assert info.value.channels == ("v",)
    # ... and one sample of time skew
    with pytest.raises(UnknownNoiseError, match="sensors' responses or timing"):
        channel_noise(noisy.replace(v=np.roll(noisy.v, 1)), numerical.model())


def test_a_displacement_floor_holding_motion_is_caught_when_v_is_measured(numerical, noisy):
    # a tone at 0.4 fs in z only: z's floor reads it as noise, v - dz/dt sees it as something else
    t = noisy.t
    z = noisy.z + 3 * true_sd(noisy, "z") * np.sin(2 * np.pi * 0.4 * noisy.fs * t)
    with pytest.raises(UnknownNoiseError) as info:
        channel_noise(noisy.replace(z=z), numerical.model())
    assert "v" in info.value.channels


def test_unmeasured_displacement_needs_its_level(numerical, noisy):
    record = Record(f=noisy.f, z=noisy.z, fs=noisy.fs, a=noisy.a, provenance={"z": "integrated from a"})
    with pytest.raises(UnknownNoiseError, match=r"displacement is not measured.*noise=\{'z'"):
        channel_noise(record, numerical.model())
    assert channel_noise(record, numerical.model(), {"z": 1e-4})["z"].sd == 1e-4


def test_bad_levels(numerical, noisy):
    with pytest.raises(InputError, match="channel 'a'; only z and v are corrected"):
        channel_noise(noisy, numerical.model(), {"a": 1.0})
    with pytest.raises(InputError, match="non-negative"):
        channel_noise(noisy, numerical.model(), {"v": -1.0})
    with pytest.raises(InputError, match="no measured velocity"):
        channel_noise(noisy.without("v"), numerical.model(), {"v": 0.01})
    with pytest.raises(DataError, match="too few samples"):
        velocity_noise(noisy.z[:500], noisy.v[:500], noisy.fs)


def test_unknown_noise_error_survives_pickling():
    exc = pickle.loads(pickle.dumps(UnknownNoiseError("why", ("z", "v"))))
    assert exc.channels == ("z", "v") and exc.reason == "why" and "noise={'z': sd in m, 'v': sd in m/s}" in str(exc)
