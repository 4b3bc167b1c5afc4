"""The chaos check's pair of free runs, the second stopped where it joins the first.

:func:`nlid.scoring.free_run_error` judges a model chaotic when two free runs started
:data:`~nlid.scoring.SENSITIVITY_DELTA` ``std(z)`` apart end up apart. For a model that is not
chaotic the two runs do not merely come close: the offset decays below the last bit and, from some
sample on, the two states ``(z, v)`` are the same floating-point numbers (on the paper-numerical
study's fits after 5-14 % of the record, seen at a chunk's end after 7-17 %). The RK4 step is a
function of the state and the force alone, so from that sample on the second run *is* the first,
to the bit. :func:`free_run_pair` therefore integrates the second run in chunks, compares its
state with the first run's at the end of each chunk, and stops at the first equal state, taking the
rest from the first run. The
displacements it returns are bitwise those of two whole :func:`nlid.simulation.free_run` calls;
only the work of the second run after the join is not done (on a chaotic model nothing is saved).

A chunk restarts :func:`nlid.simulation.simulate` from the state at its first sample, which is
the state the whole run has there, so the chunked runs are the whole runs to the bit. Models with
memory terms (Bouc-Wen's and Dahl's states are not part of the state a chunk can restart from) and
runs that diverge take the whole runs (:func:`nlid.simulation.free_run`), so every number and every
message is the one of the whole runs.
"""

from __future__ import annotations

import threading
from collections.abc import Sequence

import numpy as np

from ..model.terms import Model
from ..runtime.parallel import both

__all__ = ["free_run_pair", "CHUNK_SAMPLES"]

#: Samples per chunk of the runs compared for the join (4096 samples x 8 sub-steps: ~3 ms of RK4).
CHUNK_SAMPLES = 4096


def free_run_pair(
    model: Model,
    theta: np.ndarray,
    mass: float,
    force: np.ndarray,
    fs: float,
    *,
    force_hold: str,
    x0: Sequence[float],
    x1: Sequence[float],
    oversample: int | None = None,
    chunk: int = CHUNK_SAMPLES,
) -> tuple[np.ndarray, np.ndarray]:
    """The displacements of two free runs of one model and force, from ``x0`` and from ``x1``.

    Bitwise ``free_run(..., x0=x0)[0]`` and ``free_run(..., x0=x1)[0]`` (:func:`nlid.simulation.free_run`,
    the same arguments), the second integrated only until its state equals the first's. With a thread
    budget of two (:func:`nlid.runtime.parallel.both`) the two runs go at once, the second following the
    first chunk by chunk.

    Parameters
    ----------
    model, theta, mass
        The model, its coefficients in model order and the mass (kg).
    force, fs, force_hold
        The force samples (N), their sampling frequency (Hz) and hold (``"sampled"`` or ``"zoh"``).
    x0, x1
        The initial displacement and velocity of each run.
    oversample
        Sub-steps per sample (default :data:`nlid.simulation.FREE_RUN_OVERSAMPLE`).
    chunk
        Samples per chunk of the compared runs.

    Returns
    -------
    z0, z1 : numpy.ndarray
        The displacement of each run at the force's sample times.

    Raises
    ------
    nlid.simulation.SimulationError
        A run diverged (the first run's error before the second's, as in sequence).
    """
    from ..simulation import FREE_RUN_OVERSAMPLE, SimulationError, fine_force, free_run

    q = FREE_RUN_OVERSAMPLE if oversample is None else int(oversample)
    force = np.asarray(force, dtype=float)

    def whole(x: Sequence[float]) -> np.ndarray:
        return free_run(model, theta, mass, force, fs, force_hold=force_hold, x0=x, oversample=q)[0]

    if model.uses_memory or q < 1 or force_hold not in ("sampled", "zoh") or force.ndim != 1 or force.size < 2:
        return both(lambda: whole(x0), lambda: whole(x1))  # the whole runs (and free_run's own messages)
    pair = _Pair(model, theta, float(mass), fine_force(force, force_hold, q), float(fs), q, force.size, int(chunk))
    try:
        pair.run(x0, x1)
    except SimulationError:
        return both(lambda: whole(x0), lambda: whole(x1))  # the whole runs raise the whole runs' message
    return pair.z[0], pair.joined()


class _Pair:
    """The state of the two runs: the first's samples so far, the second's until it joins the first."""

    def __init__(
        self, model: Model, theta: np.ndarray, mass: float, fine: np.ndarray, fs: float, q: int, n: int, chunk: int
    ):
        self.model, self.theta, self.mass, self.fine, self.fs, self.q, self.n = model, theta, mass, fine, fs, q, n
        self.chunk = max(1, chunk)
        self.z = (np.empty(n), np.empty(n))
        self.v = (np.empty(n), np.empty(n))
        self.done = -1  # the first run's samples 0..done are known
        self.join: int | None = None  # the sample from which the second run is the first
        self.failed = False
        self.cond = threading.Condition()

    def _chunk(self, which: int, start: int, stop: int, state: tuple[float, float]) -> tuple[float, float]:
        """Samples ``start..stop`` of run ``which`` (``stop``: the next chunk's start) and the state at ``stop``."""
        from ..simulation import simulate

        q = self.q
        # one sub-step into sample ``stop`` gives the state at its start; the last chunk takes every sub-step (a
        # whole run checks them all for divergence)
        end = self.n * q if stop >= self.n - 1 else stop * q + 1
        z, v, _ = simulate(self.model, self.theta, self.mass, self.fine[start * q : end], self.fs * q, state)
        last = min(stop, self.n - 1)
        self.z[which][start : last + 1] = z[::q][: last + 1 - start]
        self.v[which][start : last + 1] = v[::q][: last + 1 - start]
        return float(self.z[which][last]), float(self.v[which][last])

    def first(self, x0: Sequence[float]) -> None:
        """The first run, chunk by chunk (publishing its progress), the rest at once when the second has joined."""
        try:
            state, start = (float(x0[0]), float(x0[1])), 0
            while start < self.n - 1:
                with self.cond:
                    joined = self.join is not None
                stop = self.n - 1 if joined else min(start + self.chunk, self.n - 1)
                state = self._chunk(0, start, stop, state)
                with self.cond:
                    self.done = stop
                    self.cond.notify_all()
                start = stop
        except BaseException:
            with self.cond:
                self.failed = True
                self.cond.notify_all()
            raise
        with self.cond:
            self.done = self.n - 1
            self.cond.notify_all()

    def second(self, x1: Sequence[float]) -> None:
        """The second run, chunk by chunk, until its state at a chunk's end is the first run's there."""
        state, start = (float(x1[0]), float(x1[1])), 0
        while start < self.n - 1:
            stop = min(start + self.chunk, self.n - 1)
            state = self._chunk(1, start, stop, state)
            with self.cond:
                while self.done < stop and not self.failed:
                    self.cond.wait()
                if self.failed:
                    return
                if _same(state, (self.z[0][stop], self.v[0][stop])):
                    self.join = stop
                    return
            start = stop

    def run(self, x0: Sequence[float], x1: Sequence[float]) -> None:
        """Both runs (at once when the thread budget allows: :func:`nlid.runtime.parallel.both`)."""
        both(lambda: self.first(x0), lambda: self.second(x1))

    def joined(self) -> np.ndarray:
        """The second run's displacement: its own samples before the join, the first run's from there."""
        if self.join is None:
            return self.z[1]
        out = self.z[0].copy()
        out[: self.join] = self.z[1][: self.join]
        return out


def _same(a: tuple[float, float], b: tuple[float, float]) -> bool:
    """The two states are the same floating-point numbers, bit for bit (``-0.0`` is not ``0.0``)."""
    return bool(np.array_equal(np.array(a, dtype=float).view(np.int64), np.array(b, dtype=float).view(np.int64)))
