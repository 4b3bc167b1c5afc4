"""The transient rules: from which state a free run on a record starts, and which of its samples are scored.

A free run of a model driven by a record's force must start somewhere, and the
start-up transient of a lightly damped system can dominate the error for
seconds. Benchmark papers therefore state a *transient rule*; nlid knows three:

:class:`FromFirstSample` (``"first-sample"``)
    The state ``z[0]`` and the velocity at ``t = 0`` from the data
    (:func:`~nlid.scoring.initial_state`), every memory state at 0; every
    sample is scored. nlid's rule before the rules existed, and the right one
    for a record that starts at rest (the simulated presets).
:class:`InitWindow` (``"window:N"``)
    The ``nonlinear-benchmarks`` package's ``state_initialization_window_length``:
    the first ``N`` samples are not scored; the initial displacement, velocity
    and every memory state (Bouc-Wen's, Dahl's) are fitted to them by least
    squares (Gauss-Newton on the forward sensitivities of
    :func:`nlid.simulation.simulate_segments`); the run goes on from there.
:class:`PeriodicSteadyState` (``"periodic"``, ``"periodic:P"``)
    For a record in periodic steady state (a multisine's periods): preceding
    periods of the force are simulated until the state at the start of a period
    settles, and every sample of the record is scored from that state (the
    PNLSS and frequency-domain toolboxes prepend one or two periods; the
    settle check goes further and reports how many were needed). The period is
    declared (``period=``, or ``record.meta["periodic"]``) or detected from the
    force (:mod:`nlid.scoring.periods`: a force that repeats at least twice, or one
    whose spectrum is the lines of a multisine cut at whole periods).

:func:`default_rule` gives the rule a benchmark paper would use for a record;
:func:`rule_from_spec` reads the spelling of the command line and of study files.
"""

from __future__ import annotations

import numbers
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..base.validate import Interval, did_you_mean
from ..data.record import Record
from ..errors import InputError
from ..signal import derivatives
from .periods import record_period

__all__ = [
    "FromFirstSample",
    "InitWindow",
    "PeriodicSteadyState",
    "TransientRule",
    "Start",
    "default_rule",
    "rule_from_spec",
    "resolve_rule",
    "error_metrics",
    "SPELLINGS",
    "periodic_fine_force",
]

#: The spellings :func:`rule_from_spec` reads (``N``, ``P``: numbers of samples).
SPELLINGS = ("first-sample", "window:N", "periodic", "periodic:P")

_SAMPLES = Interval(1, None, "left", "a positive whole number of samples", integer=True)
_PERIOD = Interval(2, None, "left", "a whole number of samples, at least 2", integer=True)
_PERIODS = Interval(1, None, "left", "a positive whole number of periods", integer=True)
_TOL = Interval(0.0, 1.0, "neither", "a number between 0 and 1 (a fraction of the state's scale)")


def _count(value: Any, rule: Interval, name: str) -> int:
    """``value`` as an ``int`` (numpy integers accepted) if it satisfies ``rule``."""
    if isinstance(value, numbers.Integral) and not isinstance(value, bool):
        value = int(value)
    return rule.check(value, name)


@dataclass(frozen=True)
class FromFirstSample:
    """Start from the record's first sample (data ``z[0]`` and velocity, memory states 0); score every sample."""

    def describe(self) -> str:
        """``"from the record's first sample"``."""
        return "from the record's first sample"

    def to_spec(self) -> str:
        """The spelling :func:`rule_from_spec` reads back."""
        return "first-sample"


@dataclass(frozen=True)
class InitWindow:
    """An initialisation window: the first ``samples`` are not scored; the initial state is fitted to them.

    Parameters
    ----------
    samples
        Length of the window (samples). The initial displacement, velocity and every memory state are the
        least-squares fit of the simulated ``z`` to the measured one over the window.
    """

    samples: int

    def __post_init__(self) -> None:
        object.__setattr__(self, "samples", _count(self.samples, _SAMPLES, "samples="))

    def describe(self) -> str:
        """``"initialisation window of 50 samples (state fitted to them; not scored)"``."""
        return f"initialisation window of {self.samples} samples (state fitted to them; not scored)"

    def to_spec(self) -> str:
        """The spelling :func:`rule_from_spec` reads back."""
        return f"window:{self.samples}"


@dataclass(frozen=True)
class PeriodicSteadyState:
    """Periodic steady state: preceding periods of the force simulated until the state settles; every sample scored.

    Parameters
    ----------
    period
        The period in samples; ``None``: detected from the force (:func:`record_period`: two whole periods
        in the record, or one period of a multisine).
    max_periods
        Most preceding periods simulated.
    tol
        The state at a period start has settled when it moves by less than ``tol`` times its scale (the
        standard deviation of ``z`` and ``v`` over a period; ``std(z)`` for a Bouc-Wen state, 1 for a Dahl
        state) and the distance still to go, estimated from the geometric decay of the moves, is below that
        too.
    """

    period: int | None = None
    max_periods: int = 100
    tol: float = 1e-6

    def __post_init__(self) -> None:
        if self.period is not None:
            object.__setattr__(self, "period", _count(self.period, _PERIOD, "period="))
        object.__setattr__(self, "max_periods", _count(self.max_periods, _PERIODS, "max_periods="))
        object.__setattr__(self, "tol", _TOL.check(self.tol, "tol="))

    def describe(self) -> str:
        """``"periodic steady state (period 8192 samples, declared)"`` or ``"... (period detected from the force)"``."""
        if self.period is None:
            return "periodic steady state (period detected from the force)"
        return f"periodic steady state (period {self.period} samples, declared)"

    def to_spec(self) -> str:
        """The spelling :func:`rule_from_spec` reads back (``max_periods`` and ``tol`` need the mapping form)."""
        return "periodic" if self.period is None else f"periodic:{self.period}"


TransientRule = FromFirstSample | InitWindow | PeriodicSteadyState
_RULES = (FromFirstSample, InitWindow, PeriodicSteadyState)


@dataclass(frozen=True)
class Start:
    """Where a free run under a rule starts (:func:`start`).

    Attributes
    ----------
    state
        ``(z, v, w_1..w_M)`` at the record's first sample.
    first
        The first scored sample.
    fine
        The force of every RK4 sub-step over the record (:func:`nlid.simulation.fine_force`; for a periodic
        record, of its periodic extension, so the first samples see the preceding period's force).
    description
        The rule as applied: what was found (period, periods simulated, window fitted).
    """

    state: np.ndarray
    first: int
    fine: np.ndarray
    description: str


def default_rule(record: Record) -> TransientRule:
    """The transient rule a benchmark paper would use for a record.

    1. ``record.meta["protocol"]["rule"]`` when a declared benchmark gives one;
    2. ``record.meta["periodic"]`` (``True``, or a period in samples): :class:`PeriodicSteadyState` of that period;
    3. a force detected as periodic (:func:`record_period`: at least two whole periods with a response in
       steady state, or one period of a multisine, its spectrum lines with empty bins between):
       :class:`PeriodicSteadyState` with the period detected, which the rule as applied states;
    4. else :class:`FromFirstSample` (simulated presets start at rest).
    """
    protocol = record.meta.get("protocol")
    if isinstance(protocol, Mapping) and protocol.get("rule"):
        return rule_from_spec(protocol["rule"])
    period, how = record_period(record)
    if period is None:
        return FromFirstSample()
    return PeriodicSteadyState(period if how == "declared" else None)


def rule_from_spec(spec: str | Mapping[str, Any] | TransientRule) -> TransientRule:
    """A transient rule from its spelling.

    Parameters
    ----------
    spec
        ``"first-sample"``, ``"window:50"``, ``"periodic"`` or ``"periodic:8192"`` (the command line's and
        study files' spelling); a mapping ``{"kind": "window", "samples": 50}`` or ``{"kind": "periodic",
        "period": 8192, "max_periods": 100, "tol": 1e-6}``; or a rule (returned as it is).

    Raises
    ------
    InputError
        Anything else.
    """
    if isinstance(spec, _RULES):
        return spec
    if isinstance(spec, Mapping):
        items = dict(spec)
        kind = items.pop("kind", None)
        known = {"first-sample": (), "window": ("samples",), "periodic": ("period", "max_periods", "tol")}
        if kind not in known:
            raise InputError(f"a transient rule's kind must be one of {', '.join(known)}, got {kind!r}")
        extra = sorted(set(items) - set(known[kind]))
        if extra:
            raise InputError(f"a {kind} rule takes {', '.join(known[kind]) or 'no settings'}; unknown: {extra[0]!r}")
        if kind == "window" and "samples" not in items:
            raise InputError("a window rule needs samples (the length of the initialisation window)")
        cls = {"first-sample": FromFirstSample, "window": InitWindow, "periodic": PeriodicSteadyState}[kind]
        return cls(**items)
    if not isinstance(spec, str):
        raise InputError(f"a transient rule is one of {', '.join(SPELLINGS)}, got {type(spec).__name__}")
    text = spec.strip().lower()
    word, _, number = text.partition(":")
    try:
        if word == "first-sample" and not number:
            return FromFirstSample()
        if word == "window" and number:
            return InitWindow(_whole(number))
        if word == "periodic":
            return PeriodicSteadyState(_whole(number) if number else None)
    except ValueError:
        pass
    hint = did_you_mean(word, ("first-sample", "window", "periodic"))
    raise InputError(f"unknown transient rule {spec!r}{hint}; use one of {', '.join(SPELLINGS)}")


def _whole(text: str) -> int:
    if not text.strip().isdigit():
        raise ValueError(text)
    return int(text)


def resolve_rule(rule: str | Mapping[str, Any] | TransientRule | None, record: Record) -> TransientRule:
    """``rule`` read by :func:`rule_from_spec`, or the record's :func:`default_rule` when it is ``None``."""
    return default_rule(record) if rule is None else rule_from_spec(rule)


# --------------------------------------------------------------------------- applying a rule
def error_metrics(z: np.ndarray, z_sim: np.ndarray) -> tuple[float, float, float]:
    """RMSE ``RMS(z_sim - z)``, NRMSE ``100 RMSE / std(z)`` and fit ``100 (1 - |z - z_sim| / |z - mean(z)|)``."""
    # |z - z_sim| / |z - mean(z)| = RMSE / std(z): written through the same mean-based reductions as the
    # NRMSE, because BLAS norms may sum in a different order in another process (last-bit differences)
    rmse = float(np.sqrt(np.mean((z_sim - z) ** 2)))
    nrmse = 100.0 * rmse / float(np.std(z))
    return rmse, nrmse, 100.0 - nrmse


def data_velocity(record: Record) -> np.ndarray:
    """The velocity a state is taken from: the measured one, else ``z`` differentiated through the shared filter."""
    if record.is_measured("v"):
        return np.asarray(record.v)
    v, _ = derivatives.differentiate(record.z, record.fs, order=1)
    return v


def _memory_scales(model: Any, z_scale: float) -> np.ndarray:
    """The scale of each memory state: ``z_scale`` for a state in m (Bouc-Wen), 1 for a dimensionless one (Dahl)."""
    from ..model.terms.memory import KINDS

    return np.array([z_scale if KINDS[t.memory[0]][1] == "m" else 1.0 for t in model.terms if t.is_memory])


def start(fit: Any, record: Record, rule: TransientRule, oversample: int) -> Start:
    """Where a free run of ``fit`` on ``record`` starts under ``rule`` (not :class:`FromFirstSample`: see
    :func:`nlid.scoring.free_run_error`, which keeps its original path).

    Raises
    ------
    InputError
        The record is too short for the rule, or no period is declared and none is detected.
    nlid.simulation.SimulationError
        A simulation diverged.
    """
    from ..simulation import fine_force

    q = int(oversample)
    memory = sum(t.is_memory for t in fit.model.terms)
    state = np.zeros(2 + memory)
    state[0] = record.z[0]
    state[1] = data_velocity(record)[0]
    if isinstance(rule, InitWindow):
        if rule.samples >= record.n - 1:
            raise InputError(
                f"an initialisation window of {rule.samples} samples leaves too little of a record of "
                f"{record.n} samples to score"
            )
        fine = fine_force(record.f, record.force_hold, q)
        fitted = _fit_window(fit, record, rule.samples, fine, q, state)
        return Start(fitted, rule.samples, fine, rule.describe())
    if isinstance(rule, PeriodicSteadyState):
        return _periodic_start(fit, record, rule, q, state)
    if isinstance(rule, FromFirstSample):
        return Start(state, 0, fine_force(record.f, record.force_hold, q), rule.describe())
    raise InputError(f"not a transient rule: {rule!r}")


def _fit_window(fit: Any, record: Record, samples: int, fine: np.ndarray, q: int, guess: np.ndarray) -> np.ndarray:
    """The initial state whose free run best fits ``z`` over the window (Gauss-Newton, trust region)."""
    from scipy import optimize

    from ..simulation import simulate_segments

    model, theta, mass = fit.model, fit.theta, float(fit.mass)
    force, z = record.f[:samples], record.z[:samples]
    sub = fine[: samples * q]
    n_state = guess.size
    runs: dict[bytes, Any] = {}

    def run(x: np.ndarray) -> Any:
        key = x.tobytes()
        if key not in runs:
            runs.clear()
            runs[key] = simulate_segments(
                model, theta, mass, force, record.fs, [0], x[None, :], oversample=q, fine=sub, sensitivities=True
            )
        return runs[key]

    def residuals(x: np.ndarray) -> np.ndarray:
        return run(x).z - z

    def jacobian(x: np.ndarray) -> np.ndarray:
        return run(x).sensitivities[0][:, -n_state:]

    low = np.full(n_state, -np.inf)
    high = np.full(n_state, np.inf)
    for r, term in enumerate(t for t in model.terms if t.is_memory):
        if term.memory[0] == "dahl":  # a Dahl state stays within [-1, 1]
            low[2 + r], high[2 + r] = -1.0, 1.0
    found = optimize.least_squares(
        residuals,
        guess,
        jac=jacobian,
        bounds=(low, high),
        method="trf",
        x_scale="jac",
        xtol=1e-12,
        ftol=1e-12,
        gtol=1e-12,
        max_nfev=100,
    )
    return np.asarray(found.x, dtype=float)


def periodic_fine_force(force: np.ndarray, period: int, force_hold: str, oversample: int) -> np.ndarray:
    """The sub-step force (:func:`nlid.simulation.fine_force`) over a record in periodic steady state.

    Whole periods are interpolated by the FFT; otherwise the record is continued by its own period on each
    side (``f[i - P] = f[i]`` before it, ``f[i + P] = f[i]`` after it) for the interpolator's taps.
    """
    from ..simulation import INTERPOLATION_TAPS, fine_force

    f = np.asarray(force, dtype=float)
    n, q = f.size, int(oversample)
    if n % period == 0:
        return fine_force(f, force_hold, q, periodic=True)
    guard = np.arange(INTERPOLATION_TAPS)
    before = f[(guard - INTERPOLATION_TAPS) % period]  # the first period's end
    after = f[n - period + guard % period]  # the last period's start
    extended = np.concatenate([before, f, after])
    return fine_force(extended, force_hold, q)[INTERPOLATION_TAPS * q : (INTERPOLATION_TAPS + n) * q]


def _periodic_start(fit: Any, record: Record, rule: PeriodicSteadyState, q: int, guess: np.ndarray) -> Start:
    """Simulate preceding periods of the force until the state at a period start settles."""
    from ..simulation import fine_force, simulate_segments

    n = record.n
    if rule.period is None:
        period, how = record_period(record, response=False)
        if period is None:
            raise InputError(
                "periodic steady state: the force neither repeats twice within the record nor is whole periods "
                "of a multisine; declare the period (period=, or the record's meta['periodic'])"
            )
    else:
        period, how = rule.period, "declared"
    if period > n:
        raise InputError(f"periodic steady state needs a whole period ({period} samples) in a record of {n} samples")
    f = record.f
    one = fine_force(f[:period], record.force_hold, q, periodic=True)
    fine = periodic_fine_force(f, period, record.force_hold, q)
    model, theta, mass = fit.model, fit.theta, float(fit.mass)
    state = guess.copy()
    moves: list[float] = []
    settled = False
    for _ in range(rule.max_periods):
        run = simulate_segments(
            model, theta, mass, f[:period], record.fs, [0], state[None, :], oversample=q, fine=one, sensitivities=False
        )
        new = run.end_state[0]
        z_scale = float(np.std(run.z)) or float(np.std(record.z))
        v_scale = float(np.std(run.v)) or 1.0
        scale = np.concatenate([[z_scale, v_scale], _memory_scales(model, z_scale)])
        moves.append(float(np.max(np.abs(new - state) / scale)))
        state = new
        if len(moves) >= 2 and moves[-1] <= rule.tol:
            ratio = moves[-1] / moves[-2] if moves[-2] > 0 else 0.0
            if ratio < 1.0 and moves[-1] * ratio / (1.0 - ratio) <= rule.tol:
                settled = True
                break
    count = len(moves)
    found = f"period {period} samples, {how}; {count} preceding period{'s' if count != 1 else ''} simulated"
    if not settled:
        found += f", not settled (last move {moves[-1]:.2g} of the state's scale)"
    return Start(state, 0, fine, f"periodic steady state ({found})")
