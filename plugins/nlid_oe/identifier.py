"""Output-error identification: minimise the free-run simulation error, starting from another method.

Every other identifier of nlid fits an equation error (the force balance, Eq. 25). Measured benchmarks
score the *free-run* error: the model driven by the measured force from an initial state, its simulated
displacement against the measured one (:func:`nlid.scoring.free_run_error`). ``oe`` minimises that error
directly with :func:`scipy.optimize.least_squares` (trust-region reflective), over the coefficients, the
mass when it is not given, the shape parameters of the terms (a Stribeck scale, a gap's clearance, the
Bouc-Wen ``a, b``: option ``shapes``) and the initial state, starting from another identifier's estimate
(option ``init``, run through :func:`nlid.plugin.identify`).

Simulation and sensitivities
    The free run is the scheme :func:`nlid.plugin.free_run` scores with (RK4, ``oversample`` sub-steps per
    sample, the force held or band-limited interpolated, memory states moved exactly along each stage);
    its derivatives with respect to every parameter are those of the discrete scheme, propagated in
    forward mode by the compiled :func:`nlid.plugin.simulate_segments`.

Multiple shooting
    A chaotic free run cannot be fitted from ``t = 0``: a change in the last digit of a coefficient
    changes the trajectory completely after a while. The record is then cut into segments, each with its
    own estimated initial state, and the mismatch between a segment's end and the next one's start is a
    soft constraint (:mod:`nlid_oe.problem`). The segment length is a fraction
    (:data:`SEGMENT_FRACTION`) of the start model's predictability horizon
    (:func:`nlid.plugin.predictability_horizon`: the time over which the chaos check's initial offset
    grows to its limit); a start model with several stable equilibria is fitted on short segments (a single
    free run over both wells has local minima far from the truth); a record whose free run stays
    predictable is fitted in one segment. Automatic segments are halved while the fit stays above the
    measurement noise floor (docs/oe.md).

Standard errors
    From the Jacobian at the optimum: the segments' initial states are profiled out (each segment's
    columns projected out of the global ones, ignoring the continuity rows, which makes the errors
    slightly conservative with several segments), then the batch-means sandwich of
    :func:`nlid.plugin.least_squares` accounts for the residual's correlation (its integrated
    autocorrelation time sets the batch length). A (nearly) singular Gauss-Newton Hessian raises an
    :class:`~nlid.plugin.IdentificationError`.

Shapes
    When shape parameters change, the terms' canonical names change with them: the estimate carries the
    refined model (:attr:`nlid.plugin.Estimate.model`) and its coefficients are keyed by the refined terms;
    ``diagnostics["shapes"]`` lists the fitted values and their standard errors.

Several degrees of freedom (``dofs = "multi"``)
    An indexed :class:`~nlid.plugin.Record` is fitted on the free run of every DOF's displacement with
    the
    structure simulator, from another identifier's estimate (:mod:`nlid_oe.structure`).
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any

import numpy as np

from nlid.plugin import (
    FREE_RUN_OVERSAMPLE,
    DataError,
    ElementSet,
    Estimate,
    IdentificationError,
    Identifier,
    InputError,
    Model,
    Option,
    Record,
    SimulationError,
    StructureEstimate,
    choose_method,
    derivatives,
    fine_force,
    identify,
    kernel_threads,
    predictability_horizon,
    progress_line,
)

from .rules import (
    DENSE_LIMIT,
    DIRECT_LIMIT,
    EXACT_LIMIT,
    HORIZON_QUANTILE,
    MAX_HALVINGS,
    MAX_SHORT_SEGMENTS,
    MIN_SAMPLES,
    MIN_SEGMENT,
    NOISE_RATIO,
    SEGMENT_FRACTION,
    SHORT_PERIODS,
    WHOLE_RECORD_RATIO,
)

if TYPE_CHECKING:
    from .problem import Parameter, Problem, Shooting


def _data_rms(problem: Problem, res: Any) -> float:
    """RMS of a solved problem's data residual (channels scaled by their std), continuity rows left out."""
    r = problem.residual(res.x)[: problem.rows_data]
    return float(np.sqrt(np.mean(r**2)))


def _fastest_frequency(start: Any, record: Record) -> float:
    """The highest natural frequency of the start model (Hz), else the displacement's spectral peak."""
    fn = [m.fn_hz for m in start.modal if np.isfinite(m.fn_hz) and m.fn_hz > 0]
    if fn:
        return float(max(fn))
    from scipy import signal

    z = record.z - np.mean(record.z)
    f, pxx = signal.welch(z, fs=record.fs, nperseg=min(4096, z.size))
    pxx[0] = 0.0
    return float(max(f[int(np.argmax(pxx))], record.fs / z.size))


def _shape_selection(text: str | None, model: Model) -> list[int]:
    """Indices of the terms whose shape parameters are fitted (option ``shapes``; ``None``: none)."""
    if text is None or text.strip().lower() == "none":
        return []
    spec = text.strip()
    shaped = [i for i, t in enumerate(model.terms) if t.shapes]
    if spec.lower() == "all":
        return shaped
    try:
        wanted = Model.from_spec(spec, defaults=False).names
    except InputError as exc:
        raise InputError(f"oe: option 'shapes' must be 'all', 'none' or a list of terms: {exc}") from None
    out = []
    for name in wanted:
        if name not in model.names:
            raise InputError(f"oe: option 'shapes' names {name!r}, which is not a term of the model ({model})")
        i = model.names.index(name)
        if not model.terms[i].shapes:
            raise InputError(f"oe: option 'shapes' names {name!r}, which has no shape parameter")
        out.append(i)
    return out


class OutputError(Identifier):
    """Output-error least squares on the free-run simulation (multiple shooting when chaotic)."""

    name = "oe"
    summary = (
        "output error: fit the free-run simulation (coefficients, mass, shapes, initial state) from another "
        "method's start"
    )
    options = (
        Option(
            "init",
            "str",
            None,
            "identifier whose estimate starts the fit (default: the preferred installed one)",
            nullable=True,
        ),
        Option(
            "shapes",
            "str",
            "all",
            "shape parameters to fit: all, none, or a comma-separated list of terms",
            nullable=True,
        ),
        Option(
            "outputs",
            "str",
            "z",
            "measured channels whose free-run error is minimised",
            choices=("z", "z,v", "z,a", "z,v,a"),
        ),
        Option(
            "segment_seconds",
            "float",
            None,
            "multiple-shooting segment length in s (default: a third of the predictability horizon when "
            "chaotic, short segments for a model with several stable equilibria, else one segment; "
            "0: one segment)",
            nullable=True,
            minimum=0.0,
        ),
        Option("continuity_weight", "float", 1.0, "weight of the continuity defects between segments", minimum=1e-6),
        Option(
            "oversample",
            "int",
            FREE_RUN_OVERSAMPLE,
            "RK4 sub-steps per sample of the fitted free run",
            minimum=1,
            maximum=64,
        ),
        Option("max_nfev", "int", 100, "most evaluations of the free run by the optimiser", minimum=1),
        Option(
            "tol", "float", 1e-8, "relative tolerance of the optimiser (ftol, xtol, gtol)", minimum=1e-15, maximum=0.1
        ),
    )
    needs_mass = False
    dofs = "multi"
    refines = True  # starts from the method its 'init' option names
    advice = (
        "the figure that matters is the free-run (simulation) error, or a shape parameter enters "
        "nonlinearly: refines another method's fit on the free run (multiple shooting when chaotic); removes "
        "rfs's damping bias; 10-100x slower than rfs; avoid with sign(v) terms and frequent reversals"
    )
    advice_order = 50
    docs = "docs/oe.md"

    # ------------------------------------------------------------------ the start
    def _start(self, record: Record, model: Model, mass: float | None) -> tuple[Any, str]:
        method = self.settings["init"]
        if method is None:
            method, _ = choose_method(mass)
        if method == self.name:
            raise InputError("oe: option 'init' must name another identifier (oe starts from its estimate)")
        return identify(record, model, method, mass=mass), method

    # ------------------------------------------------------------------ identify
    def identify(self, record: Record, model: Model, *, mass: float | None = None) -> Estimate:
        """Fit the free run (module docstring) and return the coefficients keyed by the (refined) model."""
        clock = time.perf_counter()
        if record.n < MIN_SAMPLES:
            raise DataError(f"oe: the record has {record.n} samples; at least {MIN_SAMPLES} are needed")
        channels = tuple(self.settings["outputs"].split(","))
        for c in channels[1:]:
            if not record.is_measured(c):
                raise InputError(f"oe: option 'outputs' asks for {c!r}, which the record does not measure")
        shaped = _shape_selection(self.settings["shapes"], model)
        start, method = self._start(record, model, mass)
        # the segments' kernels on the shared pool (nlid.runtime.parallel.workers), BLAS on one thread: the matrices
        # between two free runs are small, and a BLAS pool spinning after its call takes the kernels' cores
        with kernel_threads() as threads:
            estimate = self._fit(record, model, mass, start, method, channels, shaped)
        estimate.diagnostics["threads"] = threads
        estimate.diagnostics["seconds"] = time.perf_counter() - clock
        return estimate

    def identify_structure(
        self, record: Record, elements: ElementSet, *, mass: np.ndarray | None = None
    ) -> StructureEstimate:
        """Fit every DOF's free run of a structure (:mod:`nlid_oe.structure`)."""
        from .structure import identify_structure

        return identify_structure(self, record, elements, mass)

    def _fit(
        self,
        record: Record,
        model: Model,
        mass: float | None,
        start: Any,
        method: str,
        channels: tuple[str, ...],
        shaped: list[int],
    ) -> Estimate:
        """The fit from the start estimate (:meth:`identify`)."""
        from .problem import Parameter, Problem  # scipy.sparse: not at import (loading the entry points)
        from .uncertainty import standard_errors as profiled_standard_errors

        theta0 = model.vector(dict(start.coefficients))
        m0 = float(start.mass)  # type: ignore[arg-type]
        q = int(self.settings["oversample"])

        # segments: from the start model's predictability horizon unless given
        horizon = None
        seconds = self.settings["segment_seconds"]
        try:
            if seconds is None:
                horizon = predictability_horizon(model, theta0, m0, record, oversample=q, quantile=HORIZON_QUANTILE)
        except SimulationError as exc:
            raise IdentificationError(f"oe: the start model ({method}) diverges in a free run: {exc}") from None
        if seconds is not None:
            length = record.n if seconds == 0 else int(round(seconds * record.fs))
            rule = "one segment (segment_seconds = 0)" if seconds == 0 else f"given: {seconds:g} s"
        elif horizon is not None:
            length = int(round(SEGMENT_FRACTION * horizon * record.fs))
            rule = f"a third of the start model's predictability horizon ({horizon:.4g} s)"
        elif len(start.equilibria.stable) > 1:
            length = self._short_length(start, record)
            rule = (
                f"multiple shooting on {length / record.fs:.3g}-s segments: the start model has "
                f"{len(start.equilibria.stable)} stable equilibria, and a single free run over wells it may "
                "cross differently has local minima far from the truth"
            )
        else:
            length, rule = record.n, "one segment: the start model's free run stays predictable over the record"

        # initial states of the segments from the data: z, the velocity through the shared filter, memory paths
        v = record.v if record.is_measured("v") else derivatives.differentiate(record.z, record.fs, order=1)[0]
        memory = [i for i, t in enumerate(model.terms) if t.is_memory]
        paths = [model.terms[i].evaluate(record.z) for i in memory]
        states = np.column_stack([record.z, v] + paths)
        state_scales = np.array([np.std(record.z), np.std(v)] + [max(float(np.std(w)), 1e-300) for w in paths])

        params: list[Parameter] = [Parameter("theta", i, name=n) for i, n in enumerate(model.names)]
        if mass is None:
            params.append(Parameter("mass", name="mass"))
        for i in shaped:
            term = model.terms[i]
            params += [Parameter("shape", i, j, f"{term.name}:{s}") for j, s in enumerate(term.shape_names)]
        scales = []
        for p in params:
            if p.kind == "theta":
                se = (start.standard_errors or {}).get(model.names[p.term])
                x = abs(theta0[p.term])
                scales.append(x if x > 0 else (se if se else 1.0))
            elif p.kind == "mass":
                scales.append(m0)
            else:
                x = abs(model.terms[p.term].shapes[p.shape])
                scales.append(x if x > 0 else float(np.std(record.z)))
        fine = fine_force(record.f, record.force_hold, q)

        def setup(length: int, global_values: np.ndarray | None, first_state: np.ndarray | None) -> Problem:
            length = max(int(length), MIN_SEGMENT)
            starts = np.arange(0, record.n, length)
            if starts.size > 1 and record.n - starts[-1] < length // 2:
                starts = starts[:-1]  # a short tail joins the last segment
            state0 = states[starts].copy()
            if first_state is not None:
                state0[0] = first_state
            prob = Problem(
                model,
                record,
                params,
                theta0,
                m0 if mass is None else mass,
                starts,
                state0,
                channels,
                q,
                fine,
                np.asarray(scales),
                state_scales,
                self.settings["continuity_weight"],
            )
            if global_values is not None:
                prob.set_globals(global_values)
            prob.dense_limit = DENSE_LIMIT if self._solver(prob) == "exact" else 0  # LSMR: the sparse one
            prob.refine_start()
            return prob

        stages = []
        short_fit = None
        problem = setup(length, None, None)
        if problem.K == 1 and seconds is None:
            # a free run that misses the data by much starts far from the optimum's basin (e.g. different well
            # transitions of a double well): fit short segments first, then the whole record from there
            try:
                r0 = problem._evaluate(problem.start())[0]
            except SimulationError as exc:
                raise IdentificationError(f"oe: the start model ({method}) diverges in a free run: {exc}") from None
            miss = float(np.sqrt(np.mean(r0[: problem.rows_data] ** 2)))
            if miss > DIRECT_LIMIT:
                short = self._short_length(start, record)
                if short < record.n // 2:
                    pre = setup(short, None, None)
                    res = self._solve(pre, method)
                    short_fit = (pre, res)
                    stages.append(
                        self._stage_info(
                            pre,
                            res,
                            f"short segments first: the start model's free run misses by {100 * miss:.3g} % of std(z)",
                        )
                    )
                    globals_, first = pre.globals_of(res.x), pre.states_of(res.x)[0]
                    # the start model may have been more predictable than the fitted one (a damping biased
                    # high): measure the horizon again before fitting the whole record in one free run
                    fitted, theta1, mass1, _, _ = pre.unpack(res.x)
                    try:
                        again = predictability_horizon(
                            fitted, theta1, mass1, record, oversample=q, quantile=HORIZON_QUANTILE
                        )
                    except SimulationError:
                        again = None
                    if again is not None:
                        horizon = again
                        length = int(round(SEGMENT_FRACTION * horizon * record.fs))
                        rule = (
                            f"a third of the predictability horizon ({horizon:.4g} s) of the model fitted on "
                            "short segments"
                        )
                    problem = setup(length, globals_, first)
        res = self._solve(problem, method)
        stages.append(self._stage_info(problem, res, rule))
        if short_fit is not None and problem.K < short_fit[0].K:
            miss_short, miss_whole = _data_rms(*short_fit), _data_rms(problem, res)
            if miss_whole > WHOLE_RECORD_RATIO * miss_short:
                problem, res = short_fit
                rule = (
                    f"short segments: the longer free run misses the data by {100 * miss_whole:.3g} % of std(z) "
                    f"against {100 * miss_short:.3g} % on the short segments (a local minimum), so the short "
                    "segments' answer is kept"
                )
                stages.append({"segments": int(problem.K), "rule": rule})
        if seconds is None and problem.K > 1:
            # multiple shooting that stays far above the measurement noise has segments whose states are
            # stuck in a wrong well: shorter segments, from the current answer, until it reaches the noise
            floor = float(
                np.sqrt(
                    np.mean(
                        [
                            (
                                derivatives.noise_sd(getattr(record, c), record.fs)
                                / max(float(np.std(getattr(record, c))), 1e-300)
                            )
                            ** 2
                            for c in channels
                        ]
                    )
                )
            )
            for _ in range(MAX_HALVINGS):
                miss = _data_rms(problem, res)
                length = int(np.diff(np.append(problem.starts, record.n)).min()) // 2
                if miss <= NOISE_RATIO * floor or length < MIN_SEGMENT:
                    break
                halved = setup(length, problem.globals_of(res.x), None)
                res_h = self._solve(halved, method)
                info = self._stage_info(
                    halved,
                    res_h,
                    f"segments halved to {length / record.fs:.3g} s: the fit "
                    f"missed the data by {100 * miss:.3g} % of std against a noise floor of "
                    f"{100 * floor:.3g} %",
                )
                stages.append(info)
                if _data_rms(halved, res_h) >= miss:  # no better with shorter segments: keep the answer we had
                    info["rule"] += "; not kept (no closer to the data)"
                    break
                problem, res, rule = halved, res_h, info["rule"]
        # the start model on the final segments, from the data's states: the "before" figure
        before = Problem(
            model,
            record,
            params,
            theta0,
            m0 if mass is None else mass,
            problem.starts,
            states[problem.starts],
            channels,
            q,
            fine,
            np.asarray(scales),
            state_scales,
            1.0,
        )
        before.sensitivities = False  # its residual alone
        r0 = before.residual(None)
        u = res.x
        run, refined, order = problem.run_at(u)
        _, theta, mass_fit, states, _ = problem.unpack(u)
        residual = problem.residual(u)
        se_u, se_iid_u, corr, batches = profiled_standard_errors(problem, residual, u)
        x = u * problem.scale
        se = se_u * problem.scale[: problem.G]
        se_iid = se_iid_u * problem.scale[: problem.G]

        # report: coefficients keyed by the refined model, shapes, figures of the fit
        names = [refined.names[order[i]] for i in range(len(model.terms))]
        coefficients = refined.as_dict(theta)
        standard_errors = {names[p.term]: float(se[k]) for k, p in enumerate(params) if p.kind == "theta"}
        mass_se = next((float(se[k]) for k, p in enumerate(params) if p.kind == "mass"), None)
        shapes: dict[str, Any] = {}
        for k, p in enumerate(params):
            if p.kind == "shape":
                term = model.terms[p.term]
                entry = shapes.setdefault(term.name, {"term": names[p.term], "values": {}, "standard_errors": {}})
                entry["values"][term.shape_names[p.shape]] = float(x[k])
                entry["standard_errors"][term.shape_names[p.shape]] = float(se[k])
        data0 = r0[: problem.rows_data].reshape(record.n, problem.C)
        starts = problem.starts
        data1 = residual[: problem.rows_data].reshape(record.n, problem.C)
        rms0 = np.sqrt(np.mean(data0**2, axis=0)) * problem.channel_scale
        rms1 = np.sqrt(np.mean(data1**2, axis=0)) * problem.channel_scale
        defect = residual[problem.rows_data :]
        warnings = []
        if refined.terms != model.terms:
            changed = ", ".join(
                f"{model.names[i]} -> {names[i]}" for i in range(len(names)) if model.names[i] != names[i]
            )
            warnings.append(f"oe refined shape parameters: {changed} (the coefficients are those of the refined terms)")
        diagnostics = {
            "init": method,
            "init_coefficients": dict(start.coefficients),
            "init_mass": m0,
            "shapes": shapes,
            "segments": int(problem.K),
            "segment_seconds": float(np.mean(np.diff(np.append(starts, record.n)))) / record.fs,
            "segment_rule": rule,
            "stages": stages,
            "predictability_horizon_s": horizon,
            "outputs": list(channels),
            "oversample": q,
            "rms_error_start": {c: float(x) for c, x in zip(channels, rms0, strict=True)},
            "rms_error_fit": {c: float(x) for c, x in zip(channels, rms1, strict=True)},
            "continuity_defect_max": float(np.max(np.abs(defect)) / problem.weight) if defect.size else 0.0,
            "initial_state": [float(s) for s in states[0, :2]],
            "nfev": int(sum(st.get("nfev", 0) for st in stages)),
            "correlation_length_samples": corr,
            "standard_error_batches": batches,
            "standard_errors_iid": {names[p.term]: float(se_iid[k]) for k, p in enumerate(params) if p.kind == "theta"},
            "mass_standard_error": mass_se,
        }
        return Estimate(
            coefficients=coefficients,
            mass=None if mass is not None else float(mass_fit),
            standard_errors=standard_errors,
            mass_standard_error=mass_se,
            diagnostics=diagnostics,
            warnings=warnings,
            model=refined if refined.terms != model.terms else None,
        )

    # ------------------------------------------------------------------ the optimiser
    def _solve(self, problem: Shooting, method: str) -> Any:
        """:func:`scipy.optimize.least_squares` (trust-region reflective) on one problem; raises when it fails."""
        from scipy import optimize

        u0 = problem.start()
        if not np.all(np.isfinite(problem.residual(u0))) or problem.diverged:
            raise IdentificationError(f"oe: the start model ({method}) diverges in a free run of the record")
        lower, upper = problem.bounds(u0)
        tol = self.settings["tol"]
        limit = self.settings["max_nfev"]
        # a terminal-only line when the caller asked for progress (nlid.runtime.progress): evaluations of the free run
        line = progress_line("oe", total=limit, unit="free runs")
        stage = f"{problem.K} segment(s)"

        def residual(u: np.ndarray) -> np.ndarray:
            r = problem.reduced_residual(u)
            line.update(line.done + 1, note=f"{stage}, cost {float(r @ r):.4g}")
            return r

        try:
            with line:
                res = optimize.least_squares(
                    residual,
                    u0,
                    jac=problem.reduced_jacobian,
                    bounds=(lower, upper),
                    method="trf",
                    x_scale=1.0 if self._solver(problem) == "exact" else "jac",
                    tr_solver=self._solver(problem),
                    tr_options={}
                    if self._solver(problem) == "exact"
                    else {"atol": 1e-10, "btol": 1e-10, "maxiter": 2000},
                    ftol=tol,
                    xtol=tol,
                    gtol=tol,
                    max_nfev=limit,
                )
        except (ValueError, np.linalg.LinAlgError) as exc:
            raise IdentificationError(f"oe: the optimiser failed: {exc}") from None
        if res.status == 0:
            r0 = problem.residual(u0)
            raise IdentificationError(
                f"oe: the optimiser did not converge in {self.settings['max_nfev']} evaluations of the free run "
                f"({problem.K} segment(s); cost {2 * res.cost:.4g} from {float(r0 @ r0):.4g}); raise max_nfev or "
                "loosen tol"
            )
        if not res.success:
            raise IdentificationError(f"oe: the optimiser failed: {res.message}")
        return res

    @staticmethod
    def _solver(problem: Problem) -> str:
        """``"exact"`` (dense Jacobian, SVD) while the reduced problem is small (:data:`EXACT_LIMIT`), else
        ``"lsmr"`` (sparse)."""
        return "exact" if problem.reduced_rows * problem.size**2 <= EXACT_LIMIT else "lsmr"

    @staticmethod
    def _short_length(start: Any, record: Record) -> int:
        """Samples of a short segment: :data:`SHORT_PERIODS` periods of the fastest mode, at most
        :data:`MAX_SHORT_SEGMENTS` segments."""
        short = int(round(SHORT_PERIODS * record.fs / _fastest_frequency(start, record)))
        return max(short, record.n // MAX_SHORT_SEGMENTS)

    @staticmethod
    def _stage_info(problem: Problem, res: Any, rule: str) -> dict[str, Any]:
        return {
            "segments": int(problem.K),
            "segment_samples": int(np.diff(np.append(problem.starts, problem.record.n)).min()),
            "rule": rule,
            "nfev": int(res.nfev),
            "njev": int(res.njev or 0),
            "cost": float(2 * res.cost),
            "message": str(res.message),
        }
