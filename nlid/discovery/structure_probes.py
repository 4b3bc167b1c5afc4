"""What remains in a structure's residual: flexible functions of each connection, and what no connection carries.

The "What remains" of :func:`nlid.discovery.structure.discover_structure` (its step 6): on the current model,
flexible functions of each connection's relative displacement (Legendre polynomials of degree 2-8), velocity
(degree 2-7 and its sign) and history (play operators) are fitted the same cross-fitted way as the
candidates; one that explains :data:`~nlid.discovery.probes.MIN_STRUCTURE` or more of the held-out residual
of its DOFs counts as remaining structure. Two probes of each DOF find what no connection carries
(:data:`~nlid.discovery.structure_result.DOF_PROBES`): its acceleration (a mass matrix wrong on that DOF) and
the force's neighbouring samples (a force acting delayed, early or filtered).
"""

from __future__ import annotations

import numpy as np

from ..estimation.joint import Extra
from .probes import PLAY_WIDTHS, _legendre
from .structure_fit import Search, connection_columns, connectivity, fraction, relative
from .structure_result import DOF_PROBES, ConnectionProbe, StructureRemaining

__all__ = ["STRUCTURE_PROBES", "FORCE_LAGS", "remaining_structure"]

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
    """Flexible functions of each connection's coordinate, cross-fitted on the current model's residual."""
    n, w = search.n, search.weights
    base = search.cross_scores(None)
    est, ho = search.parts["estimation"], search.parts["holdout"]
    out = []
    for c in conns:
        touched = [c[0] - 1] + ([c[1] - 1] if c[1] else [])
        x_e, xd_e = relative(est.data, c)
        scale = (0.5 * (x_e.max() + x_e.min()), max(0.5 * np.ptp(x_e), 1e-300), max(float(np.abs(xd_e).max()), 1e-300))
        for probe in STRUCTURE_PROBES:
            columns = lambda x, xd, probe=probe, scale=scale: _probe_columns(probe, x, xd, scale)  # noqa: E731
            col_e, col_h = connection_columns(est.data, c, columns), connection_columns(ho.data, c, columns)
            extra = Extra(col_e, connectivity(c, n))
            scored = search.cross_scores({"extras": [extra], "estimation": [col_e], "holdout": [col_h]})
            a = fraction(scored["on_holdout"], base["on_holdout"], w, touched)
            b = fraction(scored["on_estimation"], base["on_estimation"], w, touched)
            out.append(ConnectionProbe(c, probe, float(0.5 * (a + b)), float(a), float(b), col_e.shape[1]))
    for k in range(1, n + 1):  # what no connection carries: the mass given and the force's path, DOF by DOF
        for probe in DOF_PROBES:
            col_e, col_h = _dof_columns(probe, est.data, k), _dof_columns(probe, ho.data, k)
            if col_e is None or col_h is None:
                continue
            extra = Extra(col_e, connectivity((k, 0), n))
            scored = search.cross_scores({"extras": [extra], "estimation": [col_e], "holdout": [col_h]})
            a = fraction(scored["on_holdout"], base["on_holdout"], w, [k - 1])
            b = fraction(scored["on_estimation"], base["on_estimation"], w, [k - 1])
            out.append(ConnectionProbe((k, 0), probe, float(0.5 * (a + b)), float(a), float(b), col_e.shape[1]))
    return StructureRemaining(tuple(out), float(threshold))


def _dof_columns(probe: str, data, k: int) -> np.ndarray | None:
    """The columns of a DOF probe on DOF ``k`` (``None``: the probe says nothing there).

    ``"acceleration"``: the DOF's acceleration (a mass matrix wrong on that DOF leaves ``dm a_k`` in its balance);
    ``"force"``: the force on the DOF :data:`FORCE_LAGS` samples before and after (a force that acts delayed,
    early or filtered leaves a combination of them). Both in the equation band, as the balance's own channels.
    """
    if probe == "acceleration":
        return np.asarray(data.a[:, k - 1], dtype=float)[:, None]
    f = np.asarray(data.f[:, k - 1], dtype=float)
    if not np.any(f):
        return None  # no force on this DOF
    cols = np.zeros((f.size, 2 * FORCE_LAGS))
    for i, lag in enumerate(range(1, FORCE_LAGS + 1)):
        cols[lag:, 2 * i], cols[:-lag, 2 * i + 1] = f[:-lag], f[lag:]
    return cols
