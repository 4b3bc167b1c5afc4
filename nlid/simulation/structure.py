"""Simulating a structure: ``M z'' + C z' + K z + s + sum_e b_e theta_e g_e(x_e, x_e', w_e) = f(t)``.

The integrator is the one-DOF simulator's scheme (:mod:`nlid.simulation`):
classical RK4 with a fixed step, the force held over each step, compiled
with numba (:mod:`nlid.simulation.structure_kernels`). :func:`free_run` splits each sample
interval into ``oversample`` steps with the force of each step from
:func:`nlid.simulation.fine_force` (``"zoh"``: held; ``"sampled"``:
band-limited interpolation at the step's midpoint), exactly as
:func:`nlid.simulation.free_run` does for one DOF; :func:`simulate` takes one
step per sample with the force held. Memory elements start from ``w = 0``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from ..errors import InputError
from ..model.terms import Model, Term
from . import FREE_RUN_OVERSAMPLE, SimulationError, encode_memory, encode_model, fine_force
from .kernels import _sub_steps

if TYPE_CHECKING:  # pragma: no cover
    from ..model.structure import StructuralModel

__all__ = [
    "simulate",
    "free_run",
    "free_run_segments",
]


def _forces(model: StructuralModel, force: np.ndarray) -> np.ndarray:
    f = np.asarray(force, dtype=float)
    if f.ndim == 1 and model.n_dofs == 1:
        f = f[:, None]
    if f.ndim != 2 or f.shape[1] != model.n_dofs:
        raise InputError(f"force must have one column per DOF ({model.n_dofs}), got shape {np.shape(force)}")
    if not np.all(np.isfinite(f)):
        raise InputError("force has a value that is not finite")
    return f


def _state(x0: Sequence[Sequence[float]] | None, n: int) -> tuple[np.ndarray, np.ndarray]:
    if x0 is None:
        return np.zeros(n), np.zeros(n)
    try:
        z0, v0 = (np.asarray(x, dtype=float).reshape(n) for x in x0)
    except (TypeError, ValueError):
        raise InputError(f"x0 must be (displacements, velocities), each of {n} values") from None
    if not (np.all(np.isfinite(z0)) and np.all(np.isfinite(v0))):
        raise InputError("x0 has a value that is not finite")
    return z0, v0


def _encoded(model: StructuralModel) -> tuple:
    """The elements as the kernel's arrays (one row each) and the order of ``K z`` and ``C z'`` among them."""
    elements = model.elements.elements
    count = len(elements)
    parts = np.zeros((count, 6), np.int64)
    width = max([len(e.term.special) for e in elements] + [1])
    special = np.zeros((count, width, 4))
    pxc = np.zeros((count, 4))
    memory = np.zeros((count, 3))
    for k, e in enumerate(elements):
        one = Model((e.term,), model.elements.roots_of(e))
        p, s, c = encode_model(one)
        parts[k] = p[0]
        special[k, : s.shape[1]] = s[0]
        pxc[k] = c
        memory[k] = encode_memory(one)[0]
    theta = np.ascontiguousarray(model.theta)
    plain = np.where(memory[:, 0] > 0, 0.0, theta)
    ci = np.array([e.i - 1 for e in elements], np.int64)
    cj = np.array([e.j - 1 for e in elements], np.int64)
    if model.n_dofs == 1:  # the one-DOF simulator's order of the terms
        z_key, v_key = Term(z=(1, 1)).sort_key(), Term(v=(1, 1)).sort_key()
        kpos = sum(1 for e in elements if e.term.sort_key() < z_key)
        cpos = sum(1 for e in elements if e.term.sort_key() < v_key)
    else:
        kpos = cpos = 0
    return theta, plain, memory, parts, special, pxc, ci, cj, kpos, cpos


def _inverse_mass(M: np.ndarray) -> np.ndarray:
    d = np.diag(M)
    if np.count_nonzero(M - np.diag(d)) == 0:
        return np.diag(1.0 / d)
    return np.linalg.inv(M)


def _arguments(model: StructuralModel) -> tuple:
    """The kernel's arguments that describe the structure (between the step and the initial state)."""
    matrices = (_inverse_mass(model.M), model.K, model.C, model.static)
    return tuple(np.ascontiguousarray(x) for x in matrices) + _encoded(model)


def _run(model: StructuralModel, fine: np.ndarray, dt: float, stride: int, x0, fs: float, args=None, first=0) -> tuple:
    """The kernel over ``fine`` from ``x0``; ``args``: :func:`_arguments` when the caller has them; ``first``: the
    record's sample the run starts at (for the message)."""
    from .structure_kernels import integrate

    n = model.n_dofs
    z0, v0 = _state(x0, n)
    rows = fine.shape[0] // stride
    out = [np.empty((rows, n)) for _ in range(3)]
    args = _arguments(model) if args is None else args
    bad = integrate(np.ascontiguousarray(fine), float(dt), int(stride), *args, z0, v0, *out)
    if bad >= 0:
        sample = first + bad // stride
        raise SimulationError(
            f"simulation diverged at sample {sample} (t = {sample / fs:.4g} s); the structure may be unstable "
            "for this force (check the signs of the coefficients: they are coefficients of R = f - M z'')"
        )
    return tuple(out)


def simulate(
    model: StructuralModel, force: np.ndarray, fs: float, *, x0: Sequence[Sequence[float]] | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Integrate with one RK4 step per sample, the force held over each sample.

    Parameters
    ----------
    model
        The structure.
    force
        Force samples (N), shape ``(N, n)`` (``(N,)`` for one DOF).
    fs
        Sampling frequency (Hz).
    x0
        Initial displacements and velocities ``(z0, v0)``, each ``n`` values; default at rest at 0.

    Returns
    -------
    z, v, a : numpy.ndarray
        Shape ``(N, n)`` each, at the sample times; ``a`` is exactly ``M^-1 (f - R)`` there.

    Raises
    ------
    SimulationError
        If the state becomes non-finite.
    """
    return free_run(model, force, fs, force_hold="zoh", x0=x0, oversample=1)


def free_run(
    model: StructuralModel,
    force: np.ndarray,
    fs: float,
    *,
    force_hold: str = "sampled",
    x0: Sequence[Sequence[float]] | None = None,
    oversample: int = FREE_RUN_OVERSAMPLE,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Free run of a structure driven by a force, with ``oversample`` RK4 steps per sample.

    As :func:`nlid.simulation.free_run` for one DOF: a ``"sampled"`` force
    is interpolated (band-limited) at the midpoint of every step, a
    ``"zoh"`` force is held exactly.

    Parameters
    ----------
    model
        The structure.
    force
        Force samples (N), shape ``(N, n)``.
    fs
        Their sampling frequency (Hz).
    force_hold
        ``"sampled"`` or ``"zoh"``.
    x0
        Initial displacements and velocities ``(z0, v0)``; default at rest at 0.
    oversample
        Steps per sample (default :data:`nlid.simulation.FREE_RUN_OVERSAMPLE`).

    Returns
    -------
    z, v, a : numpy.ndarray
        The response at the force's sample times, shape ``(N, n)`` each.

    Raises
    ------
    SimulationError
        If the state becomes non-finite.
    """
    fine, q, fs = _fine(model, force, fs, force_hold, oversample)
    return _run(model, fine, 1.0 / (fs * q), q, x0, fs)


def _fine(model: StructuralModel, force: np.ndarray, fs: float, force_hold: str, oversample: int) -> tuple:
    """The checked sub-step force ``(N q, n)``, ``q`` and ``fs``."""
    q = _sub_steps(force_hold, oversample)
    fs = float(fs)
    if not np.isfinite(fs) or fs <= 0:
        raise InputError(f"fs must be a positive number of Hz, got {fs!r}")
    f = _forces(model, force)
    return np.stack([fine_force(f[:, k], force_hold, q) for k in range(f.shape[1])], axis=1), q, fs


def _segment_starts(starts: Sequence[int] | np.ndarray, N: int) -> np.ndarray:
    """The checked first sample of each segment of ``N`` samples: increasing from 0, below ``N``."""
    starts = np.asarray(starts, dtype=np.int64)
    if starts.ndim != 1 or starts.size == 0 or starts[0] != 0 or np.any(np.diff(starts) <= 0) or starts[-1] >= N:
        raise InputError(f"starts must increase from 0 and stay below the {N} samples")
    return starts


def free_run_segments(
    model: StructuralModel,
    force: np.ndarray,
    fs: float,
    starts: Sequence[int] | np.ndarray,
    states: np.ndarray,
    *,
    force_hold: str = "sampled",
    oversample: int = FREE_RUN_OVERSAMPLE,
) -> tuple[np.ndarray, np.ndarray]:
    """Free runs of consecutive segments of a record (multiple shooting), each from its own state.

    The structure's counterpart of :func:`nlid.simulation.simulate_segments` (without sensitivities): the
    scheme of :func:`free_run`, the sub-step force computed once for the whole record, the structure
    encoded once for all segments.

    Parameters
    ----------
    model, force, fs, force_hold, oversample
        As in :func:`free_run`.
    starts
        First sample of each segment, increasing, starting at 0.
    states
        Shape ``(K, 2 n)``: the displacements and velocities at the start of each segment.

    Returns
    -------
    z : numpy.ndarray
        Shape ``(N, n)``: each segment's samples from its own run.
    ends : numpy.ndarray
        Shape ``(K, 2 n)``: the state ``(z, v)`` each run reaches at the next segment's first sample (the last
        segment's: at the record's last sample).

    Raises
    ------
    SimulationError
        If a state becomes non-finite.
    """
    fine, q, fs = _fine(model, force, fs, force_hold, oversample)
    n, N = model.n_dofs, fine.shape[0] // q
    starts = _segment_starts(starts, N)
    states = np.asarray(states, dtype=float)
    if states.shape != (starts.size, 2 * n):
        raise InputError(f"states must have shape ({starts.size}, {2 * n}), got {states.shape}")
    args = _arguments(model)
    edges = np.append(starts, N)
    z, ends = np.empty((N, n)), np.empty((starts.size, 2 * n))
    for k, (a, b) in enumerate(zip(edges[:-1], edges[1:], strict=True)):
        stop = min(b + 1, N)  # one sample more: the state the next segment starts from
        run = _run(model, fine[a * q : stop * q], 1.0 / (fs * q), q, (states[k, :n], states[k, n:]), fs, args, a)
        z[a:b] = run[0][: b - a]
        ends[k] = np.concatenate([run[0][-1], run[1][-1]])
    return z, ends
