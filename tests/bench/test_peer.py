"""The pysindy peer: its free run is pysindy's model, its rules do what they say."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from nlid import InputError
from nlid.benchmarking.declarations import PeerSettings
from nlid.benchmarking.peer import DIFFERENTIATION, PeerModel, _fit, fit_peer
from nlid.data.record import Record


def _oscillator(n=3000, fs=200.0, seed=0, x0=(0.0, 0.0), force=None):
    """A lightly damped linear oscillator z'' = -400 z - 2 z' + f (exact for a force linear between samples)."""
    from scipy import signal

    rng = np.random.default_rng(seed)
    t = np.arange(n) / fs
    f = np.convolve(rng.standard_normal(n), np.ones(40) / 40, mode="same") * 200 if force is None else force
    system = signal.StateSpace([[0.0, 1.0], [-400.0, -2.0]], [[0.0], [1.0]], [[1.0, 0.0]], [[0.0]])
    _, z, _ = signal.lsim(system, f, t, X0=x0)
    return Record(f=f, z=z, fs=fs)


def test_peer_free_run_equals_pysindy_simulate():
    import pysindy as ps

    from nlid.benchmarking.peer import _library

    rec = _oscillator()
    peer = _fit(rec, PeerSettings(degree=2, friction=False, thresholds=(0.0,)), 0.05, "FiniteDifference")
    # the same pysindy model, fitted and simulated by pysindy itself (its default cubic interpolation of u)
    model = ps.SINDy(
        feature_library=_library(PeerSettings(degree=2, friction=False)),
        optimizer=ps.STLSQ(threshold=0.05, normalize_columns=True),
        differentiation_method=ps.FiniteDifference(),
    )
    z, v = rec.z, ps.FiniteDifference()(rec.z, 1 / rec.fs)
    model.fit(np.column_stack([z, v]), t=1 / rec.fs, u=rec.f, feature_names=["z", "v", "u"])
    assert np.allclose(model.coefficients(), peer.coefficients)
    t = np.arange(400) / rec.fs

    def force(t):  # few integrator steps; odd about t = 0, so that the record's odd continuation is exact there
        return 30 * np.sin(2 * np.pi * 1.5 * t) + 10 * np.sin(2 * np.pi * 4 * t)

    # pysindy integrates the force itself, the peer its samples (interpolated within their band, as nlid scores)
    kws = {"method": "RK45", "rtol": 1e-10, "atol": 1e-13}  # faster than its default LSODA at 1e-12
    theirs = model.simulate(np.array([0.01, 0.5]), t, u=force, integrator_kws=kws)[:, 0]
    ours, *_ = peer.simulate(force(t), rec.fs, (0.01, 0.5), limit=1e3, f_next=float(force(t[-1] + 1 / rec.fs)))
    inside = slice(0, t.size - 40)  # the last samples see the record's end (continued by odd reflection)
    assert np.sqrt(np.mean((ours[inside] - theirs[inside]) ** 2)) < 1e-6 * np.std(theirs)


def test_peer_threshold_is_chosen_on_the_estimation_record():
    est = _oscillator(seed=1)
    peer = fit_peer(est, PeerSettings(degree=1, friction=False, thresholds=(0.0, 0.5)))
    assert peer.selection["threshold"] in (0.0, 0.5)
    assert set(peer.selection["holdout_rmse"]) == {f"{d}, threshold {t:g}" for d in DIFFERENTIATION for t in (0.0, 0.5)}
    assert peer.selection["threshold_absolute"] == pytest.approx(peer.selection["threshold"] * peer.scale)
    z_row, v_row = peer.coefficients
    assert z_row[2] == pytest.approx(1.0, abs=1e-6)  # z' = v
    assert v_row[1] == pytest.approx(-400, rel=0.02) and v_row[3] == pytest.approx(1.0, rel=0.05)


def _true_peer():
    """The oscillator's own equations as a peer model: features 1, z, v (degree 1), u."""
    coef = np.array([[0.0, 0.0, 1.0, 0.0], [0.0, -400.0, -2.0, 1.0]])
    return PeerModel(coef, ["1", "z", "v", "u"], np.array([[0, 0], [1, 0], [0, 1]]), False, 0.0)


def _noisy(record, sigma, seed):
    return record.replace(z=record.z + sigma * np.random.default_rng(seed).standard_normal(record.n))


def test_peer_rules_give_the_true_model_its_noise_floor():
    """The true equations scored under each rule reach the output noise; from the first sample they do not."""
    peer = _true_peer()
    sigma = 2e-3  # about 1 % of std(z)
    # a record that starts far from rest: the window rule fits the state to 20 samples; the first sample
    # takes z[0] and a differentiated v[0] from single noisy samples, an error that rings for about a second
    test = _noisy(_oscillator(seed=2, x0=(0.05, 3.0)), sigma, seed=3)
    first = peer.free_run(test, "first-sample")
    window = peer.free_run(test, "window:20")
    assert window.scored_samples == test.n - 20 and first.scored_samples == test.n
    assert "initialisation window of 20 samples" in window.rule
    assert window.rmse == pytest.approx(sigma, rel=0.1) and first.rmse > 1.3 * window.rmse
    # one steady-state period: preceding periods of its force are simulated until the state settles
    period = 500
    f = np.tile(test.f[:period], 15)
    settled = _noisy(_oscillator(n=f.size, fs=test.fs, force=f)[-period:], sigma, seed=4)  # 14 periods before it
    periodic = peer.free_run(settled, f"periodic:{period}")
    assert "periodic steady state (period 500 samples, declared;" in periodic.rule
    assert periodic.rmse == pytest.approx(sigma, rel=0.1)
    with pytest.raises(InputError, match="not whole periods"):
        peer.free_run(settled[:-7], f"periodic:{period}")


def test_the_peer_normalises_its_columns_so_a_record_in_volts_keeps_its_cubic_spring():
    """Silverbox's scales (50 mV, a 'mass' of 5e-6 s^2): raw columns let STLSQ's ridge term eat the cubic spring.

    The record is one steady-state period of a multisine (its spectral derivative is exact), so the
    only error left is the regression's.
    """
    import pysindy as ps

    from nlid.identified.model import IdentifiedModel
    from nlid.model.terms import Model
    from nlid.simulation import simulate_segments

    fs, period, mass = 610.0, 2048, 5.36e-6
    coefficients = {"z": 0.989, "z^3": 3.86, "v": 2.26e-4}
    truth = IdentifiedModel(Model.from_spec(list(coefficients), defaults=False), coefficients, mass, "truth")
    bins = np.arange(period // 2 + 1) * fs / period
    spectrum = np.zeros(bins.size, complex)
    band = (bins > 1.0) & (bins < 150.0)
    spectrum[band] = np.exp(2j * np.pi * np.random.default_rng(3).random(band.sum()))
    one = np.fft.irfft(spectrum, period)
    force = np.tile(one * (0.03 / one.std()), 6)
    state = np.zeros((1, 2))
    z = simulate_segments(
        truth.model, truth.theta, mass, force, fs, [0], state, force_hold="zoh", sensitivities=False
    ).z
    rec = Record(f=force[-period:], z=z[-period:], fs=fs)
    settings = PeerSettings(degree=3, friction=False, thresholds=(0.0,))
    peer = _fit(rec, settings, 0.0, "SpectralDerivative")
    cubic = peer.names.index("z^3")
    assert peer.coefficients[1, cubic] == pytest.approx(-coefficients["z^3"] / mass, rel=0.05)
    # the same fit on raw columns (pysindy's default) loses most of the cubic spring to the ridge term
    raw = ps.SINDy(
        feature_library=peer_library(settings),
        optimizer=ps.STLSQ(threshold=0.0),
        differentiation_method=ps.SpectralDerivative(),
    )
    v = np.asarray(ps.SpectralDerivative()(rec.z, 1 / fs)).ravel()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        raw.fit(np.column_stack([rec.z, v]), t=1 / fs, u=rec.f, feature_names=["z", "v", "u"])
    assert abs(raw.coefficients()[1, cubic] / peer.coefficients[1, cubic] - 1) > 0.2


def peer_library(settings):
    """The peer's feature library (pysindy's objects)."""
    from nlid.benchmarking.peer import _library

    return _library(settings)


# --------------------------------------------------------------------------- sysidentpy's NARX (skipped without it)
def _narx_record(n=3000, seed=0, fs=100.0):
    """A record of the polynomial NARX ``y_k = 1.2 y_{k-1} - 0.5 y_{k-2} + 0.3 u_{k-1} + 0.1 u_{k-2} - 0.1 y_{k-1}^3``.

    It is in the row's model class (degree 3, lags 2), starts at rest (force and output zero), and is noise-free.
    """
    rng = np.random.default_rng(seed)
    u = np.convolve(rng.standard_normal(n), np.ones(5) / 5, mode="same")
    u[:2] = 0.0  # at rest before the record: no force, no output
    y = np.zeros(n)
    for k in range(2, n):
        y[k] = 1.2 * y[k - 1] - 0.5 * y[k - 2] + 0.3 * u[k - 1] + 0.1 * u[k - 2] - 0.1 * y[k - 1] ** 3
    return Record(f=u, z=y, fs=fs)


def test_narx_free_run_is_sysidentpys_predict():
    """The row's free run under a window is sysidentpy's ``predict`` as its Silverbox tutorial calls it."""
    pytest.importorskip("sysidentpy")
    from nlid.benchmarking.blackbox import NarxModel, _frols

    rec = _narx_record()
    row = NarxModel(_frols(rec, 3, 2, 10), 3, 2, 10)
    test = _narx_record(seed=1)
    window = 20
    score = row.free_run(test, f"window:{window}")
    # the tutorial: start = n - max_lag; yhat = model.predict(X=x_test[start:], y=y_test[start:n])[max_lag:]
    lag = row.model.max_lag
    yhat = row.model.predict(X=test.f[window - lag :, None], y=test.z[window - lag : window, None]).ravel()[lag:]
    expected = float(np.sqrt(np.mean((yhat - test.z[window:]) ** 2)))
    assert score.scored_samples == test.n - window
    assert score.rmse == pytest.approx(expected, rel=1e-9)
    assert score.rmse < 1e-6 * np.std(test.z)  # the system is in the model class and the record noise-free
    # from the first sample the lags are the first sample (the record starts at rest): the same run
    assert row.free_run(test, "first-sample").rmse < 1e-6 * np.std(test.z)


def test_narx_choices_are_made_on_the_estimation_record():
    """Degree, lags and terms are the held-out end's best; the chosen model generalises to another record."""
    pytest.importorskip("sysidentpy")
    from nlid.benchmarking.blackbox import NARX_GRID, NARX_TERMS, fit_narx

    narx = fit_narx(_narx_record(), rule="window:20")
    errors = narx.selection["holdout_rmse"]
    assert set(errors) == {f"degree {d}, lags {g}, {t} terms" for d, g in NARX_GRID for t in NARX_TERMS}
    finite = {k: v for k, v in errors.items() if np.isfinite(v)}
    chosen = f"degree {narx.degree}, lags {narx.lag}, {narx.terms} terms"
    assert finite[chosen] == min(finite.values())
    test = _narx_record(seed=2)
    assert narx.free_run(test, "window:20").rmse < 1e-3 * np.std(test.z)
