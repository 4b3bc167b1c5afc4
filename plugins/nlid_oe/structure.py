"""Output-error identification of a structure of several DOFs: fit the free run of every DOF.

The model ``M z'' + C z' + K z + s + sum_e b_e theta_e g_e = f`` is driven by
the measured force from an initial state and simulated by the structure
simulator (:func:`nlid.plugin.structure_free_run_segments`: RK4, ``oversample``
sub-steps per sample, the record's force hold); the displacement of every
DOF, each scaled by its standard deviation, is compared with the measured
one. The unknowns are

* the element coefficients ``theta``,
* the symmetric ``K`` and ``C`` (``n (n + 1) / 2`` entries each),
* the constant force per DOF (when the element set has it),
* the initial state (``z`` and ``v`` of every DOF) of every segment,

starting from another identifier's estimate (option ``init``, default the
preferred installed identifier; it must handle several DOFs). The mass
matrix is held at the given one, or at the start's estimate (reported as
estimated). Each parameter is scaled by its start value (entries that start
at zero by the largest of their matrix; states by the std of their channel).

Multiple shooting
    A lightly damped structure's free run over a long record drifts in phase
    for a frequency error of a fraction of a percent (3dof-cubic: 0.4 % on
    the first mode turns into a 56 % free-run error over 5 s), which leaves
    the optimiser in local minima. The record is therefore cut into
    segments (option ``segment_seconds``; default :data:`SEGMENT_PERIODS`
    periods of the start model's lowest mode, linearised at a stable
    equilibrium or underlying linear; with several stable equilibria, as for
    one DOF, ``SHORT_PERIODS`` periods of its highest mode; ``0``: one
    segment), each simulated
    from its own initial state, with the mismatch between a segment's end
    and the next one's start a soft constraint (option ``continuity_weight``;
    automatic segments whose fit stays above ``NOISE_RATIO`` times the
    measurement noise are halved, at most ``MAX_HALVINGS`` times, as for one
    DOF),
    as for one DOF (:mod:`nlid_oe.problem`, whose reduced problem and solver
    this module reuses). The states start from the data (the displacement,
    the velocity measured or through nlid's differentiating filter) and are
    first fitted with the model held at the start, then jointly with it: a
    state taken from a noisy record is off by the noise, and a fit that keeps
    it bends the coefficients to compensate.

Jacobian
    From the forward sensitivities of the discrete free run
    (:func:`nlid.plugin.structure_segments`: every RK4 stage carries its
    derivatives with respect to the element coefficients, the entries of ``K``
    and ``C``, the static force and the segment's initial state), computed in
    the same run as the residual, the segments in parallel on the threads of
    :func:`nlid.plugin.kernel_threads`. (Forward differences, one free run per
    parameter and state component, made a 30-s record of a 3-DOF chain take
    4.5 minutes; ``benchmarks/bench_mdof_oe.py``.)

Standard errors
    As for one DOF (:mod:`nlid_oe.uncertainty`): the segments' states profiled
    out, batch-means sandwich.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

import numpy as np

from nlid.plugin import (
    ElementSet,
    InputError,
    Record,
    SimulationError,
    StructuralModel,
    StructureEstimate,
    choose_method,
    derivatives,
    identify,
    kernel_threads,
    structure_regression_data,
    structure_segments,
)

from .problem import Parameter, Shooting
from .rules import DENSE_LIMIT, MAX_HALVINGS, NOISE_RATIO, SHORT_PERIODS

if TYPE_CHECKING:
    from .identifier import OutputError

__all__ = ["identify_structure", "StructureProblem", "SEGMENT_PERIODS"]

#: Default segment length, in periods of the start model's lowest mode.
SEGMENT_PERIODS = 5.0
#: Fewest samples in a segment.
MIN_SEGMENT = 16


class StructureProblem(Shooting):
    """The multiple-shooting free-run residual of a structure (:class:`~nlid_oe.problem.Shooting`).

    Parameters
    ----------
    record
        The data (``z`` of every DOF is the output).
    elements
        The elements.
    start
        The start model (its ``M`` is held; its other parameters are the globals' start).
    states
        The state ``(z, v)`` at every sample, shape ``(N, 2 n)``; each segment's state starts from it.
    starts
        First sample of each segment.
    oversample
        RK4 sub-steps per sample.
    continuity_weight
        Multiplies the continuity rows (as :class:`~nlid_oe.problem.Problem`).
    """

    def __init__(
        self,
        record: Record,
        elements: ElementSet,
        start: StructuralModel,
        states: np.ndarray,
        starts: np.ndarray,
        oversample: int,
        continuity_weight: float,
    ) -> None:
        n = record.n_dofs
        self.record, self.elements, self.M, self.n, self.q = record, elements, start.M, n, int(oversample)
        self.upper = [(i, j) for i in range(n) for j in range(i, n)]
        self.static = elements.static
        K = np.array([start.K[i, j] for i, j in self.upper])
        C = np.array([start.C[i, j] for i, j in self.upper])
        parts = [start.theta, K, C, *([start.static] if self.static else [])]
        self.p0 = np.concatenate(parts)
        force = float(np.sqrt(np.mean(record.f**2))) or 1.0

        def scale(x: np.ndarray, fallback: float) -> np.ndarray:
            big = float(np.max(np.abs(x))) if x.size else 0.0
            if big == 0.0:
                return np.full(len(x), fallback)
            return np.where(np.abs(x) > 1e-9 * big, np.abs(x), 1e-2 * big)

        fallbacks = [1.0, 1.0, 1.0, 1e-2 * force]  # a static force that starts at zero moves by 1 % of the force
        gscale = np.concatenate([scale(x, fb) for x, fb in zip(parts, fallbacks, strict=False)])
        self.bounds_p = np.cumsum([0, *[len(x) for x in parts]])
        labels = [f"K[{i + 1},{j + 1}]" for i, j in self.upper] + [f"C[{i + 1},{j + 1}]" for i, j in self.upper]
        names = [*elements.names, *labels, *([f"static[{i + 1}]" for i in range(n)] if self.static else [])]
        self.params = [Parameter("theta" if k < len(start.theta) else "linear", name=x) for k, x in enumerate(names)]
        self.G = self.p0.size
        self.L, self.C = 2 * n, n
        self.starts = np.asarray(starts, dtype=np.int64)
        self.K = self.starts.size
        self.edges = np.append(self.starts, record.n)
        self.channel_scale = record.z.std(axis=0)
        self.channel_scale[self.channel_scale == 0] = 1.0
        self.state_scales = np.concatenate([self.channel_scale, np.maximum(states[:, n:].std(axis=0), 1e-300)])
        self.scale = np.concatenate([gscale, np.tile(self.state_scales, self.K)])
        self.state0 = np.asarray(states, dtype=float)[self.starts]
        lengths = np.diff(self.edges)
        self.weight = float(continuity_weight) * np.sqrt(float(np.mean(lengths)) * self.C) if self.K > 1 else 0.0
        self.rows_data = record.n * self.C
        self.rows = self.rows_data + (self.K - 1) * self.L
        self.dense_limit = 0
        self.diverged = False
        self._reduced = None
        self._cache: tuple[np.ndarray, np.ndarray, object] | None = None

    def start(self) -> np.ndarray:
        """The scaled start vector ``u``."""
        return np.concatenate([self.p0, self.state0.ravel()]) / self.scale

    def bounds(self, u0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """No bounds."""
        return np.full(u0.size, -np.inf), np.full(u0.size, np.inf)

    def globals_of(self, u: np.ndarray) -> np.ndarray:
        """The global parameters at ``u`` (physical units)."""
        return np.asarray(u[: self.G]) * self.scale[: self.G]

    def states_of(self, u: np.ndarray) -> np.ndarray:
        """Each segment's initial state ``(z, v)`` at ``u``, shape ``(K, 2 n)``."""
        return (np.asarray(u[self.G :]) * self.scale[self.G :]).reshape(self.K, self.L)

    def unpack(self, u: np.ndarray) -> StructuralModel:
        """The model at ``u``."""
        p, b = self.globals_of(u), self.bounds_p
        K, C = np.zeros((self.n, self.n)), np.zeros((self.n, self.n))
        for (i, j), kv, cv in zip(self.upper, p[b[1] : b[2]], p[b[2] : b[3]], strict=True):
            K[i, j] = K[j, i] = kv
            C[i, j] = C[j, i] = cv
        static = p[b[3] : b[4]] if self.static else None
        return StructuralModel(self.M, C, K, self.elements, p[b[0] : b[1]], static)

    def run(self, u: np.ndarray):
        """The free runs of the segments at ``u`` with their sensitivities (:func:`nlid.plugin.structure_segments`)."""
        try:
            return structure_segments(
                self.unpack(u), self.record.f, self.record.fs, self.starts, self.states_of(u),
                force_hold=self.record.force_hold, oversample=self.q,
            )  # fmt: skip
        except InputError as exc:  # a non-finite state
            raise SimulationError(str(exc)) from None

    def simulate(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The free-run displacements ``(N, n)`` segment by segment, and each segment's end state ``(K, 2 n)``."""
        run = self._evaluate(u)[1]
        return run.z, run.end_state

    def _rows(self, z: np.ndarray, ends: np.ndarray, u: np.ndarray) -> np.ndarray:
        r = np.empty(self.rows)
        r[: self.rows_data] = ((z - self.record.z) / self.channel_scale).ravel()
        if self.K > 1:
            defect = (ends[:-1] - self.states_of(u)[1:]) / self.state_scales
            r[self.rows_data :] = self.weight * defect.ravel()
        return r

    def _evaluate(self, u: np.ndarray) -> tuple[np.ndarray, object]:
        if self._cache is None or not np.array_equal(self._cache[0], u):
            run = self.run(u)
            self._cache = (np.array(u, copy=True), self._rows(run.z, run.end_state, u), run)
        return self._cache[1], self._cache[2]

    def blocks(self, u: np.ndarray):
        """The Jacobian's blocks (:meth:`Shooting.blocks`) from the run's sensitivities (module docstring)."""
        run = self._evaluate(u)[1]
        G, L, K, n = self.G, self.L, self.K, self.n
        E, P = len(self.elements), len(self.upper)
        gcols = np.r_[0 : E + 2 * P, (E + 2 * P + np.arange(n)) if self.static else np.arange(0)].astype(int)
        lcols = E + 2 * P + n + np.arange(L)
        gscale, lscale = self.scale[:G], self.scale[G : G + L]
        S = run.sensitivities  # (N, n, ncol)
        inv = 1.0 / self.channel_scale
        Jg = (S[:, :, gcols] * (inv[:, None] * gscale[None, :])[None]).reshape(-1, G)
        Jl = (S[:, :, lcols] * (inv[:, None] * lscale[None, :])[None]).reshape(-1, L)
        if K == 1:
            return Jg, Jl, None
        wsc = self.weight / self.state_scales
        ends = run.end_sensitivities[:-1]  # (K - 1, L, ncol)
        dg = ends[:, :, gcols] * gscale[None, None, :] * wsc[None, :, None]
        dl = ends[:, :, lcols] * lscale[None, None, :] * wsc[None, :, None]
        nxt = np.broadcast_to(-self.weight * np.eye(L), (K - 1, L, L)).copy()
        return Jg, Jl, (dg, dl, nxt)

    def error_percent(self, u: np.ndarray) -> list[float]:
        """Free-run error per DOF: ``100 RMS(z_sim - z) / RMS(z)``."""
        r = self.residual(u)[: self.rows_data].reshape(-1, self.n) * self.channel_scale
        rms = np.sqrt(np.mean(self.record.z**2, axis=0))
        return (100 * np.sqrt(np.mean(r**2, axis=0)) / np.where(rms > 0, rms, 1.0)).tolist()


def _starts(n: int, length: int) -> np.ndarray:
    starts = list(range(0, n, max(int(length), MIN_SEGMENT)))
    if len(starts) > 1 and n - starts[-1] < MIN_SEGMENT:
        starts.pop()  # a short tail joins the last segment
    return np.asarray(starts)


def identify_structure(
    identifier: OutputError, record: Record, elements: ElementSet, mass: np.ndarray | None
) -> StructureEstimate:
    """oe on a structure record (module docstring)."""
    from .uncertainty import standard_errors

    clock = time.perf_counter()
    settings, name = identifier.settings, identifier.name
    if settings["outputs"] != "z":
        raise InputError("oe: a structure's free run is fitted on the displacements of every DOF (outputs='z')")
    method = settings["init"]
    if method is None:
        method, _ = choose_method(mass)
    if method == name:
        raise InputError("oe: option 'init' must name another identifier (oe starts from its estimate)")
    start = identify(record, elements, method, mass="estimate" if mass is None else mass)  # not the record's
    structure = start.structure
    # the segments' initial states start from the balance's displacement and velocity (filtered when estimated)
    data = structure_regression_data(record, start.elements, cutoff=None, trim=False)
    states = np.column_stack([data.z, data.v])
    seconds = settings["segment_seconds"]
    if seconds is None:
        found = [float(f) for m in (*start.modes, start.linear_modes) for f in m.fn_hz if f > 0]
        wells = len(start.equilibria.stable) if start.equilibria is not None else 1
        if wells > 1:  # as for one DOF: a free run over wells it may cross differently has local minima
            seconds = SHORT_PERIODS / max(found) if found else 0.0
        else:
            seconds = SEGMENT_PERIODS / min(found) if found else 0.0
    starts = _starts(record.n, record.n if seconds == 0 else int(round(seconds * record.fs)))

    def problem(model: StructuralModel, starts: np.ndarray) -> StructureProblem:
        out = StructureProblem(
            record, start.elements, model, states, starts, settings["oversample"], settings["continuity_weight"]
        )
        out.dense_limit = DENSE_LIMIT if identifier._solver(out) == "exact" else 0
        return out

    def miss(problem: StructureProblem, u: np.ndarray) -> float:
        return float(np.sqrt(np.mean(problem.residual(u)[: problem.rows_data] ** 2)))

    # the measurement noise per DOF relative to its std: automatic segments that leave the fit above it have
    # states stuck on a wrong trajectory (a wrong well): halved, from the data's states, as for one DOF
    floor = float(
        np.sqrt(np.mean([(derivatives.noise_sd(z, record.fs) / max(z.std(), 1e-300)) ** 2 for z in record.z.T]))
    )
    with kernel_threads() as threads:  # BLAS on one thread between the free runs
        joint = problem(structure, starts)
        before = joint.error_percent(joint.start())
        res = identifier._solve(joint, method)
        for _ in range(MAX_HALVINGS if settings["segment_seconds"] is None and joint.K > 1 else 0):
            length = int(np.diff(joint.edges).min()) // 2
            if miss(joint, res.x) <= NOISE_RATIO * floor or length < MIN_SEGMENT:
                break
            halved = problem(joint.unpack(res.x), _starts(record.n, length))
            res_h = identifier._solve(halved, method)
            if miss(halved, res_h.x) >= miss(joint, res.x):
                break
            joint, res = halved, res_h
        residual = joint.residual(res.x)
        se_u, _, corr, _ = standard_errors(joint, residual, res.x)
    model = joint.unpack(res.x)
    b = joint.bounds_p
    se = se_u[b[0] : b[1]] * joint.scale[b[0] : b[1]]
    after = joint.error_percent(res.x)
    warnings = []
    if sum(after) > sum(before):
        warnings.append("oe: the free-run error did not decrease from the start; the start's estimate may be better")
    return StructureEstimate(
        coefficients=elements.as_dict(model.theta),
        K=model.K,
        C=model.C,
        static=model.static if elements.static else None,
        M=None if mass is not None else structure.M,
        standard_errors=elements.as_dict(se),
        warnings=warnings,
        diagnostics={
            "init": method,
            "init_coefficients": dict(structure.coefficients),
            "free_run_error_percent_start": before,
            "free_run_error_percent": after,
            "continuity_defect_max": float(np.max(np.abs(residual[joint.rows_data :])) / joint.weight)
            if joint.K > 1
            else 0.0,
            "segments": int(joint.K),
            "segment_seconds": float(np.mean(np.diff(joint.edges))) / record.fs,
            "nfev": int(res.nfev),
            "njev": int(res.njev or 0),
            "optimizer_message": str(res.message),
            "correlation_length_samples": corr,
            "mass": "given" if mass is not None else f"held at the start's ({method}) estimate",
            "threads": threads,
            "jacobian": "forward sensitivities",
            "seconds_fit": time.perf_counter() - clock,
        },
    )
