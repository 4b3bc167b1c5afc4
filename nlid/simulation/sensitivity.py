"""Free runs over segments of a record with their forward sensitivities (the output-error fits).

:func:`simulate_segments` runs the scheme of :func:`nlid.simulation.free_run`
over consecutive segments from their own initial states (multiple shooting),
in parallel, and returns a :class:`SegmentRun` with the derivatives of every
sample with respect to the coefficients, the mass, the shape parameters and
each segment's initial state. Used by the scores (:mod:`nlid.scoring`) and the
output-error identifier.
"""

from __future__ import annotations

from collections.abc import Sequence

import numba
import numpy as np

from ..base.validate import MASS
from ..errors import InputError
from ..model.terms import Model
from .encode import encode_memory, encode_model
from .excitation import fine_force
from .kernels import FREE_RUN_OVERSAMPLE, SimulationError, _plan, _sub_steps
from .stage_terms import _memory_d, _segment_v, _terms_d

__all__ = ["simulate_segments", "SegmentRun", "sensitivity_columns"]

# numba's on-disk cache of a kernel is invalidated by changes of its own file only: after editing _plan or
# _sign in kernels.py, the pieces in stage_terms.py (or the memory steps of nlid.model.terms), delete
# nlid/simulation/__pycache__/sensitivity.*.nb[ci].

# --------------------------------------------------------------------------- segments with sensitivities
#
# The output-error identifier fits the free run itself, over one or many segments of a record (multiple
# shooting), and needs the derivative of every simulated sample with respect to the coefficients, the mass,
# the shape parameters and each segment's initial state. They are computed by differentiating the RK4
# scheme itself (forward mode, "internal differentiation"): every stage's state carries its derivatives,
# so the sensitivities are those of the discrete free run, exact to rounding, not of an approximation of it.
# Each term's derivatives with respect to z and v follow from its normal form (a product of signed powers
# and special factors, :mod:`nlid.model.terms.term`); the memory states' from the exact steps
# (:func:`nlid.model.terms.memory_kernels.bouc_wen_step_d`, ``dahl_step_d``).


# fmt: off
# (the kernels' long argument lists stay on two or three lines, so the four RK4 stages read side by side)


@numba.njit(cache=True)
def _accel_d(fk, z, v, ws, Sz, Sv, Sw, inv_m, theta, parts, special, pxc, memory, mem_terms, shape_col,
             col_mass, col_x0, sens, top, g, gz, gv, gs, fac, dfac, pz, pv, pp, out_da):
    """Acceleration ``(f - R) / m`` at a stage and (if ``sens``) its derivative for every column.

    The global columns (coefficients, mass, shapes) come before the initial state's; ``col_x0 == 0``: the
    state's columns only.
    """
    _terms_d(z, v, parts, special, pxc, memory, top, g, gz, gv, gs, fac, dfac, pz, pv, pp)
    R = 0.0
    Rz = 0.0
    Rv = 0.0
    for i in range(theta.size):
        R += theta[i] * g[i]
        Rz += theta[i] * gz[i]
        Rv += theta[i] * gv[i]
    for r in range(mem_terms.size):
        R += theta[mem_terms[r]] * ws[r]
    a = (fk - R) * inv_m
    if not sens:
        return a
    ncol = out_da.size
    for c in range(ncol):
        acc = Rz * Sz[c] + Rv * Sv[c]
        for r in range(mem_terms.size):
            acc += theta[mem_terms[r]] * Sw[r, c]
        out_da[c] = -acc * inv_m
    if col_x0 == 0:
        return a
    for i in range(theta.size):  # the coefficients' columns are the first ones
        out_da[i] -= g[i] * inv_m
        for j in range(special.shape[1]):
            col = shape_col[i, j]
            if col >= 0 and memory[i, 0] == 0.0:
                out_da[col] -= theta[i] * gs[i, j] * inv_m
    for r in range(mem_terms.size):
        out_da[mem_terms[r]] -= ws[r] * inv_m
    if col_mass >= 0:
        out_da[col_mass] -= a * inv_m
    return a


@numba.njit(cache=True)
def _memory_sens(Sw, Sz_stage, Sz, mw, mdz, ma, mb, mem_terms, shape_col, out):
    """Sensitivities of the memory states after a stage's displacement (chain rule of the exact step)."""
    for r in range(mem_terms.size):
        i = mem_terms[r]
        for c in range(out.shape[1]):
            out[r, c] = mw[r] * Sw[r, c] + mdz[r] * (Sz_stage[c] - Sz[c])
        if shape_col[i, 0] >= 0:
            out[r, shape_col[i, 0]] += ma[r]
        if shape_col.shape[1] > 1 and shape_col[i, 1] >= 0:
            out[r, shape_col[i, 1]] += mb[r]


@numba.njit(cache=True, inline="always")
def _stage_f(fk, z, v, inv_m, theta, parts, special, pxc, memory, shape_col, col_mass, col_x0, top, g, gz, gv, gs,
             fac, dfac, pz, pv, pp, F, st):
    """Stage ``st`` of :func:`_segment_f`: the acceleration, ``dR/dz``, ``dR/dv`` and (in ``F[st]``) what each
    global column's derivative of the acceleration subtracts (the products and sums of :func:`_accel_d`)."""
    _terms_d(z, v, parts, special, pxc, memory, top, g, gz, gv, gs, fac, dfac, pz, pv, pp)
    R = 0.0
    Rz = 0.0
    Rv = 0.0
    for i in range(theta.size):
        R += theta[i] * g[i]
        Rz += theta[i] * gz[i]
        Rv += theta[i] * gv[i]
    a = (fk - R) * inv_m
    if col_x0 > 0:
        for i in range(theta.size):
            F[st, i] = g[i] * inv_m
            for j in range(special.shape[1]):
                col = shape_col[i, j]
                if col >= 0:
                    F[st, col] = theta[i] * gs[i, j] * inv_m
        if col_mass >= 0:
            F[st, col_mass] = a * inv_m
    return a, Rz, Rv


@numba.njit(cache=True)
def _segment_f(fine, q, dt, mass, theta, parts, special, pxc, memory, shape_col, col_mass, col_x0, x0, start, n,
               out_z, out_v, out_a, out_S, end_x, end_S):
    """:func:`_segment_d` of a model without memory terms, every column's four stages in one loop.

    The state's four stages come first (each with ``dR/dz``, ``dR/dv`` and the global columns' terms), then
    one pass over the columns carries their sensitivities through the step in registers: the same products
    and sums as :func:`_segment_d` (subtracting a zero where it subtracts nothing), so the same values to
    the bit, for about half the work.
    """
    ncol = out_S.shape[2]
    p = theta.size
    k_max = special.shape[1]
    g = np.zeros(p)
    gz = np.zeros(p)
    gv = np.zeros(p)
    gs = np.zeros((p, k_max))
    fac = np.zeros(k_max)
    dfac = np.zeros(k_max)
    _, top = _plan(parts, special)
    pz = np.zeros(max(top[0], 0) + 1)
    pv = np.zeros(max(top[1], 0) + 1)
    pp = np.zeros(max(top[2], 0) + 1)
    Sz = np.zeros(ncol)
    Sv = np.zeros(ncol)
    F = np.zeros((4, ncol))
    A = np.zeros(4)
    V = np.zeros(4)
    RZ = np.zeros(4)
    RV = np.zeros(4)
    z = x0[0]
    v = x0[1]
    Sz[col_x0] = 1.0
    Sv[col_x0 + 1] = 1.0
    inv_m = 1.0 / mass
    h2 = 0.5 * dt
    h6 = dt / 6.0
    for k in range(n):
        out_z[start + k] = z
        out_v[start + k] = v
        for c in range(ncol):
            out_S[0, start + k, c] = Sz[c]
            out_S[1, start + k, c] = Sv[c]
        for sub in range(q):
            fk = fine[(start + k) * q + sub]
            for st in range(4):  # the four stages through one call site (one inlined copy: compile time)
                if st == 0:
                    zs = z
                    vs = v
                else:
                    h = dt if st == 3 else h2
                    zs = z + h * V[st - 1]
                    vs = v + h * A[st - 1]
                V[st] = vs
                A[st], RZ[st], RV[st] = _stage_f(fk, zs, vs, inv_m, theta, parts, special, pxc, memory, shape_col,
                                                 col_mass, col_x0, top, g, gz, gv, gs, fac, dfac, pz, pv, pp, F, st)
            a1, a2, a3, a4 = A[0], A[1], A[2], A[3]
            v2, v3, v4 = V[1], V[2], V[3]
            Rz1, Rz2, Rz3, Rz4 = RZ[0], RZ[1], RZ[2], RZ[3]
            Rv1, Rv2, Rv3, Rv4 = RV[0], RV[1], RV[2], RV[3]
            if sub == 0:
                out_a[start + k] = a1
            for c in range(ncol):
                sz = Sz[c]
                sv = Sv[c]
                d1 = -(Rz1 * sz + Rv1 * sv) * inv_m - F[0, c]
                if sub == 0:
                    out_S[2, start + k, c] = d1
                sz2 = sz + h2 * sv
                sv2 = sv + h2 * d1
                d2 = -(Rz2 * sz2 + Rv2 * sv2) * inv_m - F[1, c]
                sz3 = sz + h2 * sv2
                sv3 = sv + h2 * d2
                d3 = -(Rz3 * sz3 + Rv3 * sv3) * inv_m - F[2, c]
                sz4 = sz + dt * sv3
                sv4 = sv + dt * d3
                d4 = -(Rz4 * sz4 + Rv4 * sv4) * inv_m - F[3, c]
                Sz[c] = sz + h6 * (sv + 2.0 * sv2 + 2.0 * sv3 + sv4)
                Sv[c] = sv + h6 * (d1 + 2.0 * d2 + 2.0 * d3 + d4)
            z = z + h6 * (v + 2.0 * v2 + 2.0 * v3 + v4)
            v = v + h6 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
        if not (np.isfinite(z) and np.isfinite(v)):
            return k
    end_x[0] = z
    end_x[1] = v
    for c in range(ncol):
        end_S[0, c] = Sz[c]
        end_S[1, c] = Sv[c]
    return -1


@numba.njit(cache=True)
def _segment_d(fine, q, dt, mass, theta, parts, special, pxc, memory, mem_terms, shape_col, col_mass, col_x0,
               x0, start, n, sens, out_z, out_v, out_a, out_S, end_x, end_S):
    """RK4 over ``n`` samples from sample ``start`` and state ``x0``, with forward sensitivities.

    Returns the first sample (relative to ``start``) whose state is not finite, or -1.
    """
    M = mem_terms.size
    ncol = out_S.shape[2] if sens else 1
    p = theta.size
    k_max = special.shape[1]
    g = np.zeros(p)
    gz = np.zeros(p)
    gv = np.zeros(p)
    gs = np.zeros((p, k_max))
    fac = np.zeros(k_max)
    dfac = np.zeros(k_max)
    _, top = _plan(parts, special)
    pz = np.zeros(max(top[0], 0) + 1)
    pv = np.zeros(max(top[1], 0) + 1)
    pp = np.zeros(max(top[2], 0) + 1)
    Sz = np.zeros(ncol)
    Sv = np.zeros(ncol)
    Sw = np.zeros((M, ncol))
    Sz2 = np.zeros(ncol)
    Sv2 = np.zeros(ncol)
    Sz3 = np.zeros(ncol)
    Sv3 = np.zeros(ncol)
    Sz4 = np.zeros(ncol)
    Sv4 = np.zeros(ncol)
    Szn = np.zeros(ncol)
    Sws = np.zeros((M, ncol))
    da1 = np.zeros(ncol)
    da2 = np.zeros(ncol)
    da3 = np.zeros(ncol)
    da4 = np.zeros(ncol)
    w = np.zeros(M)
    ws = np.zeros(M)
    mw = np.zeros(M)
    mdz = np.zeros(M)
    ma = np.zeros(M)
    mb = np.zeros(M)
    z = x0[0]
    v = x0[1]
    for r in range(M):
        w[r] = x0[2 + r]
    if sens:
        Sz[col_x0] = 1.0
        Sv[col_x0 + 1] = 1.0
        for r in range(M):
            Sw[r, col_x0 + 2 + r] = 1.0
    inv_m = 1.0 / mass
    h2 = 0.5 * dt
    h6 = dt / 6.0
    for k in range(n):
        out_z[start + k] = z
        out_v[start + k] = v
        if sens:
            for c in range(ncol):
                out_S[0, start + k, c] = Sz[c]
                out_S[1, start + k, c] = Sv[c]
        for sub in range(q):
            fk = fine[(start + k) * q + sub]
            for r in range(M):
                ws[r] = w[r]
            a1 = _accel_d(fk, z, v, ws, Sz, Sv, Sw, inv_m, theta, parts, special, pxc, memory, mem_terms,
                          shape_col, col_mass, col_x0, sens, top, g, gz, gv, gs, fac, dfac, pz, pv, pp, da1)
            if sub == 0:
                out_a[start + k] = a1
                if sens:
                    for c in range(ncol):
                        out_S[2, start + k, c] = da1[c]
            # stage 2
            z2 = z + h2 * v
            v2 = v + h2 * a1
            _memory_d(memory, mem_terms, w, z2 - z, ws, mw, mdz, ma, mb)
            if sens:
                for c in range(ncol):
                    Sz2[c] = Sz[c] + h2 * Sv[c]
                    Sv2[c] = Sv[c] + h2 * da1[c]
                _memory_sens(Sw, Sz2, Sz, mw, mdz, ma, mb, mem_terms, shape_col, Sws)
            a2 = _accel_d(fk, z2, v2, ws, Sz2, Sv2, Sws, inv_m, theta, parts, special, pxc, memory, mem_terms,
                          shape_col, col_mass, col_x0, sens, top, g, gz, gv, gs, fac, dfac, pz, pv, pp, da2)
            # stage 3
            z3 = z + h2 * v2
            v3 = v + h2 * a2
            _memory_d(memory, mem_terms, w, z3 - z, ws, mw, mdz, ma, mb)
            if sens:
                for c in range(ncol):
                    Sz3[c] = Sz[c] + h2 * Sv2[c]
                    Sv3[c] = Sv[c] + h2 * da2[c]
                _memory_sens(Sw, Sz3, Sz, mw, mdz, ma, mb, mem_terms, shape_col, Sws)
            a3 = _accel_d(fk, z3, v3, ws, Sz3, Sv3, Sws, inv_m, theta, parts, special, pxc, memory, mem_terms,
                          shape_col, col_mass, col_x0, sens, top, g, gz, gv, gs, fac, dfac, pz, pv, pp, da3)
            # stage 4
            z4 = z + dt * v3
            v4 = v + dt * a3
            _memory_d(memory, mem_terms, w, z4 - z, ws, mw, mdz, ma, mb)
            if sens:
                for c in range(ncol):
                    Sz4[c] = Sz[c] + dt * Sv3[c]
                    Sv4[c] = Sv[c] + dt * da3[c]
                _memory_sens(Sw, Sz4, Sz, mw, mdz, ma, mb, mem_terms, shape_col, Sws)
            a4 = _accel_d(fk, z4, v4, ws, Sz4, Sv4, Sws, inv_m, theta, parts, special, pxc, memory, mem_terms,
                          shape_col, col_mass, col_x0, sens, top, g, gz, gv, gs, fac, dfac, pz, pv, pp, da4)
            z_new = z + h6 * (v + 2.0 * v2 + 2.0 * v3 + v4)
            v_new = v + h6 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
            _memory_d(memory, mem_terms, w, z_new - z, ws, mw, mdz, ma, mb)
            if sens:
                for c in range(ncol):
                    Szn[c] = Sz[c] + h6 * (Sv[c] + 2.0 * Sv2[c] + 2.0 * Sv3[c] + Sv4[c])
                    Sv[c] = Sv[c] + h6 * (da1[c] + 2.0 * da2[c] + 2.0 * da3[c] + da4[c])
                _memory_sens(Sw, Szn, Sz, mw, mdz, ma, mb, mem_terms, shape_col, Sws)
                for c in range(ncol):
                    Sz[c] = Szn[c]
                    for r in range(M):
                        Sw[r, c] = Sws[r, c]
            for r in range(M):
                w[r] = ws[r]
            z = z_new
            v = v_new
        if not (np.isfinite(z) and np.isfinite(v)):
            return k
    end_x[0] = z
    end_x[1] = v
    for r in range(M):
        end_x[2 + r] = w[r]
    if sens:
        for c in range(ncol):
            end_S[0, c] = Sz[c]
            end_S[1, c] = Sv[c]
            for r in range(M):
                end_S[2 + r, c] = Sw[r, c]
    return -1


@numba.njit(cache=True, parallel=True)
def _segments_d(fine, q, dt, mass, theta, parts, special, pxc, memory, mem_terms, shape_col, col_mass, col_x0,
                x0, starts, lengths, sens, out_z, out_v, out_a, out_S, end_x, end_S, bad):
    """:func:`_segment_d` for every segment, in parallel (segments are independent)."""
    for s in numba.prange(starts.size):
        if not sens:
            bad[s] = _segment_v(fine, q, dt, mass, theta, parts, special, pxc, memory, mem_terms, x0[s], starts[s],
                                lengths[s], out_z, out_v, out_a, end_x[s])
            continue
        if mem_terms.size == 0:
            bad[s] = _segment_f(fine, q, dt, mass, theta, parts, special, pxc, memory, shape_col, col_mass, col_x0,
                                x0[s], starts[s], lengths[s], out_z, out_v, out_a, out_S, end_x[s], end_S[s])
            continue
        bad[s] = _segment_d(fine, q, dt, mass, theta, parts, special, pxc, memory, mem_terms, shape_col,
                            col_mass, col_x0, x0[s], starts[s], lengths[s], sens, out_z, out_v, out_a, out_S,
                            end_x[s], end_S[s])
# fmt: on


class SegmentRun:
    """Free runs over consecutive segments of a record, with their sensitivities (:func:`simulate_segments`).

    Attributes
    ----------
    z, v, a
        The simulated displacement, velocity and acceleration at every sample (each segment from its own
        initial state), shape ``(N,)``.
    sensitivities
        ``d(z, v, a)[k] / d column``, shape ``(3, N, ncol)``, or ``None`` when not asked for. The
        initial-state columns of a sample are those of the segment it belongs to.
    end_state
        The state ``(z, v, w...)`` after each segment's last sample (where the next segment starts),
        shape ``(K, 2 + M)``.
    end_sensitivities
        Its derivatives, shape ``(K, 2 + M, ncol)`` (``None`` without sensitivities).
    columns
        Names of the columns: the model's terms (coefficients), ``"mass"``, ``"<term>:<shape name>"`` for
        every shape parameter, then ``"z0"``, ``"v0"`` and ``"w0:<term>"`` (the segment's initial state);
        the last ones alone with ``sensitivities="states"``.
    starts, lengths
        First sample and number of samples of each segment.
    memory_terms
        Indices (in the model) of the memory terms, in the order of the states ``w``.
    """

    def __init__(self, z, v, a, sensitivities, end_state, end_sensitivities, columns, starts, lengths, memory_terms):
        self.z, self.v, self.a = z, v, a
        self.sensitivities = sensitivities
        self.end_state = end_state
        self.end_sensitivities = end_sensitivities
        self.columns = columns
        self.starts = starts
        self.lengths = lengths
        self.memory_terms = memory_terms


def sensitivity_columns(model: Model) -> tuple[str, ...]:
    """The columns of :attr:`SegmentRun.sensitivities` for a model (see :class:`SegmentRun`)."""
    cols = list(model.names) + ["mass"]
    for term in model.terms:
        cols += [f"{term.name}:{n}" for n in term.shape_names]
    cols += ["z0", "v0"] + [f"w0:{t.name}" for t in model.terms if t.is_memory]
    return tuple(cols)


def simulate_segments(
    model: Model,
    coefficients: dict[str, float] | np.ndarray,
    mass: float,
    force: np.ndarray,
    fs: float,
    starts: Sequence[int] | np.ndarray,
    initial_states: np.ndarray,
    *,
    force_hold: str = "sampled",
    oversample: int = FREE_RUN_OVERSAMPLE,
    sensitivities: bool | str = True,
    fine: np.ndarray | None = None,
) -> SegmentRun:
    """Free runs of consecutive segments (multiple shooting) with forward sensitivities.

    The record's samples are split at ``starts`` (the first must be 0); segment ``k`` runs from
    ``starts[k]`` up to the next start (or the end) from its own initial state ``(z, v, w_1..w_M)``, with
    the scheme of :func:`~nlid.simulation.free_run` (``oversample`` RK4 sub-steps per sample, the force held or
    interpolated, memory states moved exactly along each stage's displacement). A single segment from
    ``(z0, v0, 0...)`` reproduces :func:`~nlid.simulation.free_run` (to rounding: the terms are evaluated by a different
    routine). Segments run in parallel.

    Parameters
    ----------
    model, coefficients, mass
        The model of ``R``, its coefficients (by name or in model order) and the mass (kg).
    force, fs
        The force samples (N) and their sampling frequency (Hz).
    starts
        First sample of each segment, increasing, starting at 0.
    initial_states
        Shape ``(K, 2 + M)``: ``z``, ``v`` and each memory term's state at the start of each segment.
    force_hold, oversample
        As in :func:`~nlid.simulation.free_run`.
    sensitivities
        Also compute the derivatives with respect to every column of :func:`sensitivity_columns`;
        ``"states"``: only with respect to each segment's initial state (the columns ``"z0"``, ``"v0"``,
        ``"w0:<term>"``, the same values as in the run with every column, for about half its work).
    fine
        The sub-step force from :func:`~nlid.simulation.fine_force` when the caller has it (saves recomputing it).

    Returns
    -------
    SegmentRun

    Raises
    ------
    SimulationError
        If a segment's state becomes non-finite.
    """
    mass = MASS.check(mass, "mass=")
    if sensitivities not in (True, False, "states"):
        raise InputError(f"sensitivities must be True, False or 'states', got {sensitivities!r}")
    q = _sub_steps(force_hold, oversample)
    force = np.asarray(force, dtype=float)
    n = force.size
    starts = np.asarray(starts, dtype=np.int64)
    if starts.ndim != 1 or starts.size == 0 or starts[0] != 0 or np.any(np.diff(starts) <= 0) or starts[-1] >= n:
        raise InputError("starts must be increasing sample indices beginning with 0 and inside the record")
    lengths = np.diff(np.append(starts, n)).astype(np.int64)
    theta = model.vector(coefficients)
    parts, special, pxc = encode_model(model)
    memory = encode_memory(model)
    mem_terms = np.array([i for i, t in enumerate(model.terms) if t.is_memory], dtype=np.int64)
    M = mem_terms.size
    # writable C arrays: one signature of the compiled kernel for every caller (a read-only array is another
    # type to numba, compiled again)
    x0 = np.require(initial_states, dtype=float, requirements=["C", "W"])
    if x0.shape != (starts.size, 2 + M):
        raise InputError(f"initial_states must have shape ({starts.size}, {2 + M}), got {x0.shape}")
    columns = sensitivity_columns(model)
    p = len(model.terms)
    k_max = max(special.shape[1], 2)
    shape_col = np.full((p, k_max), -1, dtype=np.int64)
    col = p + 1
    for i, term in enumerate(model.terms):
        for j in range(len(term.shapes)):
            shape_col[i, j] = col
            col += 1
    col_x0, col_mass = col, p
    if sensitivities == "states":  # the state's columns alone (the kernel: col_x0 == 0)
        columns, col_x0, col_mass = columns[col_x0:], 0, -1
        shape_col[:] = -1
    ncol = len(columns)
    if fine is None:
        fine = fine_force(force, force_hold, q)
    fine = np.require(fine, dtype=float, requirements=["C", "W"])
    if fine.size != n * q:
        raise InputError(f"the sub-step force has {fine.size} samples, expected {n * q}")
    out_z, out_v, out_a = np.empty(n), np.empty(n), np.empty(n)
    K = starts.size
    out_S = np.zeros((3, n, ncol)) if sensitivities else np.zeros((3, 1, 1))
    end_x = np.zeros((K, 2 + M))
    end_S = np.zeros((K, 2 + M, ncol)) if sensitivities else np.zeros((K, 2 + M, 1))
    bad = np.full(K, -1, dtype=np.int64)
    # fmt: off
    _segments_d(fine, q, 1.0 / (fs * q), float(mass), theta, parts, special, pxc, memory, mem_terms, shape_col,
                col_mass, col_x0, x0, starts, lengths, bool(sensitivities), out_z, out_v, out_a, out_S, end_x, end_S,
                bad)
    # fmt: on
    if np.any(bad >= 0):
        s = int(np.flatnonzero(bad >= 0)[0])
        k = int(starts[s] + bad[s])
        raise SimulationError(
            f"simulation diverged at sample {k} (t = {k / fs:.4g} s, segment {s}); the model may be unstable "
            "for this force (check the signs of the coefficients: they are coefficients of R = f - m z'')"
        )
    return SegmentRun(
        out_z,
        out_v,
        out_a,
        out_S if sensitivities else None,
        end_x,
        end_S if sensitivities else None,
        columns,
        starts,
        lengths,
        mem_terms,
    )
