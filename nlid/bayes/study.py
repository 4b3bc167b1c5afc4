"""What a study asks of a posterior: credible intervals, their coverage of the truth, the chains' cost.

A study config asks for posteriors with a ``[posterior]`` table; its keys are
the options of :class:`~nlid.bayes.PosteriorSampler` (``params``,
``walkers``, ``max_steps``, ``seed``, ``move``, ``bias_correction``,
``bias_pairs``, ``bias_iterations``, ``noise``, ``priors``, ``cutoff``,
``others``) plus ``level`` (credible level of the interval, default 0.9).

The posterior is the one :func:`nlid.bayes.sample_posterior` gives, whatever
channels the record has (the noise levels of the correction established as
:mod:`nlid.bayes.noise` says); a level that cannot be established fails the
posterior, which the study records as a warning on the run. The result is a
typed value (:class:`PosteriorMetrics`); the study flattens it into its
columns (:mod:`nlid.study.row`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from ..data.record import Record
from ..errors import InputError
from ..identified.model import IdentifiedModel
from ..identified.reference import Reference
from ..model.terms import Model
from .inference import PosteriorSampler

__all__ = ["PosteriorMetrics", "posterior_metrics"]


@dataclass(frozen=True)
class PosteriorMetrics:
    """The posterior of one study run, as the study reports it (:func:`posterior_metrics`).

    Attributes
    ----------
    level
        The credible level of the intervals.
    intervals
        ``{term: (lo, hi)}``: the equal-tailed credible interval of each sampled coefficient, in the
        posterior's order.
    covers
        ``{term: lo <= truth <= hi}`` for the sampled terms whose true value is known.
    tau
        The largest integrated autocorrelation time of the chains (steps).
    seconds
        The posterior's wall time.
    max_bias_shift_sd
        The largest move of a sampled coefficient by the bias correction, in its standard deviations (0
        without the correction).
    """

    level: float
    intervals: Mapping[str, tuple[float, float]]
    covers: Mapping[str, bool]
    tau: float
    seconds: float
    max_bias_shift_sd: float


def _truth_coefficients(truth: Reference | Mapping[str, Any] | None) -> dict[str, float] | None:
    """The known coefficients (:meth:`nlid.identified.reference.Reference.from_mapping` reads a mapping), ``None`` if
    unknown."""
    if truth is None:
        return None
    if not isinstance(truth, (Reference, Mapping)):
        raise InputError("truth must map term names to values (or hold them under 'coefficients')")
    ref = truth if isinstance(truth, Reference) else Reference.from_mapping(truth)
    return None if ref.coefficients is None else dict(ref.coefficients)


def posterior_metrics(
    record: Record | Any,
    fit: IdentifiedModel | Any,
    truth: Reference | Mapping[str, Any] | None,
    **options: Any,
) -> PosteriorMetrics:
    """Posterior metrics of one study run.

    Parameters
    ----------
    record, fit
        The data and the identified model of the run (or a structure record
        and its :class:`~nlid.identified.structure.IdentifiedStructure`: :mod:`nlid.bayes.structure`).
    truth
        The reference: a :class:`~nlid.identified.reference.Reference`, true
        coefficients (``{term: value}``, or a preset's ``truth()`` with a
        ``"coefficients"`` entry), or ``None`` when unknown.
    **options
        ``level`` and the :class:`~nlid.bayes.PosteriorSampler` settings.

    Returns
    -------
    PosteriorMetrics
        The credible intervals at ``level``, their coverage of the truth when it is known, the chains'
        autocorrelation time, the time and the bias correction's largest move.
    """
    options = dict(options)
    level = float(options.pop("level", 0.9))
    if not 0 < level < 1:
        raise InputError(f"posterior level must lie between 0 and 1, got {level}")
    posterior = PosteriorSampler(**options).run(record, fit)
    unknowns = posterior.model  # a one-DOF Model, or a structure's unknowns (nlid.bayes.structure)
    if isinstance(truth, Mapping) and not isinstance(unknowns, Model):  # a structure's truth: elements on connections
        coeffs = dict(truth.get("coefficients") or {}) or None
    else:
        coeffs = _truth_coefficients(truth)
    if coeffs is not None:
        coeffs = {unknowns.names[unknowns.index(k)]: v for k, v in coeffs.items() if k in unknowns}
    intervals = {name: (lo, hi) for name, (lo, hi) in posterior.interval(level).items()}
    covers = {name: bool(lo <= coeffs[name] <= hi) for name, (lo, hi) in intervals.items() if coeffs and name in coeffs}
    shift = max((abs(x) for x in posterior.bias_shifts.values()), default=0.0)
    return PosteriorMetrics(level, intervals, covers, max(posterior.tau.values()), posterior.seconds, shift)
