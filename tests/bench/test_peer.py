"""The pysindy peer: its free run is pysindy's model, its rules do what they say."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from nlid.benchmarking.peer import _fit, fit_peer
from nlid.benchmarking.protocol import PeerSettings
from nlid.record import Record


def _oscillator(n=3000, fs=200.0, seed=0, x0=(0.0, 0.0)):
    """A lightly damped linear oscillator z'' = -400 z - 2 z' + f, simulated finely (exact enough for SINDy)."""
    from scipy.integrate import solve_ivp
    from scipy.interpolate import interp1d

    rng = np.random.default_rng(seed)
    t = np.arange(n) / fs
    f = np.convolve(rng.standard_normal(n), np.ones(5) / 5, mode="same") * 50
    u = interp1d(t, f, fill_value="extrapolate")
    sol = solve_ivp(
        lambda s, x: [x[1], -400 * x[0] - 2 * x[1] + u(s)], (0, t[-1]), x0, t_eval=t, rtol=1e-10, atol=1e-12
    )
    return Record(f=f, z=sol.y[0], fs=fs)


def test_peer_free_run_equals_pysindy_simulate():
    rec = _oscillator()
    peer = _fit(rec, PeerSettings(degree=2, friction=False, thresholds=(0.0,)), 0.05, "FiniteDifference")
    import pysindy as ps

    # rebuild the same pysindy model and simulate it with pysindy itself (LSODA, u interpolated linearly)
    model = ps.SINDy(
        feature_library=_fit.__globals__["_library"](PeerSettings(degree=2, friction=False)),
        optimizer=ps.STLSQ(threshold=0.05),
        differentiation_method=ps.FiniteDifference(),
    )
    z, v = rec.z, ps.FiniteDifference()(rec.z, 1 / rec.fs)
    model.fit(np.column_stack([z, v]), t=1 / rec.fs, u=rec.f, feature_names=["z", "v", "u"])
    assert np.allclose(model.coefficients(), peer.coefficients)
    short = rec[:400]
    t = np.arange(short.n) / short.fs
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # "last time point dropped" (u interpolated)
        theirs = model.simulate(np.array([z[0], v[0]]), t, u=short.f)[:, 0]
    ours, *_ = peer.simulate(short.f, short.fs, (z[0], v[0]), limit=1e3)
    m = theirs.size
    assert np.sqrt(np.mean((ours[:m] - theirs) ** 2)) < 1e-3 * np.std(theirs)


def test_peer_rules_and_threshold_choice():
    est = _oscillator(seed=1)
    peer = fit_peer(est, PeerSettings(degree=1, friction=False, thresholds=(0.0, 0.5)))
    assert peer.selection["threshold"] in (0.0, 0.5) and set(peer.selection["holdout_rmse"]) == {
        f"{d}, threshold {t:g}" for d in ("FiniteDifference", "SmoothedFiniteDifference") for t in (0.0, 0.5)
    }
    # a test record that starts far from rest: the window rule fits the state, the first sample guesses it
    test = _oscillator(seed=2, x0=(0.05, 3.0))
    first = peer.free_run(test, "first-sample")
    window = peer.free_run(test, "window:20")
    assert window.scored_samples == test.n - 20 and first.scored_samples == test.n
    assert window.rmse < first.rmse * 1.01 and "initialisation window of 20 samples" in window.rule
    assert window.fit_percent > 90
    # periodic: the record repeats its force; preceding periods are simulated until the state settles
    period = 500
    f = np.tile(est.f[:period], 3)
    periodic = Record(f=f, z=_settled(f, est.fs), fs=est.fs)
    score = peer.free_run(periodic[-period:], f"periodic:{period}")
    assert "periodic steady state (period 500 samples" in score.rule and score.fit_percent > 95
    with pytest.raises(Exception, match="not whole periods"):
        peer.free_run(periodic[:-7], f"periodic:{period}")


def _settled(f, fs):
    """The steady-state response to a force repeating its first 500 samples (15 periods simulated, the last kept)."""
    from scipy.integrate import solve_ivp
    from scipy.interpolate import interp1d

    ff = np.tile(f[:500], 15)
    tt = np.arange(ff.size) / fs
    u = interp1d(tt, ff)
    sol = solve_ivp(
        lambda s, x: [x[1], -400 * x[0] - 2 * x[1] + u(s)], (0, tt[-1]), (0, 0), t_eval=tt, rtol=1e-10, atol=1e-12
    )
    return sol.y[0][-f.size :]
