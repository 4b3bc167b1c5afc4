"""What remains in a structure's residual: flexible functions of each connection, and what no connection carries.

The "What remains" of :func:`nlid.discovery.structure.discover_structure` (its step 6): on the current model,
flexible functions of each connection's relative displacement (Legendre polynomials of degree 2-8), velocity
(degree 2-7 and its sign) and history (play operators) are fitted the same cross-fitted way as the
candidates; one that explains :data:`~nlid.discovery.probes.MIN_STRUCTURE` or more of the held-out residual
of its DOFs counts as remaining structure. Two probes of each DOF find what no connection carries
(:data:`~nlid.discovery.structure_result.DOF_PROBES`): its acceleration (a mass matrix wrong on that DOF) and
the force's neighbouring samples (a force acting delayed, early or filtered); a third, polynomials of time
fitted within each part (:func:`nlid.discovery.probes.time_gain`), finds a drift. All are counted beyond what they
find on the current model simulated at the record's noise (:func:`probe_null`), where nothing is missing; so
are the connections' probes.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import NlidError
from ..estimation.joint import Extra
from .probes import PLAY_WIDTHS, TIME_DEGREE, _legendre, time_gain
from .structure_fit import Part, Search, connection_columns, connectivity, fraction, relative
from .structure_result import DOF_PROBES, ConnectionProbe, StructureRemaining

__all__ = ["STRUCTURE_PROBES", "FORCE_LAGS", "NULL_SEED", "mass_corrections", "probe_null", "remaining_structure"]

#: Remaining-structure probes on each connection, in report order.
STRUCTURE_PROBES = ("z", "v", "memory")
#: Samples before and after each force sample that the ``"force"`` probe offers (a delay of a few samples).
FORCE_LAGS = 4


def _probe_columns(probe: str, x: np.ndarray, xd: np.ndarray, scale: tuple[float, float, float]) -> np.ndarray:
    mid, half, vhalf = scale
    if probe == "z":
        return _legendre(np.clip((x - mid) / half, -1, 1), range(2, 9))
    if probe == "v":
        return np.column_stack([_legendre(np.clip(xd / vhalf, -1, 1), range(2, 8)), np.sign(xd)])
    from ..model.terms.memory_kernels import play_loop

    std = max(half / 2.0, 1e-300)
    cols = []
    for width in PLAY_WIDTHS:
        out = np.empty_like(x)
        play_loop(np.ascontiguousarray(x), float(width * std), out)
        cols.append(out / std)
    return np.column_stack(cols)


def remaining_structure(search: Search, conns, threshold: float) -> StructureRemaining:
    """Flexible functions of each connection's coordinate, and the DOF probes, cross-fitted on the current model's
    residual and counted beyond what they find on the model simulated at the record's noise (:func:`probe_null`)."""
    base = search.cross_scores(None)
    linear = _linear(search, base["fit_estimation"])
    found = _fractions(search, conns, base, linear)
    null = probe_null(search, conns)
    dm = mass_corrections(search, linear)
    out = []
    for (c, probe), (a, b, columns) in found.items():
        a0, b0 = (max(x, 0.0) for x in null.get((c, probe), (0.0, 0.0))[:2])
        a, b = a - a0, b - b0
        mass = {}
        if probe == "acceleration" and dm is not None:
            mass = {"mass_change": float(dm[c[0] - 1]), "given_mass": float(search.M[c[0] - 1, c[0] - 1])}
        out.append(ConnectionProbe(c, probe, 0.5 * (a + b), a, b, columns, 0.5 * (a0 + b0), **mass))
    return StructureRemaining(tuple(out), float(threshold), null=bool(null))


def mass_corrections(search: Search, linear: dict[str, np.ndarray | None]) -> np.ndarray | None:
    """The correction ``dm_k`` of each DOF's mass the data ask for, fitted together with the model (the
    acceleration probe's columns on all DOFs at once, ``linear``: :func:`_linear`); the mean of the two parts'
    fits (kg); ``None`` when the linear system's response to the force is not finite.

    Its sign is what to read: on the 3-DOF chain (1 % noise) the masses given x1.5, x1.1 and x0.5 gave DOF 1
    1.085, 1.033 and 0.641 kg against the true 1 kg. The corrected value lies between the given and the true one,
    because the response the probe's columns are built from is that of the system with the given masses, and
    the stiffnesses take up part of the error.
    """
    n = search.n
    lin_e, lin_h = linear["estimation"], linear["holdout"]
    if lin_e is None or lin_h is None:
        return None
    extras = [Extra(lin_e[:, k : k + 1], connectivity((k + 1, 0), n)) for k in range(n)]
    cols = {
        "extras": extras,
        "estimation": [x.columns for x in extras],
        "holdout": [lin_h[:, k : k + 1] for k in range(n)],
    }
    scored = search.cross_scores(cols)
    dm = 0.5 * (np.asarray(scored["fit_estimation"].extra) + np.asarray(scored["fit_holdout"].extra))
    return dm


def _linear(search: Search, fit: Any) -> dict[str, np.ndarray | None]:
    """Each part's accelerations as the linear system of ``fit`` (the estimation part's) gives them its force."""
    return {name: _linear_acceleration(p.data, fit.K, fit.C, search.M) for name, p in search.parts.items()}


def _fractions(
    search: Search, conns, base: dict[str, Any], linear: dict[str, np.ndarray | None]
) -> dict[tuple[Any, str], tuple[float, float, int]]:
    """Each probe's cross-fitted fractions (held-out, estimation) of its DOFs' residual, and its columns, keyed by
    (connection, probe); the DOF probes on ``(k, 0)``. ``base``: the search's :meth:`~Search.cross_scores` without
    a probe; ``linear``: :func:`_linear` of its estimation fit."""
    n, w = search.n, search.weights
    est, ho = search.parts["estimation"], search.parts["holdout"]
    out = {}

    def score(key, col_e, col_h, touched):
        extra = Extra(col_e, connectivity(key[0], n))
        scored = search.cross_scores({"extras": [extra], "estimation": [col_e], "holdout": [col_h]})
        a = fraction(scored["on_holdout"], base["on_holdout"], w, touched)
        b = fraction(scored["on_estimation"], base["on_estimation"], w, touched)
        out[key] = (float(a), float(b), col_e.shape[1])

    for c in conns:
        touched = [c[0] - 1] + ([c[1] - 1] if c[1] else [])
        x_e, xd_e = relative(est.data, c)
        scale = (0.5 * (x_e.max() + x_e.min()), max(0.5 * np.ptp(x_e), 1e-300), max(float(np.abs(xd_e).max()), 1e-300))
        for probe in STRUCTURE_PROBES:
            columns = lambda x, xd, probe=probe, scale=scale: _probe_columns(probe, x, xd, scale)  # noqa: E731
            col_e, col_h = connection_columns(est.data, c, columns), connection_columns(ho.data, c, columns)
            score((c, probe), col_e, col_h, touched)
    fit = base["fit_estimation"]  # what no connection carries: the mass given and the force's path, DOF by DOF
    for k in range(1, n + 1):
        for probe in DOF_PROBES:
            if probe == "time":  # a drift: within each part, its residual under the other part's fit
                a = time_gain(search.residual(ho, fit, k - 1))
                b = time_gain(search.residual(est, base["fit_holdout"], k - 1))
                out[((k, 0), probe)] = (float(a), float(b), TIME_DEGREE)
                continue
            col_e = _dof_columns(probe, est.data, k, linear["estimation"])
            col_h = _dof_columns(probe, ho.data, k, linear["holdout"])
            if col_e is not None and col_h is not None:
                score(((k, 0), probe), col_e, col_h, [k - 1])
    return out


#: Frequencies per batch of the linear system's solves (:func:`_linear_acceleration`).
SOLVE_CHUNK = 4096
#: Seed of the noise the probes' null record is given (:func:`probe_null`): the same null on every run.
NULL_SEED = 20261128


def probe_null(search: Search, conns) -> dict[tuple[Any, str], tuple[float, float, int]]:
    """What the probes find where nothing is missing: the current model simulated at the record's noise.

    The current model, fitted on the selection record, is run under each part's recorded force from the part's
    first measured state; its displacements get white noise of the standard deviation their own noise floor
    shows (:func:`nlid.signal.noisefloor.noise_sd`; velocities and accelerations are measured exactly where the
    record measures them, estimated where it estimates them), and the probes run on that record exactly as on the
    measured one. Its mass is right, its force acts as recorded and it lacks no element, so what the probes find
    there is what noise in the displacements makes of them: stiffnesses fitted from noisy displacements are
    biased (the more, the more alike the DOFs move), and any column that follows the true motion (the force's
    samples, the linear system's acceleration, a play operator) takes some of that bias up. On the 5-mode beam
    with 2-5 % noise on z the force's samples found 6-12 % of the forced DOF's residual with nothing missing, and
    the history on 4-5 5-6 %. Only displacement noise is simulated: noise in measured velocities and
    accelerations would only dilute the null, and the noise floor of a forced DOF's acceleration is not
    readable (12 times too high on the beam). Empty (no null) when a part has no record or the model's run
    diverges.
    """
    from dataclasses import replace

    from ..estimation.structure_regression import structure_regression_data
    from ..signal.noisefloor import noise_sd
    from .structure_accept import run_from_start, with_velocity

    if search.elements is None or any(p.record is None for p in search.parts.values()):
        return {}
    model = search.model()
    rng = np.random.default_rng(NULL_SEED)
    parts = {}
    for name, part in search.parts.items():
        run = run_from_start(model, with_velocity(part.record))
        if run is None:
            return {}
        z, v, a = run
        given = part.record
        sd = np.asarray([noise_sd(np.asarray(given.z[:, k], dtype=float), given.fs) for k in range(search.n)])
        channels = {
            "z": z + rng.standard_normal(z.shape) * sd,
            "v": None if given.v is None else v,
            "a": None if given.a is None else a,
        }
        try:
            simulated = replace(given, **channels)
            parts[name] = Part(structure_regression_data(simulated, search.elements, cutoff=search.cutoff))
        except NlidError:
            return {}
    null = Search(parts, search.M, search.rule, search.n, cutoff=search.cutoff)
    null.weights = search.weights
    null.equations(search.elements)
    base = null.cross_scores(None)
    return _fractions(null, conns, base, _linear(null, base["fit_estimation"]))


def _linear_acceleration(data, K: np.ndarray, C: np.ndarray, M: np.ndarray) -> np.ndarray | None:
    """The accelerations the fitted linear system gives the part's force (``(N, n)``; ``None``: not finite).

    ``A(w) = -w^2 (K + i w C - w^2 M)^-1 F(w)``, the force zero-padded to twice its length. An instrument for the
    acceleration probe: it follows the true accelerations wherever the linear part of the model does, and holds
    none of the displacement's noise, which the estimated acceleration and the residual share (on the 5-mode
    beam with 2 % noise on z that shared noise made the estimated acceleration "predict" 42-64 % of a complete
    model's residual).
    """
    f = np.asarray(data.f, dtype=float)
    N, n = f.shape
    size = 2 * N
    w = 2 * np.pi * np.fft.rfftfreq(size, 1.0 / float(data.fs))
    A = np.fft.rfft(f, n=size, axis=0)
    for lo in range(0, w.size, SOLVE_CHUNK):  # (chunk, n, n) at a time: no n^2 N array
        wc = w[lo : lo + SOLVE_CHUNK, None, None]
        Z = K[None, :, :] + 1j * wc * C[None, :, :] - wc**2 * M[None, :, :]
        try:
            A[lo : lo + SOLVE_CHUNK] = (
                -(wc[:, :, 0] ** 2) * np.linalg.solve(Z, A[lo : lo + SOLVE_CHUNK, :, None])[:, :, 0]
            )
        except np.linalg.LinAlgError:
            return None
    a = np.fft.irfft(A, n=size, axis=0)[:N]
    return a if np.all(np.isfinite(a)) else None


def _dof_columns(probe: str, data, k: int, linear: np.ndarray | None = None) -> np.ndarray | None:
    """The columns of a DOF probe on DOF ``k`` (``None``: the probe says nothing there).

    ``"acceleration"``: the DOF's acceleration as the fitted linear system gives it the force
    (:func:`_linear_acceleration`; a mass matrix wrong on that DOF leaves ``dm a_k`` in its balance);
    ``"force"``: the force on the DOF :data:`FORCE_LAGS` samples before and after (a force that acts delayed,
    early or filtered leaves a combination of them). Both in the equation band, as the balance's own channels.
    """
    if probe == "acceleration":
        return None if linear is None else linear[:, k - 1 : k]
    f = np.asarray(data.f[:, k - 1], dtype=float)
    if not np.any(f):
        return None  # no force on this DOF
    cols = np.zeros((f.size, 2 * FORCE_LAGS))
    for i, lag in enumerate(range(1, FORCE_LAGS + 1)):
        cols[lag:, 2 * i], cols[:-lag, 2 * i + 1] = f[:-lag], f[lag:]
    return cols
