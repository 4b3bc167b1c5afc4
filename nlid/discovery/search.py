"""The search: residual -> missing effect -> add it -> error before and after.

1. Identify the declared model (taken literally: no default terms are added) with the chosen identifier
   through :func:`nlid.identify`, on the estimation record.
2. Compute its residual ``r = R_e - R_hat(z, v)`` (``R_e = f - m a``, Eq. 25) and
   epsilon (Eq. 26) on the estimation and held-out records, in one equation band.
3. Add each candidate of the library to the current model, identify it with the same identifier and score it
   on the held-out record (:mod:`nlid.discovery.trials`, :mod:`nlid.discovery.evidence`).
4. Accept the best candidate if it passes the rule, re-identify (with the ``px(z)`` fixed point of
   :func:`nlid.identify` when the model uses ``px``), and recompute the residuals.
5. Repeat until no candidate is accepted or ``max_steps`` effects were added.

The free-run simulation error on the held-out record is reported for the declared model and after each step:
it is :func:`nlid.scoring.free_run_error` (with its chaos check), the same number ``nlid study`` reports for
the same model and record. Every round runs on the shared pool (:func:`nlid.runtime.parallel.kernel_threads`).

:class:`Discovery` holds the settings (as emcee's ``EnsembleSampler`` does); :meth:`Discovery.steps` is a
generator that yields a :class:`SearchState` after each round, so that the caller shows progress or stops
early; :meth:`Discovery.finish` turns a state into the :class:`~nlid.discovery.result.DiscoveryResult` and
:meth:`Discovery.run` drains the generator and finishes. Two small objects replace half of the keywords of
:func:`discover` (:mod:`nlid.discovery.inputs`): a :class:`CandidateLibrary` (which effects may be added)
and a :class:`Split` (estimation / hold-out, and a validation record that informs but never decides)::

    search = Discovery("rfs", mass=0.2, split=Split(0.25), library=CandidateLibrary.select("coulomb, viscous"))
    for state in search.steps(record, "1, z, z^3, v"):
        print(state.step.effect if state.step else state.stop_reason)
    result = search.finish(state)
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from typing import Any

import numpy as np

from ..base.validate import check_cutoff, check_mass
from ..contract.methods import choose_method, choose_refiner
from ..contract.registry import Registry, default_registry
from ..data.forcehold import force_hold_source
from ..data.record import Record
from ..errors import IdentificationError, InputError
from ..model.terms import Model
from ..runtime.parallel import kernel_threads
from ..scoring import TransientRule
from ..signal import derivatives
from ..signal.glitches import find_glitches, glitch_note, reported_by_caller
from .crossfit import PredictionRule
from .evidence import AcceptanceRule, Evidence, acceptance_rule, judge
from .inputs import DEFAULT_HOLDOUT, CandidateLibrary, Split
from .judge import Judge, judging_options
from .library import Candidate
from .paths import InputPathCandidate, held_force_note
from .probes import MIN_STRUCTURE, describe_remaining
from .result import DiscoveryResult, Stage, Step
from .state import SearchSetup, SearchState
from .trials import (
    Context,
    fit_stage,
    gate,
    injects_energy,
    prune,
    refine_stage,
    refit_description,
    residual_view,
    root_mean_square,
    test_candidate,
    test_dictionary,
    test_input_path,
    test_mass,
    validation_scores,
    with_free_run,
    with_probes,
)

__all__ = [
    "DEFAULT_MAX_STEPS",
    "Discovery",
    "discover",
]

#: Most effects added by one run.
DEFAULT_MAX_STEPS = 5
#: The stop reason of a search that added ``max_steps`` effects.
MAX_STEPS_REACHED = "maximum number of steps reached"
Progress = Callable[[str], None]


def _quiet(_message: str) -> None:
    return None


class Discovery:
    """A search for the effects a declared model lacks (see the module docstring).

    The constructor only checks and stores the settings; :meth:`steps` (or :meth:`run`) takes the data.

    Parameters
    ----------
    method
        Identifier name; default :func:`nlid.contract.methods.choose_method` (the preferred installed one).
    mass
        Known mass (kg); ``None``: estimated by the identifier.
    split
        Estimation / hold-out division, the validation record and the free runs' rule (default :class:`Split`).
    library
        Candidate effects (default :meth:`CandidateLibrary.select`: all of them).
    accept
        Acceptance rule (default :class:`~nlid.discovery.evidence.AcceptanceRule`). Its old name ``rule=``
        is refused unless given an ``AcceptanceRule`` (then it warns): ``rule`` is the transient rule
        everywhere else, here ``split``'s ``freerun_rule``.
    max_steps
        Most effects to add.
    cutoff
        Equation band (Hz) for estimated channels; default :func:`nlid.signal.derivatives.suggest_cutoff` of
        the estimation record's displacement, used for both records.
    structure
        Cross-fitted held-out fraction of the residual variance a probe must predict to count as
        remaining structure (:data:`nlid.discovery.probes.MIN_STRUCTURE`).
    options
        Identifier options.
    registry
        Where to find the identifiers (default: installed plugins).
    simulate
        Compute the free-run simulation error on the held-out record.
    views
        Keep the residual views for the report.
    refine
        Refine the final model with the preferred refining identifier (``refines = True``, e.g. the
        output-error ``oe``: free-run error, shape parameters included), started from ``method``, fitted on
        the whole record once the structure is chosen; :attr:`DiscoveryResult.refined` holds it. The
        prediction check then judges candidates by the refined fits (what the search delivers).
    prediction
        When a candidate improves the cross-fitted held-out prediction (default
        :class:`~nlid.discovery.crossfit.PredictionRule`: two blocks, every block better, the pooled error
        1 % lower); ``PredictionRule(enabled=False)`` judges by the equation error alone.

    Raises
    ------
    InputError
        Bad method, options, mass or ``max_steps``.
    """

    def __init__(
        self,
        method: str | None = None,
        *,
        mass: float | None = None,
        split: Split | None = None,
        library: CandidateLibrary | None = None,
        accept: AcceptanceRule | None = None,
        max_steps: int = DEFAULT_MAX_STEPS,
        cutoff: float | None = None,
        structure: float = MIN_STRUCTURE,
        options: dict[str, Any] | None = None,
        registry: Registry | None = None,
        simulate: bool = True,
        views: bool = True,
        refine: bool = False,
        prediction: PredictionRule | None = None,
        rule: AcceptanceRule | None = None,
    ) -> None:
        accept = acceptance_rule(accept, rule)
        if int(max_steps) < 0:
            raise InputError(f"max_steps must be >= 0, got {max_steps}")
        self.library = library if library is not None else CandidateLibrary.select()
        self.registry = registry or default_registry()
        if method is None:
            method, notes = choose_method(mass, self.registry)
        else:
            notes = [f"method {method!r} given"]
        self.identifier = self.registry.create(method, options)
        mass = check_mass(mass)
        if mass is None and getattr(self.identifier, "needs_mass", False):
            raise InputError(f"method {method!r} cannot estimate the mass: give mass= (in kg)")
        self.method, self.method_notes, self.mass = method, tuple(notes), mass
        self.split = split if split is not None else Split()
        if prediction is not None and not isinstance(prediction, PredictionRule):
            raise InputError(f"prediction= must be a PredictionRule, got {type(prediction).__name__}")
        self.prediction = prediction or PredictionRule()
        # the equation error screens and ranks; where the prediction decides, the screen is wider
        self.rule = accept or (
            AcceptanceRule(min_explained=self.prediction.screen) if self.prediction.enabled else AcceptanceRule()
        )
        self.max_steps = int(max_steps)
        self.cutoff, self.structure = cutoff, float(structure)
        self.simulate, self.views, self.refine = simulate, views, refine

    def __repr__(self) -> str:
        return (
            f"Discovery({self.method!r}, mass={self.mass!r}, max_steps={self.max_steps}, "
            f"candidates={len(self.library.candidates)})"
        )

    # ------------------------------------------------------------------ the search
    def steps(
        self, record: Record, declared: str | Iterable[str] | Model, *, progress: Progress | None = None
    ) -> Iterator[SearchState]:
        """Identify the declared model, then yield the state after each round.

        A round tests every candidate on the current model and accepts the best one that passes the
        rule (its state has a new :attr:`SearchState.step`), or accepts none (its state is
        :attr:`~SearchState.done`, with the ranking and the stop reason). The last state is done: the
        search stopped by itself, or added ``max_steps`` effects. The data are checked and the declared
        model identified when this is called; each round runs when the next state is asked for.

        Parameters
        ----------
        record
            The data (estimation record, or the whole record when the split's hold-out is a fraction).
        declared
            The complete declared model, taken literally: ``"v, 1"`` is two terms (no default ``1, z,
            v`` are added).
        progress
            Called with one line per stage (e.g. ``print`` to stderr).

        Raises
        ------
        InputError
            Bad terms, hold-out or cutoff.
        IdentificationError
            The declared model itself cannot be identified.
        """
        say = progress or _quiet
        # each unit of work on the shared pool (steps() and run() give the same numbers); glitches said once
        with kernel_threads(), reported_by_caller():
            state = self._start(record, declared, say)
        return self._rounds(state, say)

    def run(
        self, record: Record, declared: str | Iterable[str] | Model, *, progress: Progress | None = None
    ) -> DiscoveryResult:
        """The whole search: every round of :meth:`steps`, then :meth:`finish` (each on the shared pool)."""
        *_, last = self.steps(record, declared, progress=progress)  # steps() yields at least once
        return self.finish(last, progress=progress)

    def _start(self, record: Record, declared: str | Iterable[str] | Model, say: Progress) -> SearchState:
        started = time.perf_counter()
        model0 = declared if isinstance(declared, Model) else Model.from_spec(declared, defaults=False)
        estimation, held, held_text = self.split.divide(record)
        cutoff = self.cutoff
        if cutoff is None:
            cutoff = derivatives.suggest_cutoff(estimation.z, estimation.fs)
        else:
            cutoff = check_cutoff(cutoff, estimation.fs)
        rules = (self.rule, self.structure, self.split.freerun_rule)  # Split read its rule with rule_from_spec
        ctx = Context(estimation, held, self.identifier, float(cutoff), *rules, whole=record)  # type: ignore[arg-type]
        run = SearchSetup(
            context=ctx,
            method=self.method,
            method_notes=self.method_notes,
            declared=model0,
            held_text=held_text,
            source=str(record.meta.get("source", "")),
            holdout_source=str(held.meta.get("source", "")),
            units={"f": record.units["f"], "z": record.units["z"]},
            library=self.library,
            use_mass=self.library.mass and not getattr(self.identifier, "needs_mass", False),
            z_range=(float(estimation.z.min()), float(estimation.z.max())),
            started=started,
            judge=Judge.for_search(
                self.prediction, record, self._prediction_fitter(), float(cutoff), self.split.freerun_rule
            ),
        )
        say(f"identifying the declared model ({model0}) with {self.method}")
        current = fit_stage(ctx, model0, self.mass)
        view = residual_view(estimation, current, ctx.cutoff, "declared model")
        return SearchState(run, (current,), views=(view,))

    def _prediction_fitter(self) -> Any:
        """What fits a model for the prediction check: the search's identifier, or the refiner when refining."""
        if self.refine:
            name = choose_refiner(self.registry)
            return self.registry.create(name, judging_options(self.registry.get(name), self.method))
        return self.identifier

    def _rounds(self, state: SearchState, say: Progress) -> Iterator[SearchState]:
        if self.max_steps == 0:
            yield dataclasses.replace(state, stop_reason=MAX_STEPS_REACHED)
            return
        for number in range(1, self.max_steps + 1):
            # not held across the yield: the caller's code between rounds keeps its threads
            with kernel_threads(), reported_by_caller():
                state = self._round(state, number, say)
            if not state.done and number == self.max_steps:
                state = dataclasses.replace(state, stop_reason=MAX_STEPS_REACHED)
            yield state
            if state.done:
                return

    def _round(self, state: SearchState, number: int, say: Progress) -> SearchState:
        """One round: test every candidate on the current model, accept the best that passes, or stop."""
        run, ctx = state.run, state.run.context
        current = with_probes(ctx, state.stage)
        stages = (*state.stages[:-1], current)
        remaining = current.remaining
        assert remaining is not None
        view = state.views[-1]
        rms = {"z": float(np.std(view.z)), "v": root_mean_square(view.v)}
        pool = run.library.candidates
        say(
            f"step {number}: eps {current.scores.eps:.3g} % (held-out {current.scores.eps_holdout:.3g} %); "
            f"testing {len(pool)} candidates"
        )
        tested: list[Evidence] = []
        fits: dict[str, Stage] = {}

        def consider(evidence: Evidence, fit: Stage | None, bad: str) -> None:
            if fit is not None:
                bad = bad or injects_energy(fit, current, view.z, view.v)
                judge(evidence, current.scores, fit.scores, view.n_eff, view.tau_samples, ctx.rule)
                fits[evidence.effect] = fit
                evidence.passes["physical"] = not bad
                if bad:
                    evidence.status, evidence.reason = "rejected", bad + "; " + evidence.reason
            tested.append(evidence)

        added = state.added
        for cand in pool:
            if cand.name in added:
                tested.append(Evidence(cand.name, status="not applicable", reason="already added by this run"))
                continue
            why = gate(remaining, cand.requires)
            if why:
                tested.append(Evidence(cand.name, status="not applicable", reason=why))
                continue
            if isinstance(cand, InputPathCandidate):
                consider(*test_input_path(ctx, current, cand))
                continue
            consider(*test_candidate(ctx, current, cand, rms, run.z_range))
        if run.use_mass and current.given_mass is not None:
            why = gate(remaining, ("acceleration",))
            if why:
                tested.append(Evidence("mass", status="not applicable", reason=why))
            else:
                consider(*test_mass(ctx, current))

        def told(message: str) -> None:
            say(f"step {number}: {message}")

        ranking, accepted, current = run.judge.judged(current, tested, fits, told)
        if accepted is None and run.library.dictionary and not gate(remaining, ("z", "v", "z,v")):
            # open world: when nothing named passes, let a sparse regression on the dictionary propose terms
            say(f"step {number}: no named candidate passes; searching the automatic dictionary")
            consider(*test_dictionary(ctx, current, run.z_range))
            ranking, accepted, current = run.judge.judged(current, tested, fits, told)
        stages = (*state.stages[:-1], current)
        if accepted is None:
            best = ranking[0] if ranking and ranking[0].explained_holdout is not None else None
            stop_reason = "no candidate passes the acceptance rule" + (
                f" (best: {best.effect}, {best.reason})" if best else ""
            )
            say(stop_reason)
            return dataclasses.replace(state, stages=stages, ranking=tuple(ranking), stop_reason=stop_reason)
        after = fits[accepted.effect]
        notes: list[str] = []
        if accepted.effect == "mass":
            from ..base.dimensions import mass_unit
            from ..identified.plausibility import mass_hint

            units = ctx.estimation.units
            unit = mass_unit(str(units.get("f", "N")), str(units.get("z", "m")))
            notes.append(
                f"the given mass looks wrong: the data say m = {after.mass:.4g} {unit} (given: {current.mass:.4g} "
                f"{unit}; {mass_hint(current.mass, after.mass, unit)}); the mass is estimated "
                "from here on"
            )
        held = held_force_note(after.path, ctx.estimation)
        if held:
            notes.append(held)
        if after.model.uses_px:
            # re-identify with the px(z) fixed point instead of the screening's fixed roots
            try:
                after = fit_stage(ctx, after.model.with_px_roots(None), after.given_mass)
            except IdentificationError as exc:
                notes.append(f"px(z) fixed point failed ({exc}); kept the roots of the current stiffness")
        say(f"step {number}: accepted {accepted.effect} ({', '.join(accepted.terms)}): {accepted.reason}")
        after, pruned = prune(ctx, after, state.steps, accepted.effect)
        for note in pruned:
            say(f"step {number}: {note}")
        step = Step(accepted.effect, list(accepted.terms), current, after, accepted, ranking, notes + pruned)
        view = residual_view(ctx.estimation, after, ctx.cutoff, f"after step {number}: {accepted.effect}")
        return dataclasses.replace(
            state, stages=(*stages, after), steps=(*state.steps, step), views=(*state.views, view)
        )

    # ------------------------------------------------------------------ the result
    def finish(self, state: SearchState, *, progress: Progress | None = None) -> DiscoveryResult:
        """The result of a search that reached ``state``: probes, free runs, validation scores, refinement.

        ``state`` is usually the last one :meth:`steps` yielded; a search the caller stopped early says so
        in its stop reason.
        """
        with kernel_threads(), reported_by_caller():
            return self._finish(state, progress or _quiet)

    def _finish(self, state: SearchState, say: Progress) -> DiscoveryResult:
        run, ctx = state.run, state.run.context
        validation = self.split.validation
        stop_reason = state.stop_reason or f"stopped by the caller after {len(state.steps)} step(s)"
        say("remaining-structure probes")
        states = [stage if stage.remaining is not None else with_probes(ctx, stage) for stage in state.stages]
        remaining = states[-1].remaining
        assert remaining is not None
        clean = "" if remaining.structured else "the final model is "
        stop_reason = f"{stop_reason}; {clean}" + describe_remaining(remaining)
        glitches = find_glitches(ctx.whole_record)
        stop_reason += glitch_note(glitches) if glitches else ""  # what no probe can tell from an effect
        if self.simulate:
            say("free-run simulation on the held-out record")
            states = [with_free_run(ctx, stage) for stage in states]
        if validation is not None:
            say("scores on the validation record")
            states = [validation_scores(ctx, st, validation, self.simulate) for st in states]
        steps = [dataclasses.replace(step, before=states[k], after=states[k + 1]) for k, step in enumerate(state.steps)]
        refined, refine_failed = None, None
        if self.refine:
            name = choose_refiner(self.registry)
            say(f"refining the final model with {name} (output error on the free run)")
            refiner = self.registry.create(name, {"init": run.method})
            try:
                refined = refine_stage(ctx, states[-1], refiner, self.simulate, validation)
            except IdentificationError as exc:  # the search's result stands; say why it is not refined
                refine_failed = f"the refinement by {name} failed ({exc}): the search's own fit is reported"
                say(refine_failed)
        estimation, held = ctx.estimation, ctx.holdout
        info = {
            "samples_estimation": estimation.n,
            "samples_holdout": held.n,
            "holdout": run.held_text,
            "fs_hz": estimation.fs,
            "band_hz": ctx.cutoff,
            "units": dict(run.units),
            "force_hold": estimation.force_hold,
            "force_hold_source": force_hold_source(estimation.meta),
            "data_warnings": [g.describe() for g in glitches],
            "source": run.source,
            "holdout_source": run.holdout_source,
            "candidates": run.library.names,
            "validation": None
            if validation is None
            else f"{validation.n} samples, {validation.meta.get('source', 'given')}",
            "z_range": list(run.z_range),
            "z_range_validation": None
            if validation is None
            else [float(validation.z.min()), float(validation.z.max())],
            "max_steps": self.max_steps,
            "prediction_rule": {
                **run.judge.to_dict(),
                "fitter": "the refiner (output error)" if self.refine else f"the search's identifier ({run.method})",
            },
            "input_path": states[-1].path.to_dict(),
            "freerun_rule": states[-1].holdout.freerun_rule,
            "freerun_rule_validation": None if validation is None else states[-1].validation.freerun_rule,
            "refined_on": None if refined is None else refit_description(ctx),
            "refine_failed": refine_failed,
            "seconds": time.perf_counter() - run.started,
        }
        return DiscoveryResult(
            method=run.method,
            method_notes=list(run.method_notes),
            declared=list(run.declared.names),
            states=states,
            steps=steps,
            final_ranking=list(state.ranking),
            stop_reason=stop_reason,
            rule=ctx.rule,
            views=list(state.views) if self.views else [],
            info=info,
            refined=refined,
        )


def discover(
    record: Record,
    declared: str | Iterable[str] | Model,
    method: str | None = None,
    *,
    mass: float | None = None,
    holdout: float | Record = DEFAULT_HOLDOUT,
    candidates: str | Iterable[str] | None = None,
    extra_candidates: Iterable[Candidate | str] = (),
    plugins: bool | Sequence[Candidate] = True,
    accept: AcceptanceRule | None = None,
    max_steps: int = DEFAULT_MAX_STEPS,
    cutoff: float | None = None,
    structure: float = MIN_STRUCTURE,
    validation: Record | None = None,
    options: dict[str, Any] | None = None,
    registry: Registry | None = None,
    simulate: bool = True,
    views: bool = True,
    progress: Callable[[str], None] | None = None,
    refine: bool = False,
    freerun_rule: TransientRule | str | Mapping[str, Any] | None = None,
    prediction: PredictionRule | None = None,
    rule: AcceptanceRule | None = None,
) -> DiscoveryResult:
    """Find the effects a declared model lacks, one at a time (see the module docstring).

    A thin wrapper: ``Discovery(method, ..., split=Split(holdout, validation),
    library=CandidateLibrary.select(candidates, extra_candidates, plugins=plugins)).run(record, declared)``.

    Parameters
    ----------
    record
        The data (estimation record, or the whole record when ``holdout`` is
        a fraction).
    declared
        The complete declared model, taken literally: ``"v, 1"`` is two terms
        (no default ``1, z, v`` are added).
    method
        Identifier name; default :func:`nlid.contract.methods.choose_method`.
    mass
        Known mass (kg); ``None``: estimated by the identifier.
    holdout
        Fraction of ``record`` held out (its last part), or a separate
        held-out record.
    candidates
        Names of candidates to test (default: all): the library's, plugins',
        and the loop's own ``mass`` (re-estimate a given mass) and
        ``dictionary`` (sparse regression on an automatic dictionary, tried
        when no named candidate passes).
    extra_candidates
        User candidates (:class:`Candidate` or ``"NAME=TERMS"``).
    plugins
        Include candidates from installed plugins.
    accept
        Acceptance rule (default :class:`AcceptanceRule`).
    max_steps
        Most effects to add.
    cutoff
        Equation band (Hz) for estimated channels; default
        :func:`nlid.signal.derivatives.suggest_cutoff` of the estimation record's
        displacement, used for both records.
    structure
        Cross-fitted held-out fraction of the residual variance a probe must
        predict to count as remaining structure
        (:data:`nlid.discovery.probes.MIN_STRUCTURE`).
    validation
        A record on which every model is also scored (epsilon, force
        residual and free-run error) without taking part in any decision:
        e.g. a benchmark's validation set, whose excitation may differ from
        the estimation record's.
    options
        Identifier options.
    registry
        Where to find the identifiers (default: installed plugins).
    simulate
        Compute the free-run simulation error on the held-out record.
    views
        Keep the residual views for the report.
    progress
        Called with one line per stage (e.g. ``print`` to stderr).
    refine
        Refine the final model with the refining identifier (``oe``: free-run error, shape parameters
        included), started from ``method``, on the whole record; :attr:`DiscoveryResult.refined` holds it.
    freerun_rule
        Transient rule of the held-out and validation free runs (``"window:50"``...; :class:`Split`), and of
        the cross-fitted prediction's blocks.
    prediction
        When a candidate improves the cross-fitted held-out prediction
        (:class:`~nlid.discovery.crossfit.PredictionRule`; default: two blocks, every block better, the pooled
        error 1 % lower; ``PredictionRule(enabled=False)``: the equation error alone decides).
    rule
        The old name of ``accept=``: an :class:`AcceptanceRule` is taken with a :class:`DeprecationWarning`,
        anything else is refused (the transient rule is ``freerun_rule=``).

    Returns
    -------
    DiscoveryResult

    Raises
    ------
    InputError
        Bad terms, candidates, method, options, mass or hold-out.
    IdentificationError
        The declared model itself cannot be identified.
    """
    accept = acceptance_rule(accept, rule)
    library = CandidateLibrary.select(candidates, extra_candidates, plugins=plugins)
    search = Discovery(
        method,
        mass=mass,
        split=Split(holdout, validation, freerun_rule),
        library=library,
        accept=accept,
        max_steps=max_steps,
        cutoff=cutoff,
        structure=structure,
        options=options,
        registry=registry,
        simulate=simulate,
        views=views,
        refine=refine,
        prediction=prediction,
    )
    return search.run(record, declared, progress=progress)
