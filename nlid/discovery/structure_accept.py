"""Which candidate a structure's search accepts: the ranking, the rule for noisy records, the free-run check.

:func:`rank` applies the :class:`~nlid.discovery.evidence.AcceptanceRule` to one round's candidates (the
one with the fewest parameters among those within :data:`~nlid.discovery.evidence.PARSIMONY` of the best).
On a noisy record the residual is mostly noise and a real element explains less than the rule's
``min_explained``: given the remaining-structure probes, :func:`rank` also lets a candidate pass that
captures what its connection's probes find predictable (:func:`captures`), and :func:`confirmed` keeps it
only when the held-out free run improves with it (:func:`free_run_error`).

Every other accepted candidate must not worsen the prediction either (:func:`judged`, issue 31: "a discover step
that worsens the cross-fitted held-out free run is never accepted", as :mod:`nlid.discovery.crossfit` does for
one DOF): the models before and after, each fitted on one part of the selection record, run free over the other
part (both ways), and a candidate whose pooled error is larger is refused in favour of the next passing one.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np

from ..estimation.joint import joint_least_squares
from ..model.elements import Element, ElementSet
from ..scoring import SENSITIVITY_DELTA, SENSITIVITY_LIMIT
from .evidence import PARSIMONY, AcceptanceRule
from .structure_result import DOF_PROBES, ConnectionEvidence, StructureRemaining

__all__ = [
    "CAPTURE",
    "CHAOTIC_NOTE",
    "MIN_FREERUN_GAIN",
    "rank",
    "captures",
    "confirmed",
    "judged",
    "prediction_percent",
    "prediction_steps",
    "with_accepted",
    "with_velocity",
    "free_run_error",
    "rms",
]

#: Share of what the best remaining-structure probe on a connection explains that a candidate below the
#: rule's ``min_explained`` must explain to pass (:func:`rank`): the candidate then holds the structure the
#: flexible functions find there, and what it does not explain is noise.
CAPTURE = 0.8
#: Smallest relative drop of the held-out free-run error that confirms a candidate accepted below
#: ``min_explained`` (the one-DOF prediction rule's default gain, :class:`~nlid.discovery.crossfit.PredictionRule`).
MIN_FREERUN_GAIN = 0.01
#: What a stage's free-run note says when the model's free run is chaotic there (:func:`_chaotic`).
CHAOTIC_NOTE = (
    f"chaotic: two free runs started {SENSITIVITY_DELTA:g} std(z) apart part by more than "
    f"{100 * SENSITIVITY_LIMIT:g} % of std(z), so this error says little about the model (the search judges such "
    "a model by its k-step-ahead prediction)"
)


def rms(x: np.ndarray) -> np.ndarray:
    """RMS of each column of ``x`` (each DOF of a ``(samples, dofs)`` array)."""
    return np.sqrt(np.mean(np.asarray(x) ** 2, axis=0))


def with_velocity(record):
    """The record with its velocities: measured, or estimated from the displacements (once, for every run on it)."""
    return record if record.v is not None else record.with_derivatives()


def run_from_start(model, record, shift: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """The model's free run over ``record`` (its velocities present: :func:`with_velocity`) from its first measured
    state, the displacements moved by ``shift`` std(z): ``(z, v, a)``; ``None`` when the run diverges."""
    from ..simulation import SimulationError
    from ..simulation.structure import free_run

    z0 = np.asarray(record.z[0], dtype=float)
    if shift:
        z0 = z0 + shift * _std(record)
    try:
        run = free_run(
            model, record.f, record.fs, force_hold=record.force_hold, x0=(z0, np.asarray(record.v[0], dtype=float))
        )
    except SimulationError:
        return None
    return run if all(np.all(np.isfinite(x)) for x in run) else None


def _run(model, record, shift: float = 0.0) -> np.ndarray | None:
    """The displacements of :func:`run_from_start`; ``None`` when the run diverges."""
    run = run_from_start(model, record, shift)
    return None if run is None else run[0]


def _std(record) -> np.ndarray:
    """Each DOF's displacement standard deviation (1 where it is 0), the scale of the errors and of the shift."""
    std = np.std(record.z, axis=0)
    return np.where(std > 0, std, 1.0)


def free_run_error(model, record) -> tuple[tuple[float, ...], tuple[float, ...], str]:
    """The free-run error of a structural model on a record, per DOF.

    The model is simulated from the record's first sample (its measured displacement and the velocity measured
    or estimated there) under the recorded force, held as the record says.

    Returns
    -------
    tuple
        ``(rms, percent, note)``: the RMS error of each DOF's displacement (m), the same in % of that
        displacement's standard deviation, and how the run was made (``nan`` and the reason if it diverged).
    """
    from ..simulation import SimulationError
    from ..simulation.structure import free_run

    record = with_velocity(record)
    n = model.n_dofs
    nan = tuple([float("nan")] * n)
    x0 = (np.asarray(record.z[0], dtype=float), np.asarray(record.v[0], dtype=float))
    try:
        z, _, _ = free_run(model, record.f, record.fs, force_hold=record.force_hold, x0=x0)
    except SimulationError as exc:
        return nan, nan, f"diverged: {exc}"
    if not np.all(np.isfinite(z)):
        return nan, nan, "diverged"
    err = rms(z - record.z)
    std = np.std(record.z, axis=0)
    pct = tuple(float(100 * e / s) if s > 0 else float("nan") for e, s in zip(err, std, strict=True))
    note = (
        f"from the test part's first sample (measured state), force as recorded ({record.force_hold}), "
        f"{record.n} samples scored"
    )
    if _chaotic(model, record, z):
        note += f"; {CHAOTIC_NOTE}"
    return tuple(float(x) for x in err), pct, note


def rank(
    tested: list[ConnectionEvidence], rule: AcceptanceRule, probes: StructureRemaining | None = None
) -> tuple[tuple[ConnectionEvidence, ...], Any]:
    """The candidates best first, and the one accepted (``None``: none passes).

    With ``probes`` (the remaining-structure probes on the current model), a candidate below the rule's
    ``min_explained`` passes too when the residual of its DOFs is mostly noise but holds structure: its
    connection's probes find at least their threshold predictable (:data:`~nlid.discovery.probes.MIN_STRUCTURE`,
    measured against noise), the candidate explains at least :data:`CAPTURE` of what the best of them explains
    and at least that threshold itself, and its dBIC passes the rule.
    """
    fitted = sorted((e for e in tested if e.explained is not None), key=lambda e: -float(e.explained))
    rest = [e for e in tested if e.explained is None]
    if probes is not None:
        fitted = [captures(e, probes, rule) for e in fitted]
    passing = [e for e in fitted if e.status == "passes"]
    if not passing:
        return tuple(fitted + rest), None
    top = float(passing[0].explained)
    close = [e for e in passing if float(e.explained) >= top - PARSIMONY]
    chosen = min(close, key=lambda e: (e.parameters, -float(e.explained)))
    accepted = replace(chosen, status="accepted")
    ranked = tuple(accepted if e is chosen else e for e in fitted) + tuple(rest)
    return ranked, accepted


def with_accepted(current: ElementSet, accepted: ConnectionEvidence) -> ElementSet:
    """The elements ``current`` with the accepted candidate's terms added on its connection."""
    added = [Element(t, *accepted.connection) for t in accepted.terms]
    return ElementSet((*current.elements, *added), current.n_dofs, current.static, current.px_roots)


def confirmed(ranking, accepted, data, held, current, M) -> tuple[tuple[ConnectionEvidence, ...], Any]:
    """A candidate accepted below ``min_explained`` (:func:`captures`) kept only when the free run of the held-out
    part, by the models fitted on the estimation part, improves by at least :data:`MIN_FREERUN_GAIN` with it;
    otherwise it is marked ``not confirmed`` and nothing is accepted."""
    new = with_accepted(current, accepted)
    held = with_velocity(held)  # the velocities both runs start from, estimated once

    def error(elements) -> float:
        fit = joint_least_squares(data.with_elements(elements), elements, M, context="discover: ")
        return float(np.mean(free_run_error(fit.model(elements, M), held)[1]))

    before, after = error(current), error(new)
    gain = 1.0 - after / before if math.isfinite(before) and before > 0 else float("nan")
    if math.isfinite(gain) and gain >= MIN_FREERUN_GAIN:
        kept = replace(accepted, reason=f"{accepted.reason}; held-out free run {before:.3g} -> {after:.3g} % of std(z)")
        return tuple(kept if e is accepted else e for e in ranking), kept
    refused = replace(
        accepted,
        status="not confirmed",
        reason=f"{accepted.reason}; but the held-out free run does not improve by {100 * MIN_FREERUN_GAIN:g} % with it "
        f"({before:.3g} -> {after:.3g} % of std(z))",
    )
    return tuple(refused if e is accepted else e for e in ranking), None


def captures(e: ConnectionEvidence, probes: StructureRemaining, rule: AcceptanceRule) -> ConnectionEvidence:
    """``e`` marked as passing when it captures its connection's remaining structure (:func:`rank`)."""
    if e.status != "below threshold" or e.delta_bic is None or e.delta_bic > rule.max_delta_bic:
        return e
    # the connection's own probes (a DOF probe on DOF k finds what no connection k-ground carries)
    on = [p.explained for p in probes.probes if p.connection == e.connection and p.probe not in DOF_PROBES]
    found = max(on, default=0.0)
    explained = float(e.explained or 0.0)
    if found < probes.threshold or explained < max(probes.threshold, CAPTURE * found):
        return e
    return replace(
        e,
        status="passes",
        reason=(
            f"explains {100 * explained:.3g} % < {100 * rule.min_explained:g} % of a residual mostly noise, but "
            f"{100 * explained / found:.3g} % of the {100 * found:.3g} % its connection's probes find predictable; "
            f"dBIC {e.delta_bic:.3g}"
        ),
    )


def _fit(elements, data, M):
    """``elements`` fitted on ``data`` by the search's joint least squares, as a structural model."""
    return joint_least_squares(data.with_elements(elements), elements, M, context="discover: ").model(elements, M)


def prediction_steps(model, fs: float) -> int:
    """``k`` of the chaotic fallback: two periods of the fastest mode of the underlying linear system, in samples
    (bounded as for one DOF, :data:`~nlid.discovery.crossfit.CHAOTIC_MIN_STEPS` to ``CHAOTIC_MAX_STEPS``)."""
    from .crossfit import CHAOTIC_MAX_STEPS, CHAOTIC_MIN_STEPS, CHAOTIC_PERIODS

    lam = np.linalg.eigvals(np.linalg.solve(model.M, model.K)).real
    fastest = math.sqrt(float(lam.max())) / (2 * math.pi) if lam.size and lam.max() > 0 else 0.0
    k = CHAOTIC_PERIODS * fs / fastest if fastest > 0 else CHAOTIC_MAX_STEPS
    return int(min(max(round(k), CHAOTIC_MIN_STEPS), CHAOTIC_MAX_STEPS))


def prediction_percent(model, record, steps: int | None, run: np.ndarray | None = None) -> np.ndarray:
    """Each DOF's error (% of std(z)) of the model's free run over ``record`` from its first sample (``steps``
    ``None``; ``run``: that run's displacements when they are at hand) or of its ``steps``-ahead prediction (runs
    of ``steps`` samples, each from the record's state at its start); ``inf`` when a run diverges."""
    from ..simulation import SimulationError
    from ..simulation.structure import free_run_segments

    record = with_velocity(record)
    if steps is None:
        z = _run(model, record) if run is None else run
    else:
        starts = np.arange(0, record.n, steps)
        states = np.hstack([np.asarray(record.z)[starts], np.asarray(record.v)[starts]])
        try:
            z, _ = free_run_segments(model, record.f, record.fs, starts, states, force_hold=record.force_hold)
        except SimulationError:
            z = None
    if z is None or not np.all(np.isfinite(z)):
        return np.full(model.n_dofs, math.inf)
    return 100 * rms(z - record.z) / _std(record)


def _chaotic(model, record, run: np.ndarray | None) -> bool:
    """The one-DOF chaos check (:func:`nlid.scoring.free_run_error`) on a structure: the free run ``run`` (its
    displacements over ``record``, velocities present; ``None``: it diverged) and one started
    :data:`~nlid.scoring.SENSITIVITY_DELTA` std(z) away differ by more than :data:`~nlid.scoring.SENSITIVITY_LIMIT`
    std(z) over the second half (or a run diverges)."""
    shifted = None if run is None else _run(model, record, SENSITIVITY_DELTA)
    if shifted is None:
        return True
    half = record.n // 2
    spread = rms(shifted[half:] - run[half:]) / _std(record)
    return not np.all(np.isfinite(spread)) or bool(np.any(spread > SENSITIVITY_LIMIT))


def judged(
    ranking, accepted, blocks, current, M, rule: AcceptanceRule, max_judged: int
) -> tuple[tuple[ConnectionEvidence, ...], Any]:
    """The first passing candidate, in the acceptance rule's order, that does not worsen the cross-fitted prediction.

    ``blocks`` pairs the selection record's parts: ``(regression data fitted on, record predicted)``, the
    estimation part predicting the held-out part and the reverse. The current model and each candidate's are
    fitted on the one and predict the other: a free run from the block's first sample, or, when the free run
    of either model is chaotic on either block (:func:`_chaotic`: it says nothing about the model), the
    ``k``-step-ahead prediction of both on every block (:func:`prediction_steps` of the current model), as
    :mod:`nlid.discovery.crossfit` does for one DOF (but a model with a memory element is not judged then: its
    k-step runs would start the memory states at zero). The errors (mean over the DOFs, % of std(z)) are pooled
    over the blocks; a candidate whose pooled error is larger than the current model's is marked ``rejected``
    and the next passing one judged, up to ``max_judged``. ``None`` is accepted when none holds.
    """
    records = [with_velocity(record) for _, record in blocks]  # each velocity estimated once for every run
    fits = [_fit(current, data, M) for data, _ in blocks]
    runs = [_run(fit, r) for fit, r in zip(fits, records, strict=True)]
    steps = [prediction_steps(fit, r.fs) for fit, r in zip(fits, records, strict=True)]
    chaos = [_chaotic(*x) for x in zip(fits, records, runs, strict=True)]
    before: dict[bool, float] = {}  # k-step or free run -> the current model's pooled error

    def pooled(models, ahead: bool, free: list) -> float:
        errors = [
            prediction_percent(m, r, k if ahead else None, run)
            for m, r, k, run in zip(models, records, steps, free, strict=True)
        ]
        return float(np.mean([np.mean(e) for e in errors]))

    for _ in range(max_judged):
        new = with_accepted(current, accepted)
        models = [_fit(new, data, M) for data, _ in blocks]
        free = [_run(m, r) for m, r in zip(models, records, strict=True)]
        # one chaotic free run (either model, either block) and the k-step prediction judges every block: the
        # same dynamics on the other block are just as sensitive, however its two runs happened to stay together
        chaotic = any(chaos) or any(_chaotic(*x) for x in zip(models, records, free, strict=True))
        if chaotic and any(e.term.is_memory for e in new):
            # a k-step run would start each memory state (Bouc-Wen's, Dahl's) at zero, not where the measured
            # motion left it: no fair judge of such a model, so the equation error decides alone
            note = "; not judged by the prediction: a free run is chaotic and a k-step run would start the memory at 0"
            kept = replace(accepted, reason=f"{accepted.reason}{note}")
            return tuple(kept if e is accepted else e for e in ranking), kept
        if chaotic not in before:
            before[chaotic] = pooled(fits, chaotic, runs)
        b, a = before[chaotic], pooled(models, chaotic, free)
        how = "k-step prediction (a free run is chaotic)" if chaotic else "free run"
        said = f"cross-fitted held-out {how} {b:.3g} -> {a:.3g} % of std(z)"
        if a <= b:
            kept = replace(accepted, reason=f"{accepted.reason}; {said}")
            return tuple(kept if e is accepted else e for e in ranking), kept
        refused = replace(accepted, status="rejected", reason=f"{accepted.reason}; but the {said}: worse")
        ranking, accepted = rank([refused if e is accepted else e for e in ranking], rule)
        if accepted is None:
            break
    return ranking, None
