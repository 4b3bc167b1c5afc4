"""pysindy run as its documentation advises, beside nlid's pysindy peer row: is the row a fair one?

The leaderboard's ``pysindy`` row (:mod:`nlid.benchmarking.peer`) once read 54 mV on the Silverbox
arrow head where pysindy can do about 0.6 mV: a straw man. This script is the check. It uses
nothing of nlid but the benchmark's data split (:func:`nlid.benchmarking.load_estimation`,
:func:`~nlid.benchmarking.load_test`), and runs pysindy as its documentation advises:

* the SINDy components of pysindy's first tutorial (``examples/tutorial_1``): a differentiation
  method, a feature library (a polynomial library of the state with the force ``u`` as a control
  input, ``sign(v)`` for friction, as the peer), the STLSQ optimiser;
* the differentiation method chosen among pysindy's own (``FiniteDifference``, its default,
  ``SmoothedFiniteDifference``, ``SpectralDerivative``), as its differentiation example compares
  them (``examples/5_differentiation``);
* ``STLSQ(normalize_columns=True)``, the optimiser's option for library terms of very different
  magnitudes (its docstring), with a threshold grid spanning the normalised coefficients;
* the model judged by simulation on data it was not fitted to, as pysindy's tutorial on
  evaluating a model advises (``examples/tutorial_2``: "there's no substitute for simulation";
  a derivative score favours methods that oversmooth): the last 25 % of the estimation part;
* the free run by its own integrator: fixed-step RK4 (8 steps per sample) of the fitted equations,
  read from pysindy's coefficients and feature names, with the force interpolated by a cubic
  spline as ``SINDy.simulate`` does (``SINDy.simulate`` itself, LSODA at 1e-12, takes minutes per
  thousand samples: pysindy's ``predict`` costs milliseconds per call); under a window rule the
  initial state is fitted by least squares to the window's samples (what the benchmark's
  ``state_initialization_window_length`` is for), and the rest is scored.

It then fits nlid's peer row on the same estimation part and scores both on every test set under
its rule. The row passes when it is within 2x of the side-by-side on every test set.

Run (about a minute per benchmark; the figures in the report were measured at the load shown)::

    python benchmarks/peer_side_by_side.py [--benchmark silverbox,emps-internal,bouc-wen]
"""

from __future__ import annotations

import math
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))

from _common import side_by_side_main  # noqa: E402

#: Fraction of the estimation part held out for the choices (the bench's own).
HOLDOUT = 0.25
#: Thresholds tried, as fractions of the largest coefficient of the normalised, unthresholded fit.
THRESHOLDS = (0.0, 1e-4, 1e-3, 1e-2)
#: RK4 steps per sample of the free run.
STEPS = 8


def _sign(x):
    return np.sign(x)


def _sign_name(x):
    return f"sign({x})"


def library(degree: int, friction: bool):
    """pysindy's library: a polynomial in (z, v), the force u linearly, sign(v)."""
    import pysindy as ps

    libraries = [ps.PolynomialLibrary(degree=degree), ps.PolynomialLibrary(degree=1, include_bias=False)]
    inputs = [[0, 1], [2]]
    if friction:
        libraries.append(ps.CustomLibrary(library_functions=[_sign], function_names=[_sign_name]))
        inputs.append([1])
    return ps.GeneralizedLibrary(libraries, inputs_per_library=inputs)


def differentiations():
    """pysindy's differentiation methods, by name."""
    import pysindy as ps

    return {
        "FiniteDifference": ps.FiniteDifference(),
        "SmoothedFiniteDifference": ps.SmoothedFiniteDifference(),
        "SpectralDerivative": ps.SpectralDerivative(),
    }


def fit(z, u, fs, method, threshold, degree, friction):
    """``(model, largest normalised coefficient)`` of a pysindy SINDy fitted to ``z`` (its velocity by ``method``)."""
    import pysindy as ps

    diff = differentiations()[method]
    v = np.asarray(diff(z, 1 / fs)).ravel()
    model = ps.SINDy(
        feature_library=library(degree, friction),
        optimizer=ps.STLSQ(threshold=threshold, normalize_columns=True),
        differentiation_method=diff,
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        model.fit(np.column_stack([z, v]), t=1 / fs, u=u, feature_names=["z", "v", "u"])
    theta = model.feature_library.transform(np.column_stack([z, v, u]))
    scale = float(np.max(np.abs(model.coefficients()) * np.linalg.norm(np.asarray(theta), axis=0)))
    return model, scale


def equations(model):
    """The fitted right-hand side as ``f(z, v, u) -> (z', v')``, read from pysindy's coefficients and names."""
    terms = []
    for name, cz, cv in zip(model.get_feature_names(), *model.coefficients(), strict=True):
        if cz == 0 and cv == 0:
            continue
        if name == "1":
            power = (0, 0, 0, 0)
        elif name == "sign(v)":
            power = (0, 0, 0, 1)
        else:
            counts = {"z": 0, "v": 0, "u": 0}
            for factor in name.split():
                var, _, exp = factor.partition("^")
                counts[var] += int(exp or 1)
            power = (counts["z"], counts["v"], counts["u"], 0)
        terms.append((float(cz), float(cv), *power))

    def rhs(z, v, u):
        dz = dv = 0.0
        for cz, cv, pz, pv, pu, sg in terms:
            x = z**pz * v**pv * u**pu
            if sg:
                x = 1.0 if v > 0 else (-1.0 if v < 0 else 0.0)
            dz += cz * x
            dv += cv * x
        return dz, dv

    # the reading of the names is checked against pysindy's own library on a few states
    rng = np.random.default_rng(0)
    states = rng.normal(size=(5, 3))
    ours = np.array([rhs(*s) for s in states])
    theirs = np.asarray(model.feature_library.transform(states)) @ np.asarray(model.coefficients()).T
    if not np.allclose(ours, theirs, rtol=1e-9, atol=1e-12 * np.max(np.abs(theirs))):
        raise RuntimeError("the equations read from pysindy's names differ from its library")
    return rhs


def simulate(rhs, u, fs, z0, v0, limit):
    """z at every sample from (z0, v0): RK4, the force by a cubic spline between samples."""
    with np.errstate(all="ignore"):  # a diverging candidate overflows before it is stopped
        return _simulate(rhs, u, fs, z0, v0, limit)


def _simulate(rhs, u, fs, z0, v0, limit):
    from scipy.interpolate import CubicSpline

    n = u.size
    spline = CubicSpline(np.arange(n), u)
    h = 1.0 / (fs * STEPS)
    fine = spline(np.arange(n * STEPS * 2 + 1) / (2 * STEPS))
    out = np.empty(n)
    z, v = z0, v0
    for k in range(n):
        out[k] = z
        for s in range(STEPS):
            j = 2 * (k * STEPS + s)
            ua, ub, uc = fine[j], fine[j + 1], fine[j + 2]
            k1 = rhs(z, v, ua)
            k2 = rhs(z + h / 2 * k1[0], v + h / 2 * k1[1], ub)
            k3 = rhs(z + h / 2 * k2[0], v + h / 2 * k2[1], ub)
            k4 = rhs(z + h * k3[0], v + h * k3[1], uc)
            z += h / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
            v += h / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
        if not (abs(z) < limit and math.isfinite(v)):
            out[k + 1 :] = np.nan
            break
    return out


def free_run_rmse(model, z, u, fs, rule):
    """RMSE of the free run of ``model`` on ``(z, u)`` under the benchmark's rule."""
    rhs = equations(model)
    limit = 1e3 * (float(np.ptp(z)) + float(np.max(np.abs(z))))
    if rule.startswith("window:"):
        from scipy.optimize import least_squares

        w = int(rule.split(":")[1])
        v_first = float(np.gradient(z[:3], 1 / fs)[0])
        zscale, vscale = float(np.std(z)) or 1.0, (float(np.std(z)) or 1.0) * fs

        def window_error(x):
            zs = simulate(rhs, u[:w], fs, x[0] * zscale, x[1] * vscale, limit)
            return (np.nan_to_num(zs, nan=1e6) - z[:w]) / zscale

        x0 = least_squares(window_error, [z[0] / zscale, v_first / vscale]).x  # the window sets the state
        zs = simulate(rhs, u, fs, x0[0] * zscale, x0[1] * vscale, limit)
        e = zs[w:] - z[w:]
    elif rule.startswith("periodic:"):
        p = int(rule.split(":")[1])
        v0 = float(np.gradient(z[:3], 1 / fs)[0])
        zs = simulate(rhs, np.tile(u[:p], 4), fs, float(z[0]), v0, limit)[-p:]  # three periods before it
        e = np.tile(zs, z.size // p) - z
    else:
        v0 = float(np.gradient(z[:3], 1 / fs)[0])
        e = simulate(rhs, u, fs, float(z[0]), v0, limit) - z
    return float(np.sqrt(np.mean(e**2))) if np.all(np.isfinite(e)) else math.nan


def side_by_side(name: str) -> list[tuple[str, float, float, str]]:
    """``(test, pysindy as documented, nlid's peer row, rule)`` on one benchmark (RMSE in the benchmark's unit)."""
    from nlid.benchmarking import load_estimation, load_protocol, load_test
    from nlid.benchmarking.peer import fit_peer, selection_rule

    protocol = load_protocol(name)
    est, offsets = load_estimation(protocol)
    settings = protocol.pipelines.peer
    rule = selection_rule([t.rule for t in protocol.tests])
    cut = int(round(est.n * (1 - HOLDOUT)))
    t0 = time.perf_counter()
    best, best_err = None, math.inf
    for method in differentiations():
        _, scale = fit(est.z[:cut], est.f[:cut], est.fs, method, 0.0, settings.degree, settings.friction)
        for relative in THRESHOLDS:
            model, _ = fit(
                est.z[:cut], est.f[:cut], est.fs, method, relative * scale, settings.degree, settings.friction
            )
            err = free_run_rmse(model, est.z[cut:], est.f[cut:], est.fs, rule)
            print(
                f"  {name}: {method}, threshold {relative:g}: held-out RMSE {err * protocol.scale:.4g} {protocol.unit}"
            )
            if math.isfinite(err) and err < best_err:
                best, best_err = (method, relative), err
    method, relative = best
    _, scale = fit(est.z, est.f, est.fs, method, 0.0, settings.degree, settings.friction)
    model, _ = fit(est.z, est.f, est.fs, method, relative * scale, settings.degree, settings.friction)
    print(f"  {name}: side-by-side chose {method}, threshold {relative:g} ({time.perf_counter() - t0:.0f} s)")
    t1 = time.perf_counter()
    peer = fit_peer(est, settings, holdout=protocol.pipelines.holdout, rule=rule)
    print(
        f"  {name}: nlid's peer chose {peer.selection['differentiation']}, threshold {peer.selection['threshold']:g} "
        f"({time.perf_counter() - t1:.0f} s)"
    )
    out = []
    for test in protocol.tests:
        if test.file is not None:
            continue
        rec = load_test(protocol, test, offsets)
        ours = free_run_rmse(model, rec.z, rec.f, rec.fs, test.rule) * protocol.scale
        row = peer.free_run(rec, test.rule).rmse * protocol.scale
        out.append((test.name, ours, row, test.rule))
    return out


def main() -> None:
    """Run the side-by-side on each benchmark and print the ratio table (:func:`_common.side_by_side_main`)."""
    side_by_side_main(__doc__, side_by_side, "pysindy")


if __name__ == "__main__":
    main()
