"""Errors-in-variables and filtering bias of the equation-error estimate, by simulation.

The regressors ``g_i(z, v)`` are evaluated on the measured displacement (and
a velocity differentiated from it), so measurement noise enters them: least
squares on ``y = f - m a = G theta + e`` is then biased (errors in
variables). A Coulomb term ``sign(v) |px(z)|`` evaluated on a noisy velocity
is smeared near ``v = 0``; ``v |v|`` picks up a spurious ``sign(v)`` part.
Estimating the velocity through the low-pass adds a smaller bias even without
noise. On the ``paper-experimental`` preset with 2 % noise on ``z`` and ``a``
the friction coefficients come out 10-75 % off, 5-8 standard deviations.

The correction is indirect inference (Gourieroux, Monfort & Renault 1993)
with a binding function that is linear at each step: the identified model is
simulated with the recorded force, noise of the level measured on the record
is added to the channels the regressors are built from, and the same force
balance (:func:`nlid.estimation.balance.regression_data`, same band) is formed. On a
simulated record the exact regressors ``G_ex`` (from the simulated ``z`` and
``v``, through the same low-pass) are known, and ``y = G_ex theta`` holds
exactly when the acceleration is measured. Least squares on the noisy
regressors therefore returns ``E[theta_hat] = J theta + d`` with

* ``J = E[(G^T G)^-1 G^T G_ex]`` (the attenuation, or binding, matrix) and
* ``d = E[(G^T G)^-1 G^T (y - G_ex theta)]`` (noise that enters ``y`` too,
  e.g. when ``a`` is differentiated from the noisy ``z``),

and the corrected estimate solves ``theta_hat = J theta + d``. Each of
``pairs`` antithetic noise pairs (``+n`` and ``-n``, which cancel the part
linear in the noise) drives its own trajectory: the recorded force shifted
circularly by a fraction of its length, so that ``J`` is averaged over
trajectories and not tied to one (on ``paper-experimental`` two trajectories
driven by the same force gave corrections one standard deviation apart).
:func:`indirect_inference` repeats the step at the corrected point (a fixed
point of the binding function) and propagates the covariance.

Assumptions: the measurement noise on ``z`` (and on ``v`` when it is
measured) is white and its level is the one :func:`nlid.signal.derivatives.noise_sd`
reads from the record's noise floor (override it with ``noise``); the force
is stationary (its circular shifts are equally likely excitations); the
simulation starts from the record's first displacement at rest, reads the
force between the samples as the record's force balance does (held for
``force_hold="zoh"``, band-limited for a sampled force) and takes the RK4
sub-steps the record needs (:func:`correction_substeps`: at least 40 steps
per period of the fastest linear mode). Noise on the acceleration needs no correction (it
enters ``y`` linearly and independently of ``G``) and is not simulated.
"""

from __future__ import annotations

import os
from collections import deque
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..base import numerics
from ..data.record import Record
from ..errors import IdentificationError, InputError, NlidError
from ..estimation.balance import RegressionData, regression_data, share_channels
from ..model.terms import Model
from ..runtime import parallel
from ..signal import derivatives
from ..simulation import SimulationError, fine_force, simulate
from .noise import channel_noise

__all__ = ["BiasCorrection", "simulate_bias", "indirect_inference", "regressor_noise", "correction_substeps"]

#: RK4 steps per period of the fastest linear mode the correction's simulation takes at least
#: (:func:`correction_substeps`).
STEPS_PER_PERIOD = 40
#: The most sub-steps per sample :func:`correction_substeps` chooses.
MAX_SUBSTEPS = 32


@dataclass(frozen=True)
class BiasCorrection:
    """The linear binding function ``E[theta_hat] = J theta + d``.

    Attributes
    ----------
    binding
        ``J``, shape ``(p, p)``: the mean over the pairs.
    offset
        ``d``, shape ``(p,)``.
    pair_bindings, pair_offsets
        ``J`` and ``d`` of each antithetic pair alone, shapes
        ``(pairs, p, p)`` and ``(pairs, p)``: their spread is the Monte Carlo
        error.
    noise
        Noise standard deviation simulated on each channel.
    """

    binding: np.ndarray
    offset: np.ndarray
    pair_bindings: np.ndarray
    pair_offsets: np.ndarray
    noise: dict[str, float]

    @property
    def pairs(self) -> int:
        """Number of antithetic noise pairs simulated."""
        return int(self.pair_offsets.shape[0])

    def correct(self, theta_hat: np.ndarray) -> np.ndarray:
        """The bias-corrected estimate ``J^-1 (theta_hat - d)``."""
        return np.linalg.solve(self.binding, np.asarray(theta_hat, dtype=float) - self.offset)

    def pair_estimates(self, theta_hat: np.ndarray) -> np.ndarray:
        """The corrected estimate from each antithetic pair alone, shape ``(pairs, p)``."""
        theta_hat = np.asarray(theta_hat, dtype=float)
        return np.array(
            [np.linalg.solve(J, theta_hat - d) for J, d in zip(self.pair_bindings, self.pair_offsets, strict=True)]
        )


def regressor_noise(record: Record, model: Model, noise: Mapping[str, float] | None = None) -> dict[str, float]:
    """Noise standard deviation on each channel the regressors are built from.

    ``z`` always (it gives the position terms and, when not measured, the
    velocity and acceleration) and ``v`` when it is measured and the model
    uses it. Levels in ``noise`` win; the others are established from the
    record by :func:`nlid.bayes.noise.channel_noise` (``z`` from its noise
    floor, ``v`` from its consistency with ``dz/dt``), which refuses
    (:class:`~nlid.bayes.noise.UnknownNoiseError`) when it cannot.
    """
    return {c: level.sd for c, level in channel_noise(record, model, noise).items()}


def correction_substeps(record: Record, model: Model, theta: np.ndarray, mass: float) -> int:
    """RK4 sub-steps per sample that make the correction's simulation accurate on this record.

    The rule: at least :data:`STEPS_PER_PERIOD` steps per period of the fastest linear mode,
    ``q = ceil(STEPS_PER_PERIOD f_n / fs)`` with ``f_n`` the highest natural frequency of the model
    linearised at its stable equilibria within the recorded displacement (:func:`nlid.model.physics.modal`;
    without one, the stiffest point of that range), at least 1 and at most :data:`MAX_SUBSTEPS`. A model
    without a positive stiffness gets one step per sample.

    Why: RK4 with the step ``h`` shifts a linear oscillation's frequency by about ``(omega h)^4 / 120``
    (relative) and adds a numerical damping ratio of about ``(omega h)^5 / 144``. At one step per sample on
    Silverbox (the cubic model's linear mode at 68 Hz, sampled at 610 Hz: 8.9 samples per period) that is a
    0.2 % frequency error and a damping ratio of 1.2e-3; the simulated records then carry an integration
    error that the correction reads as bias (it moved ``v`` by +2,693 sd, the force also held). Measured with
    ``benchmarks/posterior_substeps.py`` (Silverbox SNLS80mV, ``z^3``; the corrected estimate's largest
    difference from the one with 16 sub-steps, in sd of each coefficient): 125 sd with 1 sub-step per
    sample, 3.1 with 2, 0.19 with 4, 0.078 with 5 (this rule's choice), 0.011 with 8; the correction
    then moves ``v`` by -2.3 sd (``nlid posterior`` on SNLS80mV). The presets have 44 (``paper-experimental``)
    and 157 (``paper-numerical``) samples per period of their fastest linear mode and keep one step per sample,
    to the bit the simulation before sub-steps: on ``paper-numerical`` (2 % noise on z, v and a) 1 and 16
    sub-steps differ by 0.002 sd; on ``paper-experimental`` (2 % on z and a; chaotic, so any change of the
    integration draws other trajectories) 1, 2, 4 and 8 sub-steps differ from 16 by 0.8, 0.4, 0.6 and 0.5 sd,
    the correction's Monte Carlo spread, with no trend.
    """
    from ..model import physics

    fs = float(record.fs)
    z = np.asarray(record.z, dtype=float)
    if not (np.isfinite(mass) and mass > 0) or z.size == 0 or not np.all(np.isfinite(z)):
        return 1
    theta = np.asarray(theta, dtype=float)
    lo, hi = float(np.min(z)), float(np.max(z))
    with numerics.collect_warnings():  # a frequency that cannot be formed falls back below, quietly
        try:
            modes = physics.modal(model, theta, mass, z_range=(lo, hi))
        except (NlidError, ArithmeticError, ValueError, np.linalg.LinAlgError):
            modes = []
        if modes:
            f_n = max(m.fn_hz for m in modes)
        else:  # no stable equilibrium in the range: the stiffest point of it
            grid = np.linspace(lo, hi, 65) if hi > lo else np.array([lo])
            step = max(hi - lo, abs(lo), 1e-12) * 1e-6
            k = (physics.elastic(model, theta, grid + step) - physics.elastic(model, theta, grid - step)) / (2 * step)
            k = k + sum(float(c) * term.memory_slope for term, c in zip(model.terms, theta, strict=True))
            top = float(np.max(k))
            f_n = np.sqrt(top / mass) / (2 * np.pi) if np.isfinite(top) and top > 0 else 0.0
    if not (np.isfinite(f_n) and f_n > 0):
        return 1
    return int(min(MAX_SUBSTEPS, max(1, np.ceil(STEPS_PER_PERIOD * f_n / fs))))


def _fit(G: np.ndarray, B: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """``(G^T G)^-1 G^T B`` with the columns of G scaled for conditioning."""
    Gs = G / scale
    out = np.linalg.solve(Gs.T @ Gs, Gs.T @ B)
    return out / (scale if out.ndim == 1 else scale[:, None])


def simulate_bias(
    record: Record,
    model: Model,
    theta: np.ndarray,
    mass: float,
    data: RegressionData,
    *,
    pairs: int = 4,
    noise: Mapping[str, float] | None = None,
    rng: np.random.Generator | None = None,
    phase: float = 0.0,
    substeps: int | None = None,
) -> BiasCorrection:
    """Estimate the binding function at ``theta`` by simulating the identified model.

    Parameters
    ----------
    record
        The measured record (its force, sampling, channels and noise floor).
    model, theta, mass
        The model and the coefficients to simulate (usually the least-squares
        estimate); the mass in kg.
    data
        The record's force balance (gives the band and the kept samples).
    pairs
        Number of antithetic noise pairs (each costs two force balances).
    noise
        Noise standard deviations for ``z`` (and ``v``), default from the
        noise floor.
    rng
        Random generator of the noise.
    phase
        Fraction of ``1 / pairs`` of the record by which every circular
        shift of the force is moved on (gives other trajectories).
    substeps
        RK4 sub-steps per sample of the simulation (default
        :func:`correction_substeps`).

    Raises
    ------
    IdentificationError
        If the identified model cannot be simulated (it diverges).
    """
    levels = regressor_noise(record, model, noise)
    substeps = _check_substeps(substeps)
    (correction,) = _bindings(
        record, model, theta, mass, data, [levels], pairs=pairs, rng=rng, phase=phase, substeps=substeps
    )
    return correction


def _check_substeps(substeps: int | None) -> int | None:
    """``substeps=`` as a positive whole number (``None``: the rule of :func:`correction_substeps`)."""
    if substeps is None:
        return None
    if isinstance(substeps, bool) or not isinstance(substeps, (int, np.integer)) or substeps < 1:
        raise InputError(f"substeps must be a positive whole number of RK4 sub-steps per sample, got {substeps!r}")
    return int(substeps)


def bias_threads(pairs: int) -> int:
    """Threads the antithetic pairs of one step are simulated on: the free cores, at most one per pair.

    :func:`nlid.runtime.parallel.threads` with the 1-minute load average: one in a process whose numerical
    libraries are pinned to a thread (a study's run: one run per core, ``NUMBA_NUM_THREADS=1``,
    :func:`nlid.runtime.process.pin_threads`); else ``NLID_WORKERS`` when set (a positive integer: nlid's
    one pool size; anything else is an :class:`~nlid.errors.InputError`); otherwise the cores this process
    may use less the other processes' load, at least one.
    """
    if pairs <= 1:
        return 1
    try:
        load = os.getloadavg()[0]
    except OSError:  # pragma: no cover - no load average
        load = 0.0
    return parallel.threads(pairs, load=load)


def _bindings(
    record: Record,
    model: Model,
    theta: np.ndarray,
    mass: float,
    data: RegressionData,
    level_sets: list[dict[str, float]],
    *,
    pairs: int,
    rng: np.random.Generator | None,
    phase: float,
    threads: int | None = None,
    substeps: int | None = None,
) -> list[BiasCorrection]:
    """:func:`simulate_bias` for several sets of noise levels on the same trajectories and noise draws.

    Every set must name the same channels; each set's noise is the same
    standard-normal draws times its levels (common random numbers), so the
    differences between the sets' corrections are due to the levels alone.

    The pairs' simulations and force balances (compiled kernel, FFT filters and
    array arithmetic, which release the GIL) run on ``threads`` threads
    (default :func:`bias_threads`), at most that many pairs ahead; their noise
    is drawn from ``rng`` in pair order first, and the least-squares fits (the
    only linear algebra) run in this thread in pair order. Every number is the
    one the pairs give one after the other, to the bit: the correction feeds a
    simulation of a possibly chaotic model, where a difference in the last bit
    would grow into a different Monte Carlo draw.

    Each trajectory is integrated with ``substeps`` RK4 sub-steps per sample (default
    :func:`correction_substeps` at ``theta``) through :func:`_trajectory`.
    """
    if pairs < 1:
        raise InputError(f"bias correction needs at least one noise pair, got {pairs}")
    rng = rng if rng is not None else np.random.default_rng(0)
    theta = np.asarray(theta, dtype=float)
    v0 = float(record.v[0]) if record.is_measured("v") else 0.0
    fc = data.filtered_at
    meta = {"force_hold": record.force_hold}
    units = [{c: rng.standard_normal(record.n) for c in level_sets[0]} for _ in range(pairs)]
    q = correction_substeps(record, model, theta, mass) if substeps is None else int(substeps)

    def balances(pair: int) -> list[list[tuple[np.ndarray, np.ndarray, np.ndarray]]]:
        """``(G, G_ex, y)`` of each level set and sign (+, -) for one antithetic pair."""
        # each pair drives its own trajectory: the recorded force shifted circularly by pair/pairs of its length
        force = np.roll(record.f, -int((pair + phase) * record.n / pairs))
        try:
            zs, vs, as_ = _trajectory(model, theta, mass, force, record, (float(record.z[0]), v0), q)
        except SimulationError as exc:
            raise IdentificationError(
                f"bias correction: the identified model diverges when simulated with the recorded force ({exc}); "
                "switch the correction off (bias_correction=False)"
            ) from None
        exact = model.evaluate(zs, vs if model.uses_velocity else None)
        if fc is not None:
            # a constant column (the term 1) is its own low-pass, to the bit (the filter passes the line through
            # the end samples unchanged): only the others are filtered, the filter's response computed once
            varying = [j for j in range(exact.shape[1]) if np.any(exact[:, j] != exact[0, j])]
            derivatives.lowpass_columns(exact, record.fs, fc, varying)
        states = {"z": zs, "v": vs}
        channels = {"a": as_} if record.is_measured("a") else {}
        out = []
        first = None
        for levels in level_sets:
            signs = []
            for sign in (1.0, -1.0):
                noisy = dict(channels)
                for c, n in units[pair].items():
                    noisy[c] = states[c] + sign * (levels[c] * n)
                sim = Record(f=force, fs=record.fs, meta=meta, **noisy)
                # the force (and a measured acceleration) is the same in every noisy copy: filtered once
                if first is not None:
                    share_channels(first, sim)
                d = regression_data(sim, model, cutoff=fc)
                first = first if first is not None else sim
                signs.append((d.G, exact[d.kept], d.restoring_force(mass)))
            out.append(signs)
        return out

    scale = None
    J_pairs: list[list[np.ndarray]] = [[] for _ in level_sets]
    d_pairs: list[list[np.ndarray]] = [[] for _ in level_sets]
    for sets in _in_order(balances, pairs, bias_threads(pairs) if threads is None else threads):
        for k, signs in enumerate(sets):
            Js, ds = [], []
            for G, G_ex, y in signs:
                if scale is None:
                    scale = np.sqrt(np.mean(G**2, axis=0))
                    scale[scale == 0] = 1.0
                both = _fit(G, np.column_stack([G_ex, y - G_ex @ theta]), scale)
                Js.append(both[:, :-1])
                ds.append(both[:, -1])
            J_pairs[k].append(0.5 * (Js[0] + Js[1]))
            d_pairs[k].append(0.5 * (ds[0] + ds[1]))
    out = []
    for k, levels in enumerate(level_sets):
        J = np.mean(J_pairs[k], axis=0)
        d = np.mean(d_pairs[k], axis=0)
        if not np.all(np.isfinite(J)) or np.linalg.cond(J) > 1e12:
            raise IdentificationError(
                "bias correction: the simulated attenuation matrix is singular (a term carries no information "
                "once noise is added); switch the correction off or remove the term"
            )
        out.append(
            BiasCorrection(
                binding=J,
                offset=d,
                pair_bindings=np.array(J_pairs[k]),
                pair_offsets=np.array(d_pairs[k]),
                noise=dict(levels),
            )
        )
    return out


def _trajectory(
    model: Model, theta: np.ndarray, mass: float, force: np.ndarray, record: Record, x0: tuple[float, float], q: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The model's response to ``force`` at the record's samples, ``q`` RK4 sub-steps per sample.

    The force between the samples is the one the record's force balance assumes
    (:func:`nlid.simulation.fine_force` with the record's ``force_hold``): held
    over each sample for ``"zoh"``, the band-limited signal through the samples
    for ``"sampled"`` (a held sampled force would reach the motion half a sample
    late, which the force balance of a sampled record does not expect, and the
    correction would read that delay as bias). A held force with ``q = 1`` is
    :func:`nlid.simulation.simulate` itself, to the bit. The acceleration is the
    one at the sample times, ``(f_k - R(z_k, v_k)) / m``.
    """
    if q == 1 and record.force_hold == "zoh":
        return simulate(model, theta, mass, force, record.fs, x0)
    fine = fine_force(force, record.force_hold, q)
    z, v, a = simulate(model, theta, mass, fine, record.fs * q, x0)
    # the kernel's acceleration at a sample is (fine - R) / m; the force at the sample time is the sample itself
    return z[::q], v[::q], a[::q] + (force - fine[::q]) / mass


def _in_order(work: Callable[[int], Any], count: int, threads: int) -> Iterator[Any]:
    """``work(0)``, ``work(1)``, ... in order, computed on ``threads`` threads at most ``threads`` items ahead.

    An error of an item is raised when its turn comes (the earlier items are yielded first).
    """
    threads = max(1, min(int(threads), count))
    if threads == 1:
        for i in range(count):
            yield work(i)
        return
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(threads, thread_name_prefix="nlid-bias") as pool:
        pending = deque(pool.submit(work, i) for i in range(threads))
        submitted = threads
        try:
            while pending:
                value = pending.popleft().result()
                if submitted < count:
                    pending.append(pool.submit(work, submitted))
                    submitted += 1
                yield value
        finally:
            for fut in pending:
                fut.cancel()


def indirect_inference(
    record: Record,
    model: Model,
    theta_hat: np.ndarray,
    mass: float,
    data: RegressionData,
    covariance: np.ndarray,
    *,
    pairs: int = 4,
    iterations: int = 3,
    noise: Mapping[str, float] | None = None,
    rng: np.random.Generator | None = None,
    substeps: int | None = None,
    parts: dict[str, Any] | None = None,
) -> tuple[np.ndarray, np.ndarray, dict[str, Any]]:
    """Bias-corrected estimate and its covariance.

    Iterates ``theta_{k+1} = J(theta_k)^-1 (theta_hat - d(theta_k))`` from
    ``theta_0 = theta_hat``, each step simulating the model at the current
    point (a fixed point of the binding function, as indirect inference asks;
    the second step mattered on ``paper-experimental``, where the attenuation
    depends on the friction itself). The covariance is
    ``J^-1 V J^-T + (1 + 1/pairs) S`` with ``S`` the spread of a single
    pair's corrected estimate (pooled over the iterations): the record's own
    bias is one draw from that spread (its trajectory and noise), and the
    mean of ``pairs`` draws carries ``S / pairs`` of Monte Carlo error.

    Parameters
    ----------
    record, model, theta_hat, mass, data
        As for :func:`simulate_bias`; ``theta_hat`` is the least-squares
        estimate of the record.
    covariance
        ``V``, the sampling covariance of ``theta_hat``.
    pairs
        Antithetic pairs of the last step (at least 2, for the spread); the
        earlier steps, which only move the point of evaluation, use half as
        many (at least 2).
    iterations
        Fixed-point steps (a step with ``k`` pairs costs ``k`` simulations
        and ``2 k`` force balances).
    noise, rng
        As for :func:`simulate_bias`.
    substeps
        RK4 sub-steps per sample of every step's simulations (default
        :func:`correction_substeps` at ``theta_hat``, kept for every step).
    parts
        A dictionary that, when given, receives the covariance's parts (for
        calibration experiments): ``sampling`` (``J^-1 V J^-T``), ``spread``
        (``S``), ``level_moves`` (the noise levels' rank-one moves) and
        ``spread_dof``.

    Returns
    -------
    centre, covariance, info
        The corrected estimate, its covariance, and diagnostics (noise
        levels, the steps' estimates).
    """
    if pairs < 2:
        raise InputError(f"the bias correction needs at least 2 noise pairs to measure its own spread, got {pairs}")
    if iterations < 1:
        raise InputError(f"the bias correction needs at least one iteration, got {iterations}")
    theta_hat = np.asarray(theta_hat, dtype=float)
    rng = rng if rng is not None else np.random.default_rng(0)
    substeps = _check_substeps(substeps)
    q = correction_substeps(record, model, theta_hat, mass) if substeps is None else substeps
    levels = channel_noise(record, model, noise)
    sds = {c: level.sd for c, level in levels.items()}
    # a level estimated with a standard error: the last step also gives the correction at a variance one
    # standard error higher, on the same trajectories and draws; the move of the corrected estimate enters the
    # covariance as a rank-one term (the delta method over one standard error of the level)
    uncertain = [c for c, level in levels.items() if level.relative_se]
    bumped = [dict(sds, **{c: levels[c].sd * np.sqrt(1.0 + levels[c].relative_se)}) for c in uncertain]
    theta = theta_hat
    deviations = []
    steps = []
    corr = None
    others: list[BiasCorrection] = []
    for it in range(iterations):
        # the earlier steps only move the point where the binding function is evaluated: half the pairs do
        final = it == iterations - 1
        n_pairs = pairs if final else max(2, pairs // 2)
        sets = [sds, *bumped] if final else [sds]
        corr, *others = _bindings(
            record, model, theta, mass, data, sets, pairs=n_pairs, rng=rng, phase=it / iterations, substeps=q
        )
        each = corr.pair_estimates(theta_hat)
        deviations.append(each - each.mean(axis=0))
        theta = corr.correct(theta_hat)
        steps.append(theta)
    dev = np.concatenate(deviations)
    spread = dev.T @ dev / (dev.shape[0] - iterations)
    jinv = np.linalg.inv(corr.binding)
    sampling = jinv @ np.asarray(covariance, dtype=float) @ jinv.T
    cov = sampling + (1.0 + 1.0 / pairs) * spread
    widening = {}
    level_moves = []
    for c, other in zip(uncertain, others, strict=True):
        move = other.correct(theta_hat) - theta
        cov = cov + np.outer(move, move)
        level_moves.append(move)
        widening[c] = {n: float(x) for n, x in zip(model.names, move, strict=True)}
    if parts is not None:
        parts.update(sampling=sampling, spread=spread, level_moves=level_moves, spread_dof=dev.shape[0] - iterations)
    info = {
        "noise_sd": corr.noise,
        "noise": {c: level.to_dict() for c, level in levels.items()},
        "noise_level_moves": widening,
        "pairs": pairs,
        "iterations": iterations,
        "substeps": q,
        "steps": [s.tolist() for s in steps],
    }
    return theta, 0.5 * (cov + cov.T), info
