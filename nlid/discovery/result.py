"""What a discovery run found: each model (stage), each accepted effect (step), the whole run (result).

:class:`Stage` is one model of the search, identified on the estimation
record and scored on the held-out one; it carries its own mass (given or
estimated), which the fits built on it use. :class:`Step` is one accepted
effect with the stages before and after; :class:`DiscoveryResult` holds the
run (see :meth:`DiscoveryResult.to_dict` for the JSON of ``nlid discover
--json``), prints as the table ``nlid discover`` shows
(:meth:`DiscoveryResult.summary`) and writes the report
(:mod:`nlid.discovery.report`, which reads these classes by their attributes
and imports nothing from here).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..base.jsonable import to_jsonable
from ..estimation.inputpath import InputPath
from ..identified.model import IdentifiedModel
from ..model.terms import Model
from ..report.summary import Summary
from ..scoring import Scores as ScoreSet
from ..scoring.coverage import RangeExcess, beyond_range
from .crossfit import FoldPrediction
from .evidence import AcceptanceRule, Evidence, Scores
from .probes import Remaining
from .report import discovery_summary, write_report

__all__ = ["Stage", "ResidualView", "Step", "DiscoveryResult", "VALIDATION_WORSE"]

#: The validation note (:attr:`DiscoveryResult.validation_note`) appears when the final model's validation
#: free-run error exceeds the best stage's by this factor.
VALIDATION_WORSE = 1.25


@dataclass
class Stage:
    """One model of the loop: identified on the estimation record, scored on both records.

    Attributes
    ----------
    identified
        The :class:`~nlid.identified.model.IdentifiedModel` (its ``scores`` are
        those on the estimation record).
    holdout
        Its scores on the held-out record (:meth:`nlid.IdentifiedModel.score`,
        with the free-run error for the models the loop keeps).
    remaining
        What the remaining-structure probes find in its residual
        (:mod:`nlid.discovery.probes`), for the models the loop keeps.
    validation
        Its scores on a validation record that takes no part in the
        decisions (``discover(..., validation=...)``), if one was given.
    prediction
        Its cross-fitted held-out prediction (:mod:`nlid.discovery.crossfit`), once the search measured it.
    """

    identified: IdentifiedModel
    holdout: ScoreSet
    remaining: Remaining | None = None
    validation: ScoreSet | None = None
    prediction: FoldPrediction | None = None

    @property
    def model(self) -> Model:
        """The model (with the ``px(z)`` roots used, if any)."""
        return self.identified.model

    @property
    def mass(self) -> float:
        """Mass used or estimated (kg)."""
        return float(self.identified.mass)  # type: ignore[arg-type]

    @property
    def given_mass(self) -> float | None:
        """The mass this model was given (kg), ``None`` when it estimated it: what the fits built on it are given.

        A search keeps a given mass until its ``mass`` candidate is accepted; from then on every model
        estimates it. Each stage carries that state, so nothing is reset along the way.
        """
        return None if self.identified.mass_estimated else self.mass

    @property
    def path(self) -> InputPath:
        """The input path the force goes through in this model (:mod:`nlid.estimation.inputpath`)."""
        return self.identified.input_path

    @property
    def coefficients(self) -> dict[str, float]:
        """Identified coefficients by canonical term."""
        return dict(self.identified.coefficients)

    @property
    def scores(self) -> Scores:
        """Epsilon and force residual on the estimation and held-out records (percent)."""
        est = self.identified.scores
        assert est is not None  # the loop always has a mass
        return Scores(
            eps=est.eps_percent,
            force_residual=est.force_residual_percent,
            eps_holdout=self.holdout.eps_percent,
            force_residual_holdout=self.holdout.force_residual_percent,
        )

    @property
    def sim_rms_holdout(self) -> float | None:
        """RMS free-run error on the held-out record (unit of z); ``None`` when not computed (see :attr:`sim_note`)."""
        return self.holdout.freerun_rmse if np.isfinite(self.holdout.freerun_rmse) else None

    @property
    def sim_rms_validation(self) -> float | None:
        """RMS free-run error on the validation record (unit of z), if one was given and the error computed."""
        if self.validation is None or not np.isfinite(self.validation.freerun_rmse):
            return None
        return self.validation.freerun_rmse

    @property
    def sim_note(self) -> str:
        """Why the free-run error is missing (empty when it was computed or not asked for)."""
        note = self.holdout.freerun_note
        return "" if note == "not computed" else note


@dataclass
class ResidualView:
    """The residual of one model on the estimation record, for the report.

    Attributes
    ----------
    label
        Which model ("declared model", "after step 1: coulomb"...).
    z, v
        Displacement and velocity in the equation band.
    r
        Residual ``R_e - R_hat = f - m a - G theta``.
    restoring
        ``R_e = f - m a``.
    fs
        Sampling frequency (Hz).
    tau_samples, n_eff
        Integrated autocorrelation time of ``r`` and ``N / tau``.
    band_hz
        The equation band (Hz), ``None`` when nothing was filtered.
    """

    label: str
    z: np.ndarray
    v: np.ndarray
    r: np.ndarray
    restoring: np.ndarray
    fs: float
    tau_samples: float
    n_eff: float
    band_hz: float | None = None


@dataclass
class Step:
    """One accepted effect."""

    effect: str
    terms: list[str]
    before: Stage
    after: Stage
    evidence: Evidence
    ranking: list[Evidence]
    notes: list[str] = field(default_factory=list)

    def to_dict(self, rule: AcceptanceRule) -> dict[str, Any]:
        """The step as in the JSON contract (``evidence`` holds the ranking and the rule)."""
        b, a = self.before.scores, self.after.scores
        evidence = self.evidence.to_dict()
        evidence["rule"] = rule.to_dict()
        evidence["ranking"] = [e.to_dict() for e in self.ranking]
        return {
            "effect": self.effect,
            "terms": list(self.terms),
            "eps_before": b.eps,
            "eps_after": a.eps,
            "eps_before_holdout": b.eps_holdout,
            "eps_after_holdout": a.eps_holdout,
            "force_residual_before": b.force_residual,
            "force_residual_after": a.force_residual,
            "force_residual_before_holdout": b.force_residual_holdout,
            "force_residual_after_holdout": a.force_residual_holdout,
            "sim_rms_before_holdout": self.before.sim_rms_holdout,
            "sim_rms_after_holdout": self.after.sim_rms_holdout,
            "sim_rms_before_validation": self.before.sim_rms_validation,
            "sim_rms_after_validation": self.after.sim_rms_validation,
            "prediction_before": None if self.before.prediction is None else self.before.prediction.to_dict(),
            "prediction_after": None if self.after.prediction is None else self.after.prediction.to_dict(),
            "input_path_after": self.after.path.to_dict(),
            "coefficients_after": self.after.coefficients,
            "mass_after": self.after.mass,
            "notes": list(self.notes),
            "evidence": evidence,
        }


@dataclass
class DiscoveryResult:
    """Everything one run of the loop found (see :meth:`to_dict` for the JSON).

    Attributes
    ----------
    method, method_notes
        The identifier used and why.
    declared
        The declared terms (canonical names).
    states
        The declared model's fit, then the fit after each step.
    steps
        The accepted effects.
    final_ranking
        The candidates tested in the last round (the one that accepted
        nothing), with their evidence; empty if the loop stopped at
        ``max_steps``.
    stop_reason
        Why the loop stopped.
    rule
        The acceptance rule.
    views
        Residual views of each state (estimation record), for the report.
    info
        Record sizes, band, units, hold-out description, timing.
    """

    method: str
    method_notes: list[str]
    declared: list[str]
    states: list[Stage]
    steps: list[Step]
    final_ranking: list[Evidence]
    stop_reason: str
    rule: AcceptanceRule
    views: list[ResidualView] = field(default_factory=list, repr=False)
    info: dict[str, Any] = field(default_factory=dict)
    refined: Stage | None = None

    @property
    def refined_model(self) -> IdentifiedModel | None:
        """The final model refined by a refining identifier such as ``oe`` (``discover(..., refine=True)``)."""
        return None if self.refined is None else self.refined.identified

    @property
    def initial(self) -> Stage:
        """The declared model's stage."""
        return self.states[0]

    @property
    def final(self) -> Stage:
        """The final model's stage."""
        return self.states[-1]

    @property
    def final_model(self) -> IdentifiedModel:
        """The final identified model."""
        return self.states[-1].identified

    @property
    def remaining(self) -> Remaining | None:
        """What the remaining-structure probes find in the final model's residual."""
        return self.states[-1].remaining

    @property
    def validation_note(self) -> str | None:
        """A sentence when the validation record prefers an earlier model than the final one, else ``None``.

        The validation record takes no part in the decisions; this only says when the steps that
        improved the held-out equation error make the validation free run worse by more than
        :data:`VALIDATION_WORSE` (typically terms that extrapolate badly beyond the estimation record's
        range), so that the user can choose.
        """
        sims = [st.sim_rms_validation for st in self.states]
        if any(x is None for x in sims) or len(sims) < 2:
            return None
        best = int(np.argmin(sims))
        final = sims[-1]
        if best == len(sims) - 1 or final <= VALIDATION_WORSE * sims[best]:  # type: ignore[operator]
            return None
        label = "the declared model" if best == 0 else f"step {best} ({self.steps[best - 1].effect})"
        unit = self.info.get("units", {}).get("z", "")
        text = (
            f"on the validation record the free run of {label} is the best ({sims[best]:.4g} {unit} RMS "
            f"against {final:.4g} {unit} for the final model): the later steps improve the held-out equation "
            "error but not the simulation there"
        )
        zr, zv = self.info.get("z_range"), self.info.get("z_range_validation")
        beyond = beyond_range(zr, zv) if zr and zv else 0.0
        if beyond > 0:
            text += (
                f"; the validation record reaches {100 * beyond:.3g} % of the estimation range beyond it, "
                "where added terms extrapolate"
            )
        return text

    @property
    def validation_range(self) -> str | None:
        """A sentence when the validation record goes beyond the estimation record's displacements, else ``None``.

        Said when it reaches more than :data:`nlid.scoring.coverage.RANGE_TOLERANCE` of the estimation range
        beyond it (:class:`nlid.scoring.RangeExcess`, the sentence ``nlid bench`` states under its tables, without
        the share of samples outside: only the validation record's range is kept): its free-run errors then
        measure how the models extrapolate as much as the models themselves.
        """
        zr, zv = self.info.get("z_range"), self.info.get("z_range_validation")
        if not (zr and zv):
            return None
        return RangeExcess.from_ranges(zr, zv).describe("the validation record") or None

    def summary(self) -> Summary:
        """The table ``nlid discover`` prints: each model's errors, each step, the stop reason.

        A :class:`~nlid.report.summary.Summary`: ``print()`` it (or ``str()``), or ``.as_markdown()`` / ``.as_html()``.
        """
        return discovery_summary(self)

    def write_report(self, out_dir: str, *, force: bool = False) -> list:
        """Write the Markdown/HTML report with figures (:func:`nlid.discovery.write_report`)."""
        return write_report(self, out_dir, force=force)

    def __repr__(self) -> str:
        added = ", ".join(s.effect for s in self.steps) or "nothing"
        b, a = self.initial.scores, self.final.scores
        return (
            f"<DiscoveryResult {self.method!r}: added {added}; held-out eps {b.eps_holdout:.3g} % -> "
            f"{a.eps_holdout:.3g} %; {self.stop_reason}"
            + (
                f"; NOT TRUSTED: {', '.join(f.code for f in self.final.identified.flags)}"
                if self.final.identified.flags
                else ""
            )
            + ">"
        )

    def _repr_html_(self) -> str:
        return self.summary().as_html()

    def to_dict(self) -> dict[str, Any]:
        """The JSON object of ``nlid discover --json``."""
        first, last = self.initial, self.final
        se = last.identified.standard_errors or {}
        return to_jsonable(
            {
                "method": self.method,
                "method_notes": list(self.method_notes),
                "declared": list(self.declared),
                "eps_initial": first.scores.eps,
                "eps_final": last.scores.eps,
                "eps_initial_holdout": first.scores.eps_holdout,
                "eps_final_holdout": last.scores.eps_holdout,
                "force_residual_initial": first.scores.force_residual,
                "force_residual_final": last.scores.force_residual,
                "force_residual_initial_holdout": first.scores.force_residual_holdout,
                "force_residual_final_holdout": last.scores.force_residual_holdout,
                "sim_rms_initial_holdout": first.sim_rms_holdout,
                "sim_rms_final_holdout": last.sim_rms_holdout,
                "sim_rms_initial_validation": first.sim_rms_validation,
                "sim_rms_final_validation": last.sim_rms_validation,
                "steps": [s.to_dict(self.rule) for s in self.steps],
                "final_terms": list(last.model.names),
                "coefficients": last.coefficients,
                "standard_errors": {k: se.get(k) for k in last.model.names} if se else None,
                "mass": last.mass,
                "mass_estimated": bool(last.identified.mass_estimated),
                "px_roots": None if last.model.px_roots is None else list(last.model.px_roots),
                "input_path": last.path.to_dict(),
                "prediction_initial": None if first.prediction is None else first.prediction.to_dict(),
                "prediction_final": None if last.prediction is None else last.prediction.to_dict(),
                "remaining": None if last.remaining is None else last.remaining.to_dict(),
                "validation_note": self.validation_note,
                "validation_range": self.validation_range,
                "remaining_initial": None if first.remaining is None else first.remaining.to_dict(),
                "final_model": last.identified.to_dict(),
                "final_check": {
                    "stop_reason": self.stop_reason,
                    "ranking": [e.to_dict() for e in self.final_ranking],
                },
                "rule": self.rule.to_dict(),
                "info": dict(self.info),
                "refined": None if self.refined is None else _refined_dict(last, self.refined),
            }
        )


def _refined_dict(final: Stage, refined: Stage) -> dict[str, Any]:
    """The refinement by ``oe``: the final model's scores before and after, and the refined model."""
    return {
        "method": refined.identified.method,
        "sim_rms_before_holdout": final.sim_rms_holdout,
        "sim_rms_after_holdout": refined.sim_rms_holdout,
        "sim_rms_before_validation": final.sim_rms_validation,
        "sim_rms_after_validation": refined.sim_rms_validation,
        "eps_before_holdout": final.scores.eps_holdout,
        "eps_after_holdout": refined.scores.eps_holdout,
        "model": refined.identified.to_dict(),
    }
