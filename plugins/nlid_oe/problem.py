"""The output-error least-squares problem: parameters, residuals and their Jacobian (multiple shooting).

The free run of ``m z'' + R(z, z') = f`` over consecutive segments of the record, each from its own
estimated initial state (:func:`nlid.plugin.simulate_segments`), is compared with the measured channels;
the mismatch of each segment's end state with the next segment's initial state (the continuity defect)
is a soft constraint. With one segment this is the plain free-run (single-shooting) output error.

Residual vector (dimensionless), time-major:

* data rows ``(y_sim,c(t_k) - y_c(t_k)) / std(y_c)`` for every sample ``k`` and fitted channel ``c``;
* defect rows ``w_c (x_end,k - x_0,k+1) / s_x`` for every segment boundary and state component (``z``,
  ``v`` and each memory state ``w``), with ``s_x`` the state's scale (``std(z)``, ``std(v)``,
  ``std(w)``) and ``w_c = continuity_weight * sqrt(samples per segment * channels)``: a defect of one
  state scale weighs as much as a whole segment off by one standard deviation.

Parameters are scaled (``physical = scale * u``) so that every ``u`` is of order one.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import sparse

from nlid.plugin import Model, SimulationError, simulate_segments


@dataclass(frozen=True)
class Parameter:
    """One global parameter: ``kind`` is ``"theta"``, ``"mass"`` or ``"shape"``; ``term`` and ``shape``
    index the model's term and the term's shape parameter."""

    kind: str
    term: int = -1
    shape: int = -1
    name: str = ""


class Shooting:
    """The linear algebra of a multiple-shooting least-squares problem, whatever the simulator.

    A subclass sets ``G`` (global parameters), ``L`` (state components per segment), ``K`` (segments),
    ``C`` (fitted channels), ``starts`` (first sample of each segment), ``record`` (its ``n``: samples),
    ``rows_data = n C``, ``rows`` (with the ``(K - 1) L`` continuity rows), ``dense_limit``, ``diverged`` and
    ``_reduced = None``, and implements ``start()`` (the scaled start vector), ``bounds(u0)``,
    ``_evaluate(u) -> (residual, anything)`` (raising :class:`~nlid.plugin.SimulationError` where the free
    run diverges) and :meth:`blocks`. The one-DOF :class:`Problem` has exact sensitivities; the structure's
    (:mod:`nlid_oe.structure`) differences. ``OutputError._solve`` solves either. The unknowns are
    ``u = [globals (G), state of segment 0 (L), ..., state of segment K - 1 (L)]``; the residual is the data
    rows (time-major, ``C`` per sample) followed by the continuity rows.
    """

    G: int
    L: int
    K: int
    C: int
    starts: np.ndarray
    rows_data: int
    rows: int
    dense_limit: int
    diverged: bool
    _reduced: tuple[np.ndarray, np.ndarray, object] | None
    record: Any

    def start(self) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def _evaluate(self, u: np.ndarray) -> tuple[np.ndarray, object]:  # pragma: no cover - abstract
        raise NotImplementedError

    def blocks(self, u: np.ndarray):  # pragma: no cover - abstract
        """The Jacobian's non-zero blocks at ``u``: ``Jg`` (data rows x globals), ``Jl`` (data rows x the row's
        own segment's state) and, with several segments, the continuity rows' ``(dg, dl, nxt)``: shapes
        ``(K - 1, L, G)``, ``(K - 1, L, L)`` (the ending segment's state), ``(K - 1, L, L)`` (the next one's)."""
        raise NotImplementedError

    @property
    def size(self) -> int:
        """Number of unknowns (global parameters and every segment's initial state)."""
        return self.G + self.K * self.L

    def residual(self, u: np.ndarray | None) -> np.ndarray:
        """The residual vector at ``u`` (default: the start); a large constant where the free run diverges.

        A diverging trial point has a cost far above any other, so the optimiser refuses the step;
        :attr:`diverged` tells whether the last evaluation diverged.
        """
        u = self.start() if u is None else u
        try:
            out = self._evaluate(u)[0]
            self.diverged = False
            return out
        except SimulationError:
            self.diverged = True
            return np.full(self.rows, 1e3)

    def jacobian(self, u: np.ndarray):
        """The Jacobian of :meth:`residual` with respect to ``u`` (dense for one segment, else sparse CSR)."""
        Jg, Jl, defect = self.blocks(u)
        if self.K == 1:
            return np.concatenate([Jg, Jl], axis=1)
        J = self._assemble(Jg, Jl, defect, self.C * np.diff(np.append(self.starts, self.record.n)))
        return J.toarray() if self.rows * self.size <= self.dense_limit else J

    def _assemble(self, Jg, Jl, defect, heights):
        """The multiple-shooting Jacobian as a CSR matrix from its blocks; ``heights``: data rows per segment."""
        G, L, K = self.G, self.L, self.K
        rows_d = Jg.shape[0]
        seg = np.repeat(np.arange(K), heights)
        data_idx = np.concatenate(
            [np.broadcast_to(np.arange(G), (rows_d, G)), G + seg[:, None] * L + np.arange(L)[None, :]], axis=1
        )
        data_val = np.concatenate([Jg, Jl], axis=1)
        dg, dl, nxt = defect
        b = np.arange(K - 1)
        def_idx = np.concatenate(
            [
                np.broadcast_to(np.arange(G), (K - 1, L, G)),
                np.broadcast_to((G + b * L)[:, None, None] + np.arange(L)[None, None, :], (K - 1, L, L)),
                np.broadcast_to((G + (b + 1) * L)[:, None, None] + np.arange(L)[None, None, :], (K - 1, L, L)),
            ],
            axis=2,
        ).reshape(-1, G + 2 * L)
        def_val = np.concatenate([dg, dl, nxt], axis=2).reshape(-1, G + 2 * L)
        width_d, width_e = G + L, G + 2 * L
        indptr = np.concatenate(
            [np.arange(rows_d + 1) * width_d, rows_d * width_d + np.arange(1, def_idx.shape[0] + 1) * width_e]
        )
        indices = np.concatenate([data_idx.ravel(), def_idx.ravel()])
        values = np.concatenate([data_val.ravel(), def_val.ravel()])
        return sparse.csr_matrix((values, indices, indptr), shape=(rows_d + def_idx.shape[0], self.size))

    # ------------------------------------------------------------------ the reduced problem
    @property
    def reduced_rows(self) -> int:
        """Rows of the reduced problem (:meth:`reduced`): ``G + L + 1`` per segment and the defect rows."""
        return self.K * (self.G + self.L + 1) + (self.K - 1) * self.L

    def reduced(self, u: np.ndarray) -> tuple[np.ndarray, object]:
        """The residual and Jacobian of an equivalent small least-squares problem at ``u``.

        Each segment's data rows ``[J_k | r_k]`` (global and own-state columns, residual) are replaced by the
        triangular factor of their QR decomposition, ``G + L + 1`` rows: ``J_k = Q_k R_k`` and
        ``r_k = Q_k t_k`` exactly, so ``|J p + r|`` is the same for every step ``p`` (and ``|r|`` the same
        cost) as in the full problem of :meth:`residual` and :meth:`jacobian` (up to rounding): the
        trust-region steps are the full problem's, computed on ``K (G + L + 1) + (K - 1) L`` rows instead of
        ``N C + (K - 1) L``. The defect rows are kept as they are. Raises :class:`SimulationError` where the
        free run diverges.

        Returns
        -------
        residual, jacobian
            Dense Jacobian while ``reduced_rows x size`` is at most :attr:`dense_limit`, else CSR.
        """
        if self._reduced is not None and np.array_equal(self._reduced[0], u):
            return self._reduced[1], self._reduced[2]
        r = self._evaluate(u)[0]
        Jg, Jl, defect = self.blocks(u)
        G, L, K, C = self.G, self.L, self.K, self.C
        W = G + L + 1
        heights = C * np.diff(np.append(self.starts, self.record.n))
        A = np.concatenate([Jg, Jl, r[: self.rows_data, None]], axis=1)
        R = np.zeros((K, W, W))
        h = int(heights[0])
        equal = int(np.argmin(heights == h)) if np.any(heights != h) else K  # leading segments of h rows
        # segments of equal length (all but possibly the last) in one batched QR
        Rb = np.linalg.qr(A[: equal * h].reshape(equal, h, W), mode="r")
        R[:equal, : Rb.shape[1]] = Rb
        edges = np.append(0, np.cumsum(heights))
        for k in range(equal, K):
            Rk = np.linalg.qr(A[edges[k] : edges[k + 1]], mode="r")
            R[k, : Rk.shape[0]] = Rk
        f = np.concatenate([R[:, :, -1].ravel(), r[self.rows_data :]])
        if K == 1:
            J = R[0, :, :-1]
        else:
            J = self._assemble(
                R[:, :, :G].reshape(K * W, G), R[:, :, G : G + L].reshape(K * W, L), defect, np.full(K, W)
            )
            if self.reduced_rows * self.size <= self.dense_limit:
                J = J.toarray()
        self._reduced = (np.array(u, copy=True), f, J)
        return f, J

    def reduced_residual(self, u: np.ndarray) -> np.ndarray:
        """The residual of :meth:`reduced` (a large constant where the free run diverges, as in :meth:`residual`)."""
        try:
            out = self.reduced(u)[0]
            self.diverged = False
            return out
        except SimulationError:
            self.diverged = True
            return np.full(self.reduced_rows, 1e3 * np.sqrt(self.rows / self.reduced_rows))

    def reduced_jacobian(self, u: np.ndarray, *_: object):
        """The Jacobian of :meth:`reduced` (at a point :meth:`reduced_residual` was evaluated at)."""
        return self.reduced(u)[1]


class Problem(Shooting):
    """The least-squares problem of one output-error fit (see the module docstring).

    Parameters
    ----------
    model
        The model as given (shape parameters at their start values).
    record
        The data.
    params
        The global parameters fitted (coefficients, mass, shapes), in order.
    fixed_theta, fixed_mass
        Values of the coefficients and mass (the fitted ones are overwritten from ``u``).
    starts
        First sample of each segment.
    state0
        Start values of each segment's initial state, shape ``(K, 2 + M)``.
    channels
        Fitted channels (``"z"``, ``"v"``, ``"a"``), each measured in ``record``.
    oversample, fine
        Sub-steps per sample and the sub-step force.
    scales, state_scales
        Scale of each global parameter and of each state component.
    continuity_weight
        Multiplies the defect rows.
    """

    def __init__(
        self,
        model,
        record,
        params,
        fixed_theta,
        fixed_mass,
        starts,
        state0,
        channels,
        oversample,
        fine,
        scales,
        state_scales,
        continuity_weight,
    ):
        self.model = model
        self.record = record
        self.params = list(params)
        self.theta = np.asarray(fixed_theta, dtype=float).copy()
        self.mass = float(fixed_mass)
        self.shapes = [list(t.shapes) for t in model.terms]
        self.starts = np.asarray(starts, dtype=np.int64)
        self.K = self.starts.size
        self.M = sum(t.is_memory for t in model.terms)
        self.L = 2 + self.M
        self.G = len(self.params)
        self.state0 = np.asarray(state0, dtype=float)
        self.channels = tuple(channels)
        self.C = len(self.channels)
        self.measured = np.column_stack([getattr(record, c) for c in self.channels])
        self.channel_scale = np.array([float(np.std(getattr(record, c))) for c in self.channels])
        self.q = int(oversample)
        self.fine = fine
        self.scale = np.concatenate([np.asarray(scales, dtype=float), np.tile(state_scales, self.K)])
        self.state_scales = np.asarray(state_scales, dtype=float)
        n = record.n
        lengths = np.diff(np.append(self.starts, n))
        self.segment_of = np.repeat(np.arange(self.K), lengths)
        self.weight = float(continuity_weight) * np.sqrt(float(np.mean(lengths)) * self.C) if self.K > 1 else 0.0
        self.rows_data = n * self.C
        self.rows = self.rows_data + (self.K - 1) * self.L
        self._cache: tuple[np.ndarray, np.ndarray, object] | None = None
        self._reduced: tuple[np.ndarray, np.ndarray, object] | None = None
        self.evaluations = 0
        self.diverged = False
        self._start: np.ndarray | None = None
        #: Largest Jacobian (rows x columns) returned dense.
        self.dense_limit = 0
        #: Whether evaluations compute the sensitivities (``False``: the residual alone, no :meth:`blocks`).
        self.sensitivities = True

    # ------------------------------------------------------------------ parameters
    def start(self) -> np.ndarray:
        """The scaled start vector ``u`` (after :meth:`fit_states`, the refined one)."""
        if self._start is not None:
            return self._start.copy()
        phys = []
        for p in self.params:
            if p.kind == "theta":
                phys.append(self.theta[p.term])
            elif p.kind == "mass":
                phys.append(self.mass)
            else:
                phys.append(self.shapes[p.term][p.shape])
        return np.concatenate([np.asarray(phys, dtype=float), self.state0.ravel()]) / self.scale

    def unpack(self, u: np.ndarray) -> tuple[Model, np.ndarray, float, np.ndarray, list[int]]:
        """The model (shapes applied), coefficients in its order, mass, initial states and the term order.

        ``order[i]`` is the position in the returned model of the given model's term ``i``.
        """
        x = np.asarray(u, dtype=float) * self.scale
        theta = self.theta.copy()
        mass = self.mass
        shapes = [list(s) for s in self.shapes]
        for p, value in zip(self.params, x[: self.G], strict=True):
            if p.kind == "theta":
                theta[p.term] = value
            elif p.kind == "mass":
                mass = float(value)
            else:
                shapes[p.term][p.shape] = float(value)
        model = self.model
        names = list(model.names)
        for i, term in enumerate(self.model.terms):
            if term.shapes and tuple(shapes[i]) != term.shapes:
                model = model.with_term_shapes(names[i], shapes[i])
                names[i] = term.with_shapes(shapes[i]).name
        order = [model.names.index(n) for n in names]
        theta_model = np.empty_like(theta)
        theta_model[order] = theta
        states = x[self.G :].reshape(self.K, self.L).copy()
        # memory states in the order of the (possibly reordered) model's memory terms
        if self.M > 1:
            given = [i for i, t in enumerate(self.model.terms) if t.is_memory]
            now = sorted(given, key=lambda i: order[i])
            states[:, 2:] = states[:, 2 + np.array([given.index(i) for i in now])]
        return model, theta_model, mass, states, order

    def refine_start(self, iterations: int = 30) -> None:
        """Replace the start's segment states by :meth:`fit_states`'s (the global parameters kept)."""
        self._start = self.fit_states(self.start(), iterations)

    def set_globals(self, values: np.ndarray) -> None:
        """Set the start values of the global parameters (physical units, in the order of ``params``)."""
        for p, value in zip(self.params, np.asarray(values, dtype=float), strict=True):
            if p.kind == "theta":
                self.theta[p.term] = value
            elif p.kind == "mass":
                self.mass = float(value)
            else:
                self.shapes[p.term][p.shape] = float(value)

    def globals_of(self, u: np.ndarray) -> np.ndarray:
        """The global parameters at ``u`` (physical units)."""
        return np.asarray(u[: self.G]) * self.scale[: self.G]

    def states_of(self, u: np.ndarray) -> np.ndarray:
        """Each segment's initial state at ``u``, shape ``(K, 2 + M)`` (the given model's memory order)."""
        return (np.asarray(u[self.G :]) * self.scale[self.G :]).reshape(self.K, self.L)

    def bounds(self, u0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Bounds of ``u``: a positive mass and scales (exp, tanh, Dahl's rho), gap clearances of their sign."""
        lower = np.full(u0.size, -np.inf)
        upper = np.full(u0.size, np.inf)
        for k, p in enumerate(self.params):
            if p.kind == "mass":
                lower[k] = 1e-3 * u0[k]
            elif p.kind == "shape":
                term = self.model.terms[p.term]
                kind, value = term.shape_names[p.shape], term.shapes[p.shape]
                if kind in ("c", "rho"):
                    lower[k] = 1e-3 * u0[k]
                elif kind == "d" and value >= 0:
                    lower[k] = 0.0
                elif kind == "d":
                    upper[k] = 0.0
        return lower, upper

    # ------------------------------------------------------------------ evaluation
    def _evaluate(self, u: np.ndarray):
        if self._cache is not None and np.array_equal(self._cache[0], u):
            return self._cache[1], self._cache[2]
        self.evaluations += 1
        model, theta, mass, states, order = self.unpack(u)
        if not mass > 0:
            raise SimulationError("the mass is not positive")
        run = simulate_segments(
            model,
            theta,
            mass,
            self.record.f,
            self.record.fs,
            self.starts,
            states,
            force_hold=self.record.force_hold,
            oversample=self.q,
            sensitivities=self.sensitivities,
            fine=self.fine,
        )
        sim = np.column_stack([getattr(run, c) for c in self.channels])
        r = np.empty(self.rows)
        r[: self.rows_data] = ((sim - self.measured) / self.channel_scale).ravel()
        if self.K > 1:
            x0 = np.asarray(u[self.G :] * self.scale[self.G :]).reshape(self.K, self.L)
            defect = (run.end_state[:-1] - self._given_state_order(x0[1:], model, order)) / self._state_scale(
                model, order
            )
            r[self.rows_data :] = self.weight * defect.ravel()
        self._cache = (np.array(u, copy=True), r, (run, model, order))
        return r, (run, model, order)

    def _given_state_order(self, states: np.ndarray, model: Model, order: list[int]) -> np.ndarray:
        """Initial states (given model's memory order) in the order of ``model``'s memory terms."""
        if self.M <= 1:
            return states
        given = [i for i, t in enumerate(self.model.terms) if t.is_memory]
        now = sorted(given, key=lambda i: order[i])
        out = states.copy()
        out[:, 2:] = states[:, 2 + np.array([given.index(i) for i in now])]
        return out

    def _state_scale(self, model: Model, order: list[int]) -> np.ndarray:
        return self._given_state_order(self.state_scales[None, :], model, order)[0]

    def blocks(self, u: np.ndarray):
        """The Jacobian's non-zero blocks at ``u``.

        Returns ``Jg`` (data rows x global parameters), ``Jl`` (data rows x the state of the row's own
        segment) and the defect rows' blocks ``(dg, dl, nxt)``: each boundary's derivatives with respect to
        the global parameters, the ending segment's state and the next segment's state, shapes
        ``(K - 1, L, G)``, ``(K - 1, L, L)``, ``(K - 1, L, L)``.
        """
        _, (run, model, order) = self._evaluate(u)
        S = run.sensitivities  # (3, N, ncol), columns of sensitivity_columns(model)
        cols = list(run.columns)
        gcols = []
        for p in self.params:
            if p.kind == "theta":
                gcols.append(order[p.term])
            elif p.kind == "mass":
                gcols.append(cols.index("mass"))
            else:
                term = model.terms[order[p.term]]
                gcols.append(cols.index(f"{term.name}:{term.shape_names[p.shape]}"))
        lcols = self._local_columns(cols, model, order)
        which = {"z": 0, "v": 1, "a": 2}
        chan = [which[c] for c in self.channels]
        n = self.record.n
        gscale = self.scale[: self.G]
        lscale = self.scale[self.G : self.G + self.L]
        # data rows, time-major: (n, C, G) and (n, C, L)
        Sc = S[chan]
        Jg = (Sc[:, :, gcols].transpose(1, 0, 2) * (gscale / self.channel_scale[:, None])[None]).reshape(n * self.C, -1)
        Jl = (Sc[:, :, lcols].transpose(1, 0, 2) * (lscale[None, :] / self.channel_scale[:, None])[None]).reshape(
            n * self.C, -1
        )
        if self.K == 1:
            return Jg, Jl, None
        # defect rows: boundary b (end of segment b vs start of b + 1), one per state component
        sx = self._state_scale(model, order)
        E = run.end_sensitivities[:-1]  # (K-1, L, ncol)
        wsc = self.weight / sx
        dg = E[:, :, gcols] * gscale[None, None, :] * wsc[None, :, None]
        dl = E[:, :, lcols] * lscale[None, None, :] * wsc[None, :, None]
        perm = self._local_permutation(model, order)
        # the next segment's initial state enters with -1 (in the given model's memory order)
        nxt = np.zeros((self.K - 1, self.L, self.L))
        nxt[:, np.arange(self.L), perm] = -(lscale[perm] * wsc)[None, :]
        return Jg, Jl, (dg, dl, nxt)

    def _local_permutation(self, model: Model, order: list[int]) -> np.ndarray:
        """``perm[l]``: the given-order local column that state component ``l`` of ``model`` comes from."""
        perm = np.arange(self.L)
        if self.M > 1:
            given = [i for i, t in enumerate(self.model.terms) if t.is_memory]
            now = sorted(given, key=lambda i: order[i])
            perm[2:] = 2 + np.array([given.index(i) for i in now])
        return perm

    def _local_columns(self, cols: list[str], model: Model, order: list[int]) -> list[int]:
        """Sensitivity columns of the initial state, in the given model's memory order."""
        out = [cols.index("z0"), cols.index("v0")]
        for i, t in enumerate(self.model.terms):
            if t.is_memory:
                out.append(cols.index(f"w0:{model.terms[order[i]].name}"))
        return out

    def fit_states(self, u: np.ndarray, iterations: int = 30, rtol: float = 1e-6) -> np.ndarray:
        """Each segment's initial state fitted with the global parameters held, on growing windows.

        :meth:`fit_window` on the first eighth of every segment, then a quarter, a half and the whole: over
        a short window the state is nearly determined by the data (a position and a slope), and each longer
        window starts from the shorter one's answer (a state fitted to a long window directly can settle on
        a wrong trajectory, e.g. the other well of a double well).
        """
        lengths = np.diff(np.append(self.starts, self.record.n))
        shortest = int(lengths.min())
        for fraction in (8, 4, 2, 1):
            window = shortest // fraction
            if window >= 16 or fraction == 1:
                u = self.fit_window(u, window if fraction > 1 else None, iterations, rtol)
        return u

    def fit_window(self, u: np.ndarray, window: int | None, iterations: int = 30, rtol: float = 1e-6) -> np.ndarray:
        """Each segment's initial state fitted to its own data with the global parameters held (``u`` updated).

        The states taken from the data (a noisy displacement, a band-limited velocity estimate) can be far
        from any trajectory of the model: starting the joint fit there, the optimiser wanders. Here every
        segment's state alone is fitted to the first ``window`` samples of the segment (``None``: all) by
        Levenberg-Marquardt steps (the segments are independent when the global parameters are held and the
        continuity rows left out), all segments in one simulation per iteration. Only the windows are
        simulated (the windows of all segments joined into one shorter record of segments: the samples, their
        force and sub-step force are those of the record), and a step is kept or refused segment by segment
        without simulating again (a segment's run depends on its own state only).
        """
        u = np.array(u, dtype=float, copy=True)
        G, L, K, C, q = self.G, self.L, self.K, self.C, self.q
        lengths = np.diff(np.append(self.starts, self.record.n))
        width = lengths if window is None else np.minimum(int(window), lengths)
        idx = np.concatenate([np.arange(s, s + w) for s, w in zip(self.starts, width, strict=True)])
        starts = np.append(0, np.cumsum(width)[:-1])
        fine = self.fine[(idx[:, None] * q + np.arange(q)[None, :]).ravel()]
        force = self.record.f[idx]
        measured = self.measured[idx]
        edges = np.append(starts, idx.size) * C  # first data row of each segment's window
        seg = np.repeat(np.arange(K), width * C)
        which = {"z": 0, "v": 1, "a": 2}
        chan = [which[c] for c in self.channels]
        lscale = self.scale[G : G + L]

        def evaluate(x):
            """Cost per segment, data residual and the states' Jacobian rows of the windows; ``None`` if diverged."""
            model, theta, mass, states, order = self.unpack(x)
            if not mass > 0:
                return None
            try:
                run = simulate_segments(
                    model,
                    theta,
                    mass,
                    force,
                    self.record.fs,
                    starts,
                    states,
                    force_hold=self.record.force_hold,
                    oversample=q,
                    sensitivities="states",
                    fine=fine,
                )
            except SimulationError:
                return None
            sim = np.column_stack([getattr(run, c) for c in self.channels])
            data = ((sim - measured) / self.channel_scale).ravel()
            lcols = self._local_columns(list(run.columns), model, order)
            Jl = (
                run.sensitivities[chan][:, :, lcols].transpose(1, 0, 2)
                * (lscale[None, :] / self.channel_scale[:, None])[None]
            ).reshape(-1, L)
            return np.bincount(seg, data**2, minlength=K), data, Jl

        state = evaluate(u)
        if state is None:
            return u
        cost, data, Jl = state
        lam = np.full(K, 1e-3)
        for _ in range(iterations):
            A = np.add.reduceat(Jl[:, :, None] * Jl[:, None, :], edges[:-1], axis=0)
            g = np.add.reduceat(Jl * data[:, None], edges[:-1], axis=0)
            diag = np.einsum("kii->ki", A)
            A_damped = A + lam[:, None, None] * np.einsum("ki,ij->kij", np.maximum(diag, 1e-300), np.eye(L))
            step = -np.linalg.solve(A_damped, g[:, :, None])[:, :, 0]
            trial = u.copy()
            trial[G:] += step.ravel()
            new = evaluate(trial)
            if new is None:
                lam *= 10.0
                continue
            new_cost, new_data, new_Jl = new
            better = new_cost < cost
            u[G:] = np.where(np.repeat(better, L), trial[G:], u[G:])
            lam = np.where(better, lam / 3.0, lam * 4.0)
            gain = float(np.sum(cost - np.where(better, new_cost, cost)))
            rows = better[seg]
            cost = np.where(better, new_cost, cost)
            data = np.where(rows, new_data, data)
            Jl = np.where(rows[:, None], new_Jl, Jl)
            if gain <= rtol * float(np.sum(cost)):
                break
        return u

    def run_at(self, u: np.ndarray):
        """The segment run, model and term order at ``u`` (evaluated if needed)."""
        return self._evaluate(u)[1]
