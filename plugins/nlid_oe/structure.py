"""Output-error identification of a structure of several DOFs: fit the free run of every DOF.

The model ``M z'' + C z' + K z + s + sum_e b_e theta_e g_e = f`` is driven by
the measured force from an initial state and simulated by the structure
simulator (:func:`nlid.plugin.structure_free_run`: RK4, ``oversample``
sub-steps per sample, the record's force hold); the displacement of every
DOF, each scaled by its standard deviation, is compared with the measured
one, and :func:`scipy.optimize.least_squares` (trust-region reflective,
finite-difference Jacobian) minimises the sum of squares over

* the element coefficients ``theta``,
* the symmetric ``K`` and ``C`` (``n (n + 1) / 2`` entries each),
* the constant force per DOF (when the element set has it),

starting from another identifier's estimate (option ``init``, default the
preferred installed identifier; it must handle several DOFs). The mass
matrix is held at the given one, or at the start's estimate (reported as
estimated). Each parameter is scaled by its start value (entries that start
at zero by the largest of their matrix), so the optimiser's steps are
relative.

Segments
    A lightly damped structure's free run over a long record drifts in phase
    for a frequency error of a fraction of a percent (3dof-cubic: 0.4 % on
    the first mode turns into a 56 % free-run error over 5 s), which leaves
    the optimiser in local minima. The record is therefore cut into
    segments (option ``segment_seconds``; default :data:`SEGMENT_PERIODS`
    periods of the start model's lowest mode (linearised at a stable equilibrium or underlying linear), ``0``: one
    segment), each simulated from the state the data give at its start (the
    measured displacement, the velocity measured or through nlid's
    differentiating filter). The initial states are not fitted.

Standard errors are ``s^2 (J^T J)^-1`` at the optimum (the residual's
correlation is ignored, so they are optimistic).
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from typing import Any

import numpy as np

from nlid.plugin import (
    ElementSet,
    IdentificationError,
    InputError,
    SimulationError,
    StructuralModel,
    StructureEstimate,
    StructureRecord,
    choose_method,
    identify,
    structure_free_run,
    structure_regression_data,
)

__all__ = ["identify_structure", "StructureProblem", "SEGMENT_PERIODS"]

#: Default segment length, in periods of the start model's lowest mode.
SEGMENT_PERIODS = 5.0


class StructureProblem:
    """The free-run residual of a structure as a function of scaled parameters.

    Parameters
    ----------
    record
        The data (``z`` of every DOF is the output).
    elements
        The elements.
    start
        The start model (its ``M`` is held).
    z0, v0
        The state at every sample ``(N, n)`` each (from the data); segments start from it.
    oversample
        RK4 sub-steps per sample.
    length
        Samples per segment.
    """

    def __init__(
        self,
        record: StructureRecord,
        elements: ElementSet,
        start: StructuralModel,
        z0: np.ndarray,
        v0: np.ndarray,
        oversample: int,
        length: int,
    ) -> None:
        n = record.n_dofs
        self.record, self.elements, self.M, self.n, self.q = record, elements, start.M, n, int(oversample)
        self.upper = [(i, j) for i in range(n) for j in range(i, n)]
        self.static = elements.static
        theta = start.theta
        K = np.array([start.K[i, j] for i, j in self.upper])
        C = np.array([start.C[i, j] for i, j in self.upper])
        parts = [theta, K, C, *([start.static] if self.static else [])]
        self.p0 = np.concatenate(parts)

        force = float(np.sqrt(np.mean(record.f**2))) or 1.0

        def scale(x: np.ndarray, fallback: float) -> np.ndarray:
            big = float(np.max(np.abs(x))) if x.size else 0.0
            if big == 0.0:
                return np.full(len(x), fallback)
            return np.where(np.abs(x) > 1e-9 * big, np.abs(x), 1e-2 * big)

        fallbacks = [1.0, 1.0, 1.0, 1e-2 * force]  # a static force that starts at zero moves by 1 % of the force
        self.scale = np.concatenate([scale(x, fb) for x, fb in zip(parts, fallbacks, strict=False)])
        sizes = [len(x) for x in parts]
        self.bounds = np.cumsum([0, *sizes])
        self.zstd = record.z.std(axis=0)
        self.zstd[self.zstd == 0] = 1.0
        self.force = record.f
        self.hold = record.force_hold
        starts = list(range(0, record.n, max(int(length), 16)))
        if len(starts) > 1 and record.n - starts[-1] < 16:
            starts.pop()
        self.segments = [(a, b) for a, b in zip(starts, [*starts[1:], record.n], strict=True)]
        self.states = [(z0[a], v0[a]) for a, _ in self.segments]

    def unpack(self, u: np.ndarray) -> StructuralModel:
        """Scaled parameters to the model."""
        p = self.p0 + u * self.scale
        b = self.bounds
        theta = p[b[0] : b[1]]
        K, C = np.zeros((self.n, self.n)), np.zeros((self.n, self.n))
        for (i, j), kv, cv in zip(self.upper, p[b[1] : b[2]], p[b[2] : b[3]], strict=True):
            K[i, j] = K[j, i] = kv
            C[i, j] = C[j, i] = cv
        static = p[b[3] : b[4]] if self.static else None
        return StructuralModel(self.M, C, K, self.elements, theta, static)

    def simulate(self, u: np.ndarray) -> np.ndarray:
        """The free-run displacements ``(N, n)``, segment by segment."""
        model = self.unpack(u)
        out = np.empty_like(self.record.z)
        for (a, b), x0 in zip(self.segments, self.states, strict=True):
            z, _, _ = structure_free_run(
                model, self.force[a:b], self.record.fs, force_hold=self.hold, x0=x0, oversample=self.q
            )
            out[a:b] = z
        return out

    def residual(self, u: np.ndarray) -> np.ndarray:
        """``(z_sim - z) / std(z)`` per DOF, flattened; large where the simulation diverges."""
        try:
            z = self.simulate(u)
        except (SimulationError, InputError):
            return np.full(self.record.z.size, 1e3)
        return ((z - self.record.z) / self.zstd).ravel()

    def error_percent(self, u: np.ndarray) -> list[float]:
        """Free-run error per DOF: ``100 RMS(z_sim - z) / RMS(z)``."""
        r = self.residual(u).reshape(-1, self.n) * self.zstd
        rms = np.sqrt(np.mean(self.record.z**2, axis=0))
        return (100 * np.sqrt(np.mean(r**2, axis=0)) / np.where(rms > 0, rms, 1.0)).tolist()


def identify_structure(
    record: StructureRecord, elements: ElementSet, mass: np.ndarray | None, settings: Mapping[str, Any], name: str
) -> StructureEstimate:
    """oe on a structure record (module docstring)."""
    from scipy import optimize

    clock = time.perf_counter()
    if settings["outputs"] != "z":
        raise InputError("oe: a structure's free run is fitted on the displacements of every DOF (outputs='z')")
    method = settings["init"]
    if method is None:
        method, _ = choose_method(mass)
    if method == name:
        raise InputError("oe: option 'init' must name another identifier (oe starts from its estimate)")
    start = identify(record, elements, method, mass=mass)
    structure = start.structure
    # the segments' initial states: the balance's displacement and velocity (filtered when estimated)
    data = structure_regression_data(record, start.elements, cutoff=None, trim=False)
    seconds = settings["segment_seconds"]
    if seconds is None:
        found = [float(f) for m in (*start.modes, start.linear_modes) for f in m.fn_hz if f > 0]
        lowest = min(found, default=0.0)
        seconds = SEGMENT_PERIODS / lowest if lowest > 0 else 0.0
    length = record.n if seconds == 0 else int(round(seconds * record.fs))
    problem = StructureProblem(record, start.elements, structure, data.z, data.v, settings["oversample"], length)
    u0 = np.zeros(problem.p0.size)
    r0 = problem.residual(u0)
    if not np.all(r0 < 1e3):
        raise IdentificationError(f"oe: the start model ({method}) diverges in a free run of the record")
    tol = settings["tol"]
    sol = optimize.least_squares(
        problem.residual,
        u0,
        method="trf",
        x_scale=1.0,
        diff_step=1e-6,
        max_nfev=settings["max_nfev"],
        ftol=tol,
        xtol=tol,
        gtol=tol,
    )
    model = problem.unpack(sol.x)
    J = sol.jac
    dof = max(sol.fun.size - sol.x.size, 1)
    s2 = float(sol.fun @ sol.fun) / dof
    cov = s2 * np.linalg.pinv(J.T @ J)
    b = problem.bounds
    se = np.sqrt(np.clip(np.diag(cov)[b[0] : b[1]], 0.0, None)) * problem.scale[b[0] : b[1]]
    before, after = problem.error_percent(u0), problem.error_percent(sol.x)
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
            "segments": len(problem.segments),
            "segment_seconds": (problem.segments[0][1] - problem.segments[0][0]) / record.fs,
            "nfev": int(sol.nfev),
            "optimizer_status": int(sol.status),
            "optimizer_message": str(sol.message),
            "mass": "given" if mass is not None else f"held at the start's ({method}) estimate",
            "seconds_fit": time.perf_counter() - clock,
        },
    )
