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
* the initial displacements and velocities,

starting from another identifier's estimate (option ``init``, default the
preferred installed identifier; it must handle several DOFs). The mass
matrix is held at the given one, or at the start's estimate (reported as
estimated). Each parameter is scaled by its start value (entries that start
at zero by the largest of their matrix), so the optimiser's steps are
relative.

One free run covers the whole record (no multiple shooting: the structures
this is meant for are not chaotic; a start far from the truth on a record
crossing between wells may converge to a local minimum - the start's
equation-error estimate is usually close enough). Standard errors are
``s^2 (J^T J)^-1`` at the optimum with the initial state profiled in (the
residual's correlation is ignored, so they are optimistic).
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
    derivatives,
    identify,
    structure_free_run,
)

__all__ = ["identify_structure", "StructureProblem"]


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
        Start values of the initial state.
    oversample
        RK4 sub-steps per sample.
    """

    def __init__(
        self,
        record: StructureRecord,
        elements: ElementSet,
        start: StructuralModel,
        z0: np.ndarray,
        v0: np.ndarray,
        oversample: int,
    ) -> None:
        n = record.n_dofs
        self.record, self.elements, self.M, self.n, self.q = record, elements, start.M, n, int(oversample)
        self.upper = [(i, j) for i in range(n) for j in range(i, n)]
        self.static = elements.static
        theta = start.theta
        K = np.array([start.K[i, j] for i, j in self.upper])
        C = np.array([start.C[i, j] for i, j in self.upper])
        parts = [theta, K, C, *([start.static] if self.static else []), z0, v0]
        self.p0 = np.concatenate(parts)

        def scale(x: np.ndarray) -> np.ndarray:
            big = float(np.max(np.abs(x))) if x.size else 1.0
            return np.where(np.abs(x) > 1e-9 * big, np.abs(x), max(big, 1e-12) * 1e-2)

        self.scale = np.concatenate([scale(x) for x in parts])
        sizes = [len(x) for x in parts]
        self.bounds = np.cumsum([0, *sizes])
        self.zstd = record.z.std(axis=0)
        self.zstd[self.zstd == 0] = 1.0
        self.force = record.f
        self.hold = record.force_hold

    def unpack(self, u: np.ndarray) -> tuple[StructuralModel, np.ndarray, np.ndarray]:
        """Scaled parameters to ``(model, z0, v0)``."""
        p = self.p0 + u * self.scale
        b = self.bounds
        theta = p[b[0] : b[1]]
        K, C = np.zeros((self.n, self.n)), np.zeros((self.n, self.n))
        for (i, j), kv, cv in zip(self.upper, p[b[1] : b[2]], p[b[2] : b[3]], strict=True):
            K[i, j] = K[j, i] = kv
            C[i, j] = C[j, i] = cv
        k = 3
        static = None
        if self.static:
            static, k = p[b[3] : b[4]], 4
        z0, v0 = p[b[k] : b[k + 1]], p[b[k + 1] : b[k + 2]]
        model = StructuralModel(self.M, C, K, self.elements, theta, static)
        return model, z0, v0

    def simulate(self, u: np.ndarray) -> np.ndarray:
        """The free-run displacements ``(N, n)``."""
        model, z0, v0 = self.unpack(u)
        z, _, _ = structure_free_run(
            model, self.force, self.record.fs, force_hold=self.hold, x0=(z0, v0), oversample=self.q
        )
        return z

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
    v = (
        record.v
        if record.v is not None
        else np.column_stack(
            [derivatives.differentiate(record.z[:, k], record.fs, order=1)[0] for k in range(record.n_dofs)]
        )
    )
    problem = StructureProblem(record, start.elements, structure, record.z[0], v[0], settings["oversample"])
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
    model, z0, v0 = problem.unpack(sol.x)
    J = sol.jac
    dof = max(sol.fun.size - sol.x.size, 1)
    s2 = float(sol.fun @ sol.fun) / dof
    try:
        cov = s2 * np.linalg.inv(J.T @ J)
    except np.linalg.LinAlgError:
        raise IdentificationError("oe: the Gauss-Newton Hessian of the free-run fit is singular") from None
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
            "initial_state": {"z": z0.tolist(), "v": v0.tolist()},
            "nfev": int(sol.nfev),
            "optimizer_status": int(sol.status),
            "optimizer_message": str(sol.message),
            "mass": "given" if mass is not None else f"held at the start's ({method}) estimate",
            "seconds_fit": time.perf_counter() - clock,
        },
    )
