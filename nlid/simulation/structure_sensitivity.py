"""Free runs of a structure over segments with their forward sensitivities (``oe`` on structures).

:func:`structure_segments` runs the scheme of :func:`nlid.simulation.structure.free_run_segments` (classical RK4,
``oversample`` sub-steps per sample, the sub-step force of :func:`nlid.simulation.fine_force`, memory
states moved exactly along each stage's relative displacement and starting from 0 in every segment) and
differentiates the scheme itself in forward mode, as :func:`nlid.simulation.simulate_segments` does for one
DOF: every stage's state carries its derivatives, so they are those of the discrete free run, exact to
rounding (a.e.: the jump of ``sign`` has no derivative). The columns (:func:`structure_sensitivity_columns`)
are the element coefficients, the free entries of the symmetric ``K`` and ``C`` (``i <= j``), the static
force per DOF and the segment's initial state ``z_1..z_n, v_1..v_n``.

With ``R = s + K z + C v + sum_e b_e theta_e g_e(x_e, x_e')`` and ``a = M^-1 (f - R)``, a stage's
``da/dp = -M^-1 (K dz/dp + C dv/dp + sum_e b_e theta_e (g_x dx_e/dp + g_x' dx_e'/dp) + dR/dp|_direct)``;
each element's ``g``, ``g_x`` and ``g_x'`` come from its normal form with the one-DOF pieces
(:mod:`nlid.simulation.sensitivity`). One run with sensitivities costs about what ``2 + ncol / 8`` free
runs do (3-DOF chain, 23 columns), instead of the ``ncol`` extra runs of forward differences.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numba
import numpy as np

from ..errors import InputError
from ..model.terms.memory_kernels import bouc_wen_step_d, dahl_step_d
from . import FREE_RUN_OVERSAMPLE, SimulationError
from .kernels import _sign
from .stage_terms import _part_d, _powers, _special_d

if TYPE_CHECKING:  # pragma: no cover
    from ..model.structure import StructuralModel

__all__ = ["structure_segments", "structure_sensitivity_columns", "StructureSegmentRun"]


@numba.njit(cache=True, inline="always")
def _element_d(e, x, xd, parts, special, pxc, pz, pv, pp, out):
    """``g_e(x, x')``, ``dg/dx`` and ``dg/dx'`` of a non-memory element into ``out[0:3]``."""
    sz = _sign(x)
    sv = _sign(xd)
    _powers(x, parts[e, 0], pz)
    _powers(xd, parts[e, 2], pv)
    val, dz_ = _part_d(pz, parts[e, 0], parts[e, 1], sz)
    f, fv = _part_d(pv, parts[e, 2], parts[e, 3], sv)
    dz_ *= f
    dv_ = val * fv
    val *= f
    if parts[e, 4] != 0 or parts[e, 5] != 0:
        px = ((pxc[e, 0] * x + pxc[e, 1]) * x + pxc[e, 2]) * x + pxc[e, 3]
        dpx = (3.0 * pxc[e, 0] * x + 2.0 * pxc[e, 1]) * x + pxc[e, 2]
        _powers(px, parts[e, 4], pp)
        f, fp = _part_d(pp, parts[e, 4], parts[e, 5], _sign(px))
        dz_ = dz_ * f + val * fp * dpx
        dv_ *= f
        val *= f
    for j in range(special.shape[1]):
        kind = special[e, j, 0]
        if kind == 0.0:
            break
        on_v = special[e, j, 1] != 0.0
        f, fx, _ = _special_d(kind, xd if on_v else x, special[e, j, 2], special[e, j, 3])
        if on_v:
            dv_ = dv_ * f + val * fx
            dz_ *= f
        else:
            dz_ = dz_ * f + val * fx
            dv_ *= f
        val *= f
    out[0] = val
    out[1] = dz_
    out[2] = dv_


# fmt: off
@numba.njit(cache=True)
def _accel_d(fk, z, v, w, Sz, Sv, Sw, Minv, diagonal, K, C, static, theta, parts, special, pxc, memory, ci, cj,
             upper, col_K, col_C, col_s, sens, gd, pz, pv, pp, R, dR, a, da):
    """``a = M^-1 (f - R)`` at a stage and (if ``sens``) ``da`` for every column; ``R``, ``dR`` are scratch.

    ``diagonal``: ``M`` (hence ``M^-1``) is diagonal."""
    n = z.size
    E = theta.size
    ncol = da.shape[1]
    for i in range(n):
        s = static[i]
        for j in range(n):
            s += K[i, j] * z[j] + C[i, j] * v[j]
        R[i] = s
    if sens:
        for i in range(n):
            for c in range(ncol):
                s = 0.0
                for j in range(n):
                    s += K[i, j] * Sz[j, c] + C[i, j] * Sv[j, c]
                dR[i, c] = s
    for e in range(E):
        i = ci[e]
        j = cj[e]
        if memory[e, 0] > 0.0:
            g = w[e]
            force = theta[e] * g
            if sens:
                for c in range(ncol):
                    dR[i, c] += theta[e] * Sw[e, c]
                    if j >= 0:
                        dR[j, c] -= theta[e] * Sw[e, c]
        else:
            x = z[i] - z[j] if j >= 0 else z[i]
            xd = v[i] - v[j] if j >= 0 else v[i]
            _element_d(e, x, xd, parts, special, pxc, pz, pv, pp, gd)
            g = gd[0]
            force = theta[e] * g
            if sens:
                kx = theta[e] * gd[1]
                kv = theta[e] * gd[2]
                for c in range(ncol):
                    dx = Sz[i, c] - Sz[j, c] if j >= 0 else Sz[i, c]
                    dxd = Sv[i, c] - Sv[j, c] if j >= 0 else Sv[i, c]
                    t = kx * dx + kv * dxd
                    dR[i, c] += t
                    if j >= 0:
                        dR[j, c] -= t
        R[i] += force
        if j >= 0:
            R[j] -= force
        if sens:  # the coefficient's own column
            dR[i, e] += g
            if j >= 0:
                dR[j, e] -= g
    if sens:
        for p in range(upper.shape[0]):
            k = upper[p, 0]
            m = upper[p, 1]
            dR[k, col_K + p] += z[m]
            dR[k, col_C + p] += v[m]
            if k != m:
                dR[m, col_K + p] += z[k]
                dR[m, col_C + p] += v[k]
        if col_s >= 0:
            for i in range(n):
                dR[i, col_s + i] += 1.0
    for i in range(n):
        s = 0.0
        for j in range(n):
            s += Minv[i, j] * (fk[j] - R[j])
        a[i] = s
    if sens and diagonal:
        for i in range(n):
            for c in range(ncol):
                da[i, c] = -Minv[i, i] * dR[i, c]
    elif sens:
        for i in range(n):
            for c in range(ncol):
                s = 0.0
                for j in range(n):
                    s -= Minv[i, j] * dR[j, c]
                da[i, c] = s


@numba.njit(cache=True)
def _move_d(memory, ci, cj, w, z_stage, z_start, Sz_stage, Sz_start, Sw, sens, ws, Sws):
    """Every memory state after the stage's relative displacement from the step's start, with its sensitivities."""
    ncol = Sws.shape[1]
    for e in range(w.size):
        if memory[e, 0] <= 0.0:
            continue
        i = ci[e]
        j = cj[e]
        dx = (z_stage[i] - z_stage[j]) - (z_start[i] - z_start[j]) if j >= 0 else z_stage[i] - z_start[i]
        if memory[e, 0] == 1.0:
            ws[e], mw, mdx, _, _ = bouc_wen_step_d(w[e], dx, memory[e, 1], memory[e, 2])
        else:
            ws[e], mw, mdx, _ = dahl_step_d(w[e], dx, memory[e, 1])
        if sens:
            for c in range(ncol):
                ddx = Sz_stage[i, c] - Sz_start[i, c]
                if j >= 0:
                    ddx -= Sz_stage[j, c] - Sz_start[j, c]
                Sws[e, c] = mw * Sw[e, c] + mdx * ddx


@numba.njit(cache=True)
def _segment_d(fine, q, dt, Minv, K, C, static, theta, parts, special, pxc, memory, ci, cj, upper, col_K, col_C,
               col_s, col_x0, x0, start, length, sens, out_z, out_S, end_x, end_S):
    """RK4 over ``length`` samples from sample ``start`` and state ``x0 = (z, v)``; the first bad sample or -1."""
    n = Minv.shape[0]
    E = theta.size
    ncol = out_S.shape[2] if sens else 1
    top = 1
    for e in range(E):
        for k in (0, 2, 4):
            top = max(top, parts[e, k])
    pz = np.zeros(top + 1)
    pv = np.zeros(top + 1)
    pp = np.zeros(top + 1)
    gd = np.zeros(3)
    R = np.zeros(n)
    dR = np.zeros((n, ncol))
    z = x0[:n].copy()
    v = x0[n:].copy()
    zs = np.zeros(n)
    vs = np.zeros((4, n))
    acc = np.zeros((4, n))
    Sz = np.zeros((n, ncol))
    Sv = np.zeros((n, ncol))
    Szs = np.zeros((n, ncol))
    Svs = np.zeros((4, n, ncol))
    dacc = np.zeros((4, n, ncol))
    w = np.zeros(E)
    ws = np.zeros(E)
    Sw = np.zeros((E, ncol))
    Sws = np.zeros((E, ncol))
    if sens:
        for i in range(n):
            Sz[i, col_x0 + i] = 1.0
            Sv[i, col_x0 + n + i] = 1.0
    diagonal = True
    for i in range(n):
        for j in range(n):
            if i != j and Minv[i, j] != 0.0:
                diagonal = False
    has_memory = False
    for e in range(E):
        if memory[e, 0] > 0.0:
            has_memory = True
    h2 = 0.5 * dt
    h6 = dt / 6.0
    for k in range(length):
        for i in range(n):
            out_z[start + k, i] = z[i]
        if sens:
            for i in range(n):
                for c in range(ncol):
                    out_S[start + k, i, c] = Sz[i, c]
        for sub in range(q):
            fk = fine[(start + k) * q + sub]
            for stage in range(4):
                if stage == 0:
                    for i in range(n):
                        vs[0, i] = v[i]
                    if sens:
                        Svs[0] = Sv
                    _accel_d(fk, z, v, w, Sz, Sv, Sw, Minv, diagonal, K, C, static, theta, parts, special, pxc,
                             memory, ci, cj, upper, col_K, col_C, col_s, sens, gd, pz, pv, pp, R, dR, acc[0],
                             dacc[0])
                else:
                    h = dt if stage == 3 else h2
                    for i in range(n):
                        zs[i] = z[i] + h * vs[stage - 1, i]
                        vs[stage, i] = v[i] + h * acc[stage - 1, i]
                    if sens:
                        for i in range(n):
                            for c in range(ncol):
                                Szs[i, c] = Sz[i, c] + h * Svs[stage - 1, i, c]
                                Svs[stage, i, c] = Sv[i, c] + h * dacc[stage - 1, i, c]
                    if has_memory:
                        _move_d(memory, ci, cj, w, zs, z, Szs, Sz, Sw, sens, ws, Sws)
                    _accel_d(fk, zs, vs[stage], ws, Szs, Svs[stage], Sws, Minv, diagonal, K, C, static, theta, parts,
                             special, pxc, memory, ci, cj, upper, col_K, col_C, col_s, sens, gd, pz, pv, pp, R,
                             dR, acc[stage], dacc[stage])
            finite = True
            for i in range(n):
                zs[i] = z[i] + h6 * (vs[0, i] + 2.0 * vs[1, i] + 2.0 * vs[2, i] + vs[3, i])
                finite = finite and np.isfinite(zs[i])
            if sens:
                for i in range(n):
                    for c in range(ncol):
                        Szs[i, c] = Sz[i, c] + h6 * (Svs[0, i, c] + 2.0 * Svs[1, i, c] + 2.0 * Svs[2, i, c]
                                                     + Svs[3, i, c])
            if has_memory:
                _move_d(memory, ci, cj, w, zs, z, Szs, Sz, Sw, sens, ws, Sws)
            for i in range(n):
                v[i] = v[i] + h6 * (acc[0, i] + 2.0 * acc[1, i] + 2.0 * acc[2, i] + acc[3, i])
                finite = finite and np.isfinite(v[i])
                z[i] = zs[i]
            if sens:
                for i in range(n):
                    for c in range(ncol):
                        Sv[i, c] = Sv[i, c] + h6 * (dacc[0, i, c] + 2.0 * dacc[1, i, c] + 2.0 * dacc[2, i, c]
                                                    + dacc[3, i, c])
                        Sz[i, c] = Szs[i, c]
                if has_memory:
                    for e in range(E):
                        for c in range(ncol):
                            Sw[e, c] = Sws[e, c]
            if has_memory:
                for e in range(E):
                    w[e] = ws[e]
            if not finite:
                return k
    for i in range(n):
        end_x[i] = z[i]
        end_x[n + i] = v[i]
        if sens:
            for c in range(ncol):
                end_S[i, c] = Sz[i, c]
                end_S[n + i, c] = Sv[i, c]
    return -1


@numba.njit(cache=True, parallel=True)
def _segments_d(fine, q, dt, Minv, K, C, static, theta, parts, special, pxc, memory, ci, cj, upper, col_K, col_C,
                col_s, col_x0, x0, starts, lengths, sens, out_z, out_S, end_x, end_S, bad):
    """:func:`_segment_d` for every segment, in parallel (segments are independent)."""
    for s in numba.prange(starts.size):
        bad[s] = _segment_d(fine, q, dt, Minv, K, C, static, theta, parts, special, pxc, memory, ci, cj, upper,
                            col_K, col_C, col_s, col_x0, x0[s], starts[s], lengths[s], sens, out_z, out_S, end_x[s],
                            end_S[s])
# fmt: on


class StructureSegmentRun:
    """Free runs of a structure over consecutive segments with their sensitivities (:func:`structure_segments`).

    Attributes
    ----------
    z
        The simulated displacements at every sample, ``(N, n)`` (each segment from its own initial state).
    sensitivities
        ``dz[k, i] / d column``, ``(N, n, ncol)``, or ``None`` when not asked for; the initial-state columns
        of a sample are those of the segment it belongs to.
    end_state
        The state ``(z, v)`` after each segment's last sample (where the next segment starts), ``(K, 2 n)``.
    end_sensitivities
        Its derivatives, ``(K, 2 n, ncol)`` (``None`` without sensitivities).
    columns
        :func:`structure_sensitivity_columns`.
    """

    def __init__(self, z, sensitivities, end_state, end_sensitivities, columns) -> None:
        self.z, self.sensitivities = z, sensitivities
        self.end_state, self.end_sensitivities = end_state, end_sensitivities
        self.columns = columns


def structure_sensitivity_columns(model: StructuralModel) -> tuple[str, ...]:
    """The columns of :attr:`StructureSegmentRun.sensitivities`: elements, ``K[i,j]``, ``C[i,j]`` (``i <= j``,
    1-based), ``s[k]``, then the segment's ``z0[k]`` and ``v0[k]``."""
    n = model.n_dofs
    pairs = [(i, j) for i in range(1, n + 1) for j in range(i, n + 1)]
    return (
        *model.elements.names,
        *(f"K[{i},{j}]" for i, j in pairs),
        *(f"C[{i},{j}]" for i, j in pairs),
        *(f"s[{k}]" for k in range(1, n + 1)),
        *(f"z0[{k}]" for k in range(1, n + 1)),
        *(f"v0[{k}]" for k in range(1, n + 1)),
    )


def structure_segments(
    model: StructuralModel,
    force: np.ndarray,
    fs: float,
    starts: Sequence[int] | np.ndarray,
    states: np.ndarray,
    *,
    force_hold: str = "sampled",
    oversample: int = FREE_RUN_OVERSAMPLE,
    sensitivities: bool = True,
) -> StructureSegmentRun:
    """Free runs of consecutive segments of a record (multiple shooting) with forward sensitivities.

    Parameters
    ----------
    model
        The structure (``K`` and ``C`` are differentiated as symmetric: one column per entry ``i <= j``).
    force, fs, force_hold, oversample
        As in :func:`nlid.simulation.structure.free_run`.
    starts
        First sample of each segment, increasing, starting at 0.
    states
        ``(K, 2 n)``: the displacements and velocities at the start of each segment.
    sensitivities
        Also compute the derivatives (module docstring).

    Raises
    ------
    InputError
        Bad segments or states.
    SimulationError
        A state becomes non-finite.
    """
    from .structure import _encoded, _fine, _inverse_mass, _segment_starts

    fine, q, fs = _fine(model, force, fs, force_hold, oversample)
    n, N = model.n_dofs, fine.shape[0] // q
    starts = _segment_starts(starts, N)
    states = np.ascontiguousarray(states, dtype=float)
    if states.shape != (starts.size, 2 * n) or not np.all(np.isfinite(states)):
        raise InputError(f"states must be finite, of shape ({starts.size}, {2 * n}), got {states.shape}")
    theta, _, memory, parts, special, pxc, ci, cj, _, _ = _encoded(model)
    E = theta.size
    upper = np.array([(i, j) for i in range(n) for j in range(i, n)], dtype=np.int64)
    P = upper.shape[0]
    col_K, col_C, col_s, col_x0 = E, E + P, E + 2 * P, E + 2 * P + n
    columns = structure_sensitivity_columns(model)
    ncol = len(columns)
    lengths = np.diff(np.append(starts, N)).astype(np.int64)
    S = int(starts.size)
    out_z = np.empty((N, n))
    out_S = np.zeros((N, n, ncol)) if sensitivities else np.zeros((1, n, 1))
    end_x = np.zeros((S, 2 * n))
    end_S = np.zeros((S, 2 * n, ncol)) if sensitivities else np.zeros((S, 2 * n, 1))
    bad = np.full(S, -1, dtype=np.int64)
    matrices = [np.ascontiguousarray(x, dtype=float) for x in (_inverse_mass(model.M), model.K, model.C, model.static)]
    # fmt: off
    _segments_d(np.ascontiguousarray(fine), q, 1.0 / (fs * q), *matrices, theta, parts, special,
                np.ascontiguousarray(pxc), memory, ci, cj, upper, col_K, col_C, col_s, col_x0, states, starts,
                lengths, bool(sensitivities), out_z, out_S, end_x, end_S, bad)
    # fmt: on
    if np.any(bad >= 0):
        s = int(np.flatnonzero(bad >= 0)[0])
        k = int(starts[s] + bad[s])
        raise SimulationError(
            f"simulation diverged at sample {k} (t = {k / fs:.4g} s, segment {s}); the structure may be unstable "
            "for this force (check the signs of the coefficients: they are coefficients of R = f - M z'')"
        )
    return StructureSegmentRun(
        out_z, out_S if sensitivities else None, end_x, end_S if sensitivities else None, columns
    )
