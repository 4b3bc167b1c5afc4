"""Ranking candidate effects and the rule that accepts one.

Why a rule beyond "is the new term significant": with a few hundred thousand
samples every term a least-squares fit is given is "significant" by an
ordinary F-test or an information criterion computed with ``N`` samples, and
the residual of a force balance formed in a filtered band
(:func:`nlid.estimation.balance.regression_data`) is strongly correlated, so ``N``
overstates the information by one to three orders of magnitude. The loop
therefore asks two questions of every candidate, both answered with the
residual of the force balance ``e = f - m a - G theta`` (Eq. 25-26):

1. **Does it explain the held-out residual?** (practical significance, on
   data the fit has not seen) ``explained = 1 - RSS_after / RSS_before`` on
   the held-out record, with the model (and mass) estimated on the
   estimation record. Candidates are *ranked* by this fraction. It must be at
   least ``min_explained`` (default 0.10: the held-out residual RMS drops by
   at least 5.1 %).
2. **Is the improvement more than the extra parameters buy?** (statistical
   significance, with an honest sample size) the change of the Bayesian
   information criterion on the estimation record computed with the
   *effective* sample size::

       dBIC = N_eff ln(RSS_after / RSS_before) + k ln(N_eff),
       N_eff = N / tau_int

   where ``tau_int`` is the integrated autocorrelation time of the current
   model's residual (Sokal's windowed estimate, via
   :func:`emcee.autocorr.integrated_time`) and ``k`` the number of parameters
   the candidate adds (its terms, plus one for a shape parameter chosen on a
   grid). It must be at most ``max_delta_bic`` (default -10, "very strong"
   evidence on the Kass-Raftery scale).

The accepted effect is the highest-ranked candidate that passes both, except
that among the candidates passing both whose held-out share is within
:data:`PARSIMONY` of the best, the one with the fewest parameters is taken
(data that cannot tell a Dahl law from the Coulomb friction it reduces to get
the Coulomb friction). RSS
ratios are ratios of the force residual (the residual relative to RMS(f),
whose denominator does not depend on the model or the estimated mass), so
they are exact ratios of residual sums of squares.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from ..errors import InputError, brief

__all__ = [
    "AcceptanceRule",
    "acceptance_rule",
    "Scores",
    "Evidence",
    "integrated_time",
    "effective_sample_size",
    "delta_bic",
    "judge",
    "eligible",
    "rank",
]


@dataclass(frozen=True)
class AcceptanceRule:
    """When a candidate effect is accepted (see the module docstring).

    Parameters
    ----------
    min_explained
        Smallest fraction of the held-out residual variance the candidate
        must explain, ``0 < min_explained < 1``.
    max_delta_bic
        Largest (most positive) allowed change of the effective-sample-size
        BIC on the estimation data; negative means "better".
    """

    min_explained: float = 0.10
    max_delta_bic: float = -10.0

    def __post_init__(self) -> None:
        if not (0.0 < self.min_explained < 1.0):
            raise InputError(f"min_explained must lie between 0 and 1, got {self.min_explained}")
        if not math.isfinite(self.max_delta_bic):
            raise InputError(f"max_delta_bic must be a finite number, got {self.max_delta_bic}")

    def describe(self) -> str:
        """The rule in one sentence (for reports and JSON)."""
        drop = 100.0 * (1.0 - math.sqrt(1.0 - self.min_explained))
        return (
            "candidates are ranked by the fraction of the held-out residual variance they explain; the "
            f"highest-ranked one is accepted if that fraction is at least {self.min_explained:g} (the held-out "
            f"residual RMS drops by at least {drop:.2g} %) and the BIC on the estimation data, computed with the "
            "effective sample size N_eff = N / tau_int of the current residual, changes by at most "
            f"{self.max_delta_bic:g}"
        )

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly form, with the sentence."""
        return {**asdict(self), "text": self.describe()}


def acceptance_rule(accept: Any, rule: Any = None) -> AcceptanceRule | None:
    """The acceptance rule a search was given as ``accept=`` (``None``: the search's default).

    ``rule=`` was its old name; everywhere else in nlid ``rule`` is the transient rule of a free run, which a
    search takes as ``freerun_rule=``. An :class:`AcceptanceRule` given as ``rule=`` still works, with a
    :class:`DeprecationWarning`; anything else given as ``rule=`` (``"window:50"``) is refused.

    Raises
    ------
    InputError
        ``accept=`` is not an :class:`AcceptanceRule`, or ``rule=`` is not one either.
    """
    if rule is not None:
        if not isinstance(rule, AcceptanceRule) or accept is not None:
            raise InputError(
                f"rule= is not a setting of discover (got {brief(rule)}): the acceptance rule is accept= "
                "(an AcceptanceRule), the free runs' transient rule is freerun_rule= ('window:50', 'first-sample')"
            )
        warnings.warn(
            "discover's rule= is now accept= (the acceptance rule; rule= elsewhere is the transient rule)",
            DeprecationWarning,
            stacklevel=3,
        )
        accept = rule
    if accept is not None and not isinstance(accept, AcceptanceRule):
        raise InputError(
            f"accept= must be an AcceptanceRule (AcceptanceRule(min_explained=0.1, max_delta_bic=-10)), "
            f"got {brief(accept)}"
        )
    return accept


#: Eligible candidates whose held-out share is within this of the best one are ranked by simplicity.
PARSIMONY = 0.02


def integrated_time(residual: np.ndarray) -> float:
    """Integrated autocorrelation time of a residual, in samples (>= 1).

    Sokal's automatic window (``c = 5``) as implemented by
    :func:`emcee.autocorr.integrated_time`.
    """
    from emcee.autocorr import integrated_time as _tau

    x = np.asarray(residual, dtype=float)
    if x.size < 8 or np.ptp(x) == 0:
        return 1.0
    tau = float(np.asarray(_tau(x, c=5, tol=0, quiet=True)).ravel()[0])
    return max(1.0, tau) if math.isfinite(tau) else float(x.size)


def effective_sample_size(residual: np.ndarray) -> tuple[float, float]:
    """``(N_eff, tau_int)`` of a residual: ``N_eff = N / tau_int`` (at least 2)."""
    tau = integrated_time(residual)
    return max(2.0, np.size(residual) / tau), tau


def delta_bic(rss_ratio: float, extra_parameters: int, n_eff: float) -> float:
    """``N_eff ln(RSS_after / RSS_before) + k ln(N_eff)``."""
    if not rss_ratio > 0:
        return -math.inf
    return float(n_eff * math.log(rss_ratio) + extra_parameters * math.log(n_eff))


@dataclass(frozen=True)
class Scores:
    """Residual figures of one fitted model, in percent.

    Attributes
    ----------
    eps, eps_holdout
        Epsilon of Eq. 26 (relative to the restoring force ``f - m a``) on
        the estimation and the held-out record.
    force_residual, force_residual_holdout
        The same residual relative to the force ``f`` (the "relative force
        residual" of inverse-dynamics benchmarks such as EMPS).
    """

    eps: float
    force_residual: float
    eps_holdout: float
    force_residual_holdout: float


@dataclass
class Evidence:
    """What testing one candidate showed.

    Attributes
    ----------
    effect
        Candidate name.
    terms
        Terms it adds (canonical names; empty when not applicable).
    status
        ``"accepted"``, ``"rejected"`` (fitted, did not pass the rule),
        ``"failed"`` (the identification failed) or ``"not applicable"``.
    reason
        Why, in words.
    shape
        The chosen shape parameter ``c``, if any.
    scores
        Residuals with the candidate added.
    explained_holdout, explained_estimation
        Fractions of the residual variance it explains.
    delta_bic, n_eff, tau_samples
        The information criterion and the effective sample size behind it.
    extra_parameters
        Parameters added (terms, plus the shape).
    coefficients
        The fitted coefficients with the candidate added.
    mass
        The mass the ``mass`` candidate estimated (kg).
    input_path
        The input path an input-path candidate fitted (:meth:`nlid.estimation.inputpath.InputPath.to_spec`).
    prediction_before, prediction_after
        The cross-fitted held-out prediction of the current model and of the model with the candidate
        (:meth:`nlid.discovery.crossfit.Prediction.to_dict`), when the candidate was judged by it.
    rule_reason
        What the equation-error rule said (the reason before any later judgement was added).
    """

    effect: str
    terms: list[str] = field(default_factory=list)
    status: str = "rejected"
    reason: str = ""
    shape: float | None = None
    scores: Scores | None = None
    explained_holdout: float | None = None
    explained_estimation: float | None = None
    delta_bic: float | None = None
    n_eff: float | None = None
    tau_samples: float | None = None
    extra_parameters: int = 0
    coefficients: dict[str, float] | None = None
    passes: dict[str, bool] = field(default_factory=dict)
    mass: float | None = None
    input_path: str | None = None
    prediction_before: dict[str, Any] | None = None
    prediction_after: dict[str, Any] | None = None
    rule_reason: str = ""

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly dictionary (scores flattened with ``_after`` names)."""
        out: dict[str, Any] = {
            "effect": self.effect,
            "terms": list(self.terms),
            "status": self.status,
            "reason": self.reason,
            "shape_c": self.shape,
            "explained_holdout": self.explained_holdout,
            "explained_estimation": self.explained_estimation,
            "delta_bic": self.delta_bic,
            "n_eff": self.n_eff,
            "tau_samples": self.tau_samples,
            "extra_parameters": self.extra_parameters,
            "passes": dict(self.passes),
        }
        if self.scores is not None:
            out.update(
                eps_after=self.scores.eps,
                eps_after_holdout=self.scores.eps_holdout,
                force_residual_after=self.scores.force_residual,
                force_residual_after_holdout=self.scores.force_residual_holdout,
            )
        if self.coefficients is not None:
            out["coefficients"] = dict(self.coefficients)
        if self.mass is not None:
            out["mass"] = self.mass
        if self.input_path is not None:
            out["input_path"] = self.input_path
        if self.prediction_after is not None:
            out["prediction_before"] = self.prediction_before
            out["prediction_after"] = self.prediction_after
        return out


def judge(
    evidence: Evidence,
    before: Scores,
    after: Scores,
    n_eff: float,
    tau: float,
    rule: AcceptanceRule,
) -> Evidence:
    """Fill ``evidence`` with the figures of a fitted candidate and the rule's verdict.

    The status is ``"rejected"`` unless both tests pass, in which case it is
    ``"eligible"`` until :func:`rank` picks the accepted one.
    """
    ratio_ho = (after.force_residual_holdout / before.force_residual_holdout) ** 2
    ratio = (after.force_residual / before.force_residual) ** 2
    evidence.scores = after
    evidence.explained_holdout = float(1.0 - ratio_ho)
    evidence.explained_estimation = float(1.0 - ratio)
    evidence.n_eff, evidence.tau_samples = float(n_eff), float(tau)
    evidence.delta_bic = delta_bic(ratio, evidence.extra_parameters, n_eff)
    evidence.passes = {
        "holdout": evidence.explained_holdout >= rule.min_explained,
        "information_criterion": evidence.delta_bic <= rule.max_delta_bic,
    }
    if all(evidence.passes.values()):
        evidence.status = "eligible"
        evidence.reason = (
            f"explains {100 * evidence.explained_holdout:.3g} % of the held-out residual variance, "
            f"dBIC = {evidence.delta_bic:.4g}"
        )
    else:
        why = []
        if not evidence.passes["holdout"]:
            why.append(
                f"explains {100 * evidence.explained_holdout:.3g} % of the held-out residual variance "
                f"(< {100 * rule.min_explained:g} %)"
            )
        if not evidence.passes["information_criterion"]:
            why.append(f"dBIC = {evidence.delta_bic:.4g} (> {rule.max_delta_bic:g})")
        evidence.status = "rejected"
        evidence.reason = "; ".join(why)
    evidence.rule_reason = evidence.reason
    return evidence


def eligible(evidence: Evidence) -> bool:
    """True when a fitted candidate passes every test it was put to (the rule, physics, prediction)."""
    return evidence.explained_holdout is not None and bool(evidence.passes) and all(evidence.passes.values())


def rank(evidence: list[Evidence]) -> tuple[list[Evidence], Evidence | None]:
    """Sort by held-out explained variance and accept the best eligible candidate.

    Eligible: every test a candidate was put to passed (:func:`eligible`: the rule's two, the physical
    sign, and the prediction check once a candidate was judged by it). Ranking again after a candidate
    failed a later test gives the next one its turn: the statuses and reasons are set afresh each time.

    Returns
    -------
    ranking : list of Evidence
        Fitted candidates by decreasing ``explained_holdout``, then the failed
        and not applicable ones.
    accepted : Evidence or None
        The accepted candidate (its status set to ``"accepted"``); the other
        eligible ones become ``"rejected"`` ("a better candidate was accepted").
    """
    fitted = [e for e in evidence if e.explained_holdout is not None]
    rest = [e for e in evidence if e.explained_holdout is None]
    fitted.sort(key=lambda e: -float(e.explained_holdout))  # type: ignore[arg-type]
    passing = [e for e in fitted if eligible(e)]
    accepted = None
    if passing:
        # parsimony: of the eligible candidates within PARSIMONY of the best share, the one with the fewest
        # parameters (a Coulomb friction rather than a Dahl law that reduces to it, on data that cannot tell)
        top = float(passing[0].explained_holdout)  # type: ignore[arg-type]
        close = [e for e in passing if float(e.explained_holdout) >= top - PARSIMONY]  # type: ignore[arg-type]
        accepted = min(close, key=lambda e: (e.extra_parameters, -float(e.explained_holdout)))  # type: ignore[arg-type]
        accepted.status, accepted.reason = "accepted", accepted.rule_reason or accepted.reason
        for e in passing:
            if e is accepted:
                continue
            e.status = "rejected"
            why = (
                "explains more"
                if float(e.explained_holdout) <= float(accepted.explained_holdout)  # type: ignore[arg-type]
                else (f"explains about as much (within {100 * PARSIMONY:g} points) with fewer parameters")
            )
            e.reason = f"passes the rule, but {accepted.effect!r} {why}; " + (e.rule_reason or e.reason)
    return fitted + rest, accepted
