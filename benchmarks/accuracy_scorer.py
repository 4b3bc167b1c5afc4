"""How fine is nlid's scorer? The error it gives a model that is exactly right (issue 31, item 3).

A free run of a sampled (not held) force needs the force between the samples
(:func:`nlid.simulation.fine_force`). Whatever the scorer adds there is charged to
every model it ranks; the true system shows it: its free-run error on noise-free
data is the scorer's own error. Parts (run any; all by default):

``filter``
    the interpolator's largest gain error from 0 to 0.8 of the Nyquist frequency
    (held sub-step values against their ideal, compensated one; stage values against
    the force), and that of scipy's default ``resample_poly`` filter, nlid's before.
``linear``
    a linear oscillator (the Bouc-Wen benchmark's linear part, 750 Hz) driven by a
    sampled sine: the free run against the exact steady-state response, relative to
    its amplitude, with the force from :func:`~nlid.simulation.fine_force`, from the
    sine's exact midpoint values (no interpolation error, no hold compensation), and
    from scipy's default filter.
``boucwen``
    the Bouc-Wen benchmark's true system (m = 2, c = 10, k = 5e4, alpha = 5e4,
    beta = 1e3, gamma = 0.8, delta = -1.1, nu = 1: ``z, v, bouc_wen(800, -1100)``)
    scored on its data: the sine sweep from its first sample (the protocol's rule),
    the training multisine's 5th period in periodic steady state (its output noise,
    std about 7e-6 m, is in the figure), and the 5 periods of the training record.
``simulated``
    the same system on records simulated here, noise-free, with a sampled
    band-limited force: a random-phase multisine like the benchmark's validation
    (8192 samples, 5-150 Hz, 50 N RMS; one period in periodic steady state) and a
    band-limited random force (first-sample from rest, window:100). The reference
    response is computed at 128 RK4 sub-steps per sample with the force's exact
    values (the multisine's lines summed by an inverse FFT), not through
    ``fine_force``; ``--exact`` checks it against scipy's DOP853 at rtol 1e-11.

Run it against another checkout to compare (``PYTHONPATH=/work/main``: before)::

    python benchmarks/accuracy_scorer.py                      # every part
    python benchmarks/accuracy_scorer.py simulated --exact    # with the independent integrator
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import nlid
from nlid.identified.model import IdentifiedModel
from nlid.model.terms import Model
from nlid.scoring import free_run_error
from nlid.simulation import FREE_RUN_OVERSAMPLE, fine_force, simulate

FS = 750.0
MASS, C, K, ALPHA, BETA, GAMMA, DELTA = 2.0, 10.0, 5e4, 5e4, 1e3, 0.8, -1.1
TRUE = {"z": K, "v": C, f"bouc_wen({BETA * GAMMA:g}, {BETA * DELTA:g})": ALPHA}
REFERENCE_Q = 128


def _old(force: np.ndarray, q: int) -> np.ndarray:
    """nlid's interpolation before issue 31: scipy's default polyphase filter at the sub-step midpoints."""
    from scipy import signal

    return signal.resample_poly(force, 2 * q, 1)[1::2]


def true_fit() -> IdentifiedModel:
    """The Bouc-Wen benchmark's system as a model nlid scores."""
    model = Model.from_spec(list(TRUE), defaults=False)
    return IdentifiedModel(model, TRUE, MASS, "true model")


# --------------------------------------------------------------------------- filter
def part_filter() -> None:
    q = FREE_RUN_OVERSAMPLE
    n = 4000
    nus = np.linspace(0.002, 0.4, 100)  # cycles per sample: up to 0.8 of the Nyquist frequency
    worst = {"held": 0.0, "stages": 0.0, "scipy default": 0.0}
    inner = slice(200, n - 200)
    for nu in nus:
        x = np.arange(n)
        f = np.cos(2 * np.pi * nu * x + 0.3)
        mid = (np.arange(n * q) + 0.5) / q
        exact = np.cos(2 * np.pi * nu * mid + 0.3)
        held = fine_force(f, "sampled", q)
        # the held values carry the band with unit gain: each is the midpoint value divided by sinc(nu / q)
        target = exact / np.sinc(nu / q) if _compensates() else exact
        worst["held"] = max(worst["held"], np.abs(held - target).reshape(n, q)[inner].max())
        worst["scipy default"] = max(worst["scipy default"], np.abs(_old(f, q) - exact).reshape(n, q)[inner].max())
        if _compensates():
            stages = fine_force(f, "sampled", q, stages=True)
            t = np.arange(2 * n * q) / (2 * q)
            err = np.abs(stages - np.cos(2 * np.pi * nu * t + 0.3)).reshape(n, 2 * q)[inner].max()
            worst["stages"] = max(worst["stages"], err)
    print(f"\n== interpolator: largest |gain error| from 0 to 0.8 Nyquist ({q} sub-steps)")
    for k, v in worst.items():
        print(f"  {k:14s} {v:.2e}" if k != "stages" or _compensates() else f"  {k:14s} (not in this checkout)")


def _compensates() -> bool:
    """Whether this checkout's fine_force compensates the hold (issue 31) or not (before)."""
    import inspect

    return "stages" in inspect.signature(fine_force).parameters


# --------------------------------------------------------------------------- linear
def part_linear() -> None:
    q = FREE_RUN_OVERSAMPLE
    model = Model.from_spec(["z", "v"], defaults=False)
    theta = np.array([K, C])
    n = 6000
    print(
        f"\n== linear oscillator (m {MASS:g}, c {C:g}, k {K:g}, fn {np.sqrt(K / MASS) / 2 / np.pi:.1f} Hz), {FS:g} Hz, "
        f"{q} sub-steps: RMS error of the free run / response amplitude (samples n/2 to n - 100)"
    )
    print(f"  {'f (Hz)':>7s} {'fine_force':>11s} {'exact midpoints':>16s} {'scipy default':>14s}")
    for f0 in (5.0, 20.0, 35.0, 60.0, 100.0, 150.0, 250.0):
        w = 2 * np.pi * f0
        gain = 1.0 / (K - MASS * w**2 + 1j * C * w)
        t = np.arange(n) / FS
        force = np.cos(w * t)
        z_exact = np.real(gain * np.exp(1j * w * t))
        x0 = (z_exact[0], np.real(1j * w * gain))
        mid = np.cos(w * (np.arange(n * q) + 0.5) / (FS * q))
        row = []
        for fine in (fine_force(force, "sampled", q), mid, _old(force, q)):
            z = simulate(model, theta, MASS, fine, FS * q, x0)[0][::q]
            inner = slice(n // 2, n - 100)  # the last samples see the record's end (continued by reflection)
            row.append(np.sqrt(np.mean((z[inner] - z_exact[inner]) ** 2)) / abs(gain))
        print(f"  {f0:7.0f} {row[0]:11.2e} {row[1]:16.2e} {row[2]:14.2e}")


# --------------------------------------------------------------------------- the benchmark's data
def part_boucwen() -> None:
    fit = true_fit()
    train = nlid.load("dataset:bouc-wen:train")
    sweep = nlid.load("dataset:bouc-wen:sinesweep")
    period = 8192
    blocks = train.z.reshape(5, period)
    noise = np.sqrt(np.mean(np.diff(blocks[1:4], axis=0) ** 2) / 2)  # periods 2-4, as the protocol's floor
    print("\n== the Bouc-Wen benchmark's true system on its data (RMSE, m)")
    cases = [
        ("sine sweep, first-sample (noise-free)", sweep, "first-sample"),
        (f"training period 5, periodic:8192 (noise std ~{noise:.2e})", train[4 * period :], "periodic:8192"),
        ("training periods 1-5, periodic:8192", train, "periodic:8192"),
    ]
    for label, record, rule in cases:
        t0 = time.perf_counter()
        run = free_run_error(fit, record, rule)
        print(f"  {label:58s} {run.rmse:.3e}   ({time.perf_counter() - t0:.1f} s; {run.rule})")


# --------------------------------------------------------------------------- simulated records
def _multisine(n: int, lines: np.ndarray, rms: float, rng: np.random.Generator, q: int):
    """A random-phase multisine of period ``n`` samples: its samples and its exact values at the midpoints of
    ``q`` sub-steps per sample (an inverse FFT of the lines, evaluated on the fine grid), both of RMS ``rms``."""
    spectrum = np.zeros(n * q // 2 + 1, complex)
    spectrum[lines] = np.exp(2j * np.pi * rng.random(lines.size))
    # half a sub-step later on the fine grid: the midpoints
    fine_spectrum = spectrum * np.exp(2j * np.pi * np.arange(spectrum.size) * 0.5 / (n * q))
    fine = np.fft.irfft(fine_spectrum, n * q)
    samples = np.fft.irfft(spectrum, n * q)[::q]
    scale = rms / np.sqrt(np.mean(samples**2))
    return samples * scale, fine * scale


def _reference(force_mid: np.ndarray, q: int, x0=(0.0, 0.0)) -> np.ndarray:
    model = Model.from_spec(list(TRUE), defaults=False)
    return simulate(model, TRUE, MASS, force_mid, FS * q, x0)[0][::q]


def _exact(samples_t: np.ndarray, force_at, t_end: float) -> np.ndarray:
    """The physical Bouc-Wen ODE integrated by scipy (DOP853) with the force evaluated exactly."""
    from scipy.integrate import solve_ivp

    def rhs(t, x):
        y, v, w = x
        dw = ALPHA * v - BETA * (GAMMA * abs(v) * w + DELTA * v * abs(w))
        return [v, (force_at(t) - C * v - K * y - w) / MASS, dw]

    sol = solve_ivp(rhs, (0.0, t_end), [0.0, 0.0, 0.0], method="DOP853", rtol=1e-11, atol=1e-14, t_eval=samples_t)
    return sol.y[0]


def part_simulated(exact: bool) -> None:
    from nlid.data.record import Record

    fit = true_fit()
    rng = np.random.default_rng(31)
    q = REFERENCE_Q
    print(f"\n== simulated records of the true system, noise-free (reference: RK4 at {q} sub-steps, exact force)")
    # 1. a multisine like the benchmark's validation: one period in periodic steady state
    n = 8192
    lines = np.arange(int(np.ceil(5 * n / FS)), int(150 * n / FS) + 1)
    samples, mid = _multisine(n, lines, 50.0, rng, q)
    periods = 4  # settled: the linear part decays as exp(-c t / 2 m), e^-27 per period
    z = _reference(np.tile(mid, periods), q)
    record = Record(f=samples, z=z[-n:], fs=FS, meta={"force_hold": "sampled"})
    if exact:
        from scipy.interpolate import CubicSpline

        fine_t = (np.arange(periods * n * q) + 0.5) / (FS * q)
        spline = CubicSpline(fine_t, np.tile(mid, periods))
        t = np.arange(periods * n) / FS
        t0 = time.perf_counter()
        z_exact = _exact(t, spline, t[-1])
        tail = slice((periods - 1) * n, periods * n)
        check = np.sqrt(np.mean((z[tail] - z_exact[tail]) ** 2))
        print(f"  reference against DOP853 (last period): RMS {check:.2e} m ({time.perf_counter() - t0:.0f} s)")
    run = free_run_error(fit, record, "periodic:8192")
    print(f"  multisine, one period, periodic:8192      true system {run.rmse:.3e} m   (std(z) {np.std(z):.2e})")
    # 2. a band-limited random force (a multisine whose period is far longer than the record), from rest
    long = 2**17
    lines = np.arange(int(np.ceil(5 * long / FS)), int(150 * long / FS) + 1)
    samples, mid = _multisine(long, lines, 50.0, rng, 32)
    ramp = np.clip(np.arange(long) / (0.5 * FS), 0.0, 1.0)  # from rest: the force fades in over 0.5 s
    ramp = 0.5 - 0.5 * np.cos(np.pi * ramp)
    m = 15000
    f = (samples * ramp)[:m]
    fine_ramp = np.interp((np.arange(long * 32) + 0.5) / 32, np.arange(long), ramp)
    z = _reference((mid * fine_ramp)[: m * 32], 32)
    record = Record(f=f, z=z, fs=FS, meta={"force_hold": "sampled"})
    for rule in ("first-sample", "window:100"):
        run = free_run_error(fit, record, rule)
        print(f"  band-limited random force, {rule:14s}  true system {run.rmse:.3e} m   (std(z) {np.std(z):.2e})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("parts", nargs="*", default=["filter", "linear", "boucwen", "simulated"])
    parser.add_argument("--exact", action="store_true", help="check the simulated reference with scipy's DOP853")
    args = parser.parse_args()
    print(f"nlid from {nlid.__file__}")
    parts = {
        "filter": part_filter,
        "linear": part_linear,
        "boucwen": part_boucwen,
        "simulated": lambda: part_simulated(args.exact),
    }
    for part in args.parts:
        if part not in parts:
            parser.error(f"unknown part {part!r}; parts: {', '.join(parts)}")
        parts[part]()


if __name__ == "__main__":
    main()
