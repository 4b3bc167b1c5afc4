"""Which candidate a structure's search accepts: the ranking, the rule for noisy records, the free-run check.

:func:`rank` applies the :class:`~nlid.discovery.evidence.AcceptanceRule` to one round's candidates (the
one with the fewest parameters among those within :data:`~nlid.discovery.evidence.PARSIMONY` of the best).
On a noisy record the residual is mostly noise and a real element explains less than the rule's
``min_explained``: given the remaining-structure probes, :func:`rank` also lets a candidate pass that
captures what its connection's probes find predictable (:func:`captures`), and :func:`confirmed` keeps it
only when the held-out free run improves with it (:func:`free_run_error`).
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np

from ..estimation.joint import joint_least_squares
from ..model.elements import Element, ElementSet
from .evidence import PARSIMONY, AcceptanceRule
from .structure_result import ConnectionEvidence, StructureRemaining

__all__ = ["CAPTURE", "MIN_FREERUN_GAIN", "rank", "captures", "confirmed", "with_accepted", "free_run_error", "rms"]

#: Share of what the best remaining-structure probe on a connection explains that a candidate below the
#: rule's ``min_explained`` must explain to pass (:func:`rank`): the candidate then holds the structure the
#: flexible functions find there, and what it does not explain is noise.
CAPTURE = 0.8
#: Smallest relative drop of the held-out free-run error that confirms a candidate accepted below
#: ``min_explained`` (the one-DOF prediction rule's default gain, :class:`~nlid.discovery.crossfit.PredictionRule`).
MIN_FREERUN_GAIN = 0.01


def rms(x: np.ndarray) -> np.ndarray:
    """RMS of each column of ``x`` (each DOF of a ``(samples, dofs)`` array)."""
    return np.sqrt(np.mean(np.asarray(x) ** 2, axis=0))


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

    n = model.n_dofs
    nan = tuple([float("nan")] * n)
    full = record if record.v is not None else record.with_derivatives()
    x0 = (record.z[0], full.v[0])
    try:
        z, _, _ = free_run(model, record.f, record.fs, force_hold=record.force_hold, x0=x0)
    except SimulationError as exc:
        return nan, nan, f"diverged: {exc}"
    if not np.all(np.isfinite(z)):
        return nan, nan, "diverged"
    err = rms(z - record.z)
    std = np.std(record.z, axis=0)
    pct = tuple(float(100 * e / s) if s > 0 else float("nan") for e, s in zip(err, std, strict=True))
    return (
        tuple(float(x) for x in err),
        pct,
        f"from the test part's first sample (measured state), force as recorded ({record.force_hold}), "
        f"{record.n} samples scored",
    )


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
    found = max((p.explained for p in probes.probes if p.connection == e.connection), default=0.0)
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
