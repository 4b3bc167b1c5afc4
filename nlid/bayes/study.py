"""The study runner's hook: interval widths and coverage of a posterior.

A study config asks for posteriors with a ``[posterior]`` table; its keys are
the options of :class:`~nlid.bayes.PosteriorSampler` (``params``,
``walkers``, ``max_steps``, ``seed``, ``move``, ``bias_correction``,
``bias_pairs``, ``bias_iterations``, ``noise``, ``priors``, ``cutoff``,
``others``) plus ``level`` (credible level of the interval, default 0.9).

The posterior is the one :func:`nlid.bayes.sample_posterior` gives, whatever
channels the record has (the noise levels of the correction established as
:mod:`nlid.bayes.noise` says); a level that cannot be established fails the
posterior, which the study records as a warning on the run.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ..data.record import Record
from ..errors import InputError
from ..identified.model import IdentifiedModel
from ..identified.reference import Reference
from ..model.terms import Model
from ..scoring import columns as col
from .inference import PosteriorSampler

__all__ = ["study_metrics"]


def _truth_coefficients(truth: Reference | Mapping[str, Any] | None) -> dict[str, float] | None:
    """The known coefficients (:meth:`nlid.identified.reference.Reference.from_mapping` reads a mapping), ``None`` if
    unknown."""
    if truth is None:
        return None
    if not isinstance(truth, (Reference, Mapping)):
        raise InputError("truth must map term names to values (or hold them under 'coefficients')")
    ref = truth if isinstance(truth, Reference) else Reference.from_mapping(truth)
    return None if ref.coefficients is None else dict(ref.coefficients)


def study_metrics(
    record: Record | Any,
    fit: IdentifiedModel | Any,
    truth: Reference | Mapping[str, Any] | None,
    **options: Any,
) -> dict[str, float | bool]:
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
    dict
        For each sampled term: ``"ci_lo:<term>"`` and ``"ci_hi:<term>"`` (the
        equal-tailed credible interval), ``"ci_width:<term>"`` and, when the
        truth is known, ``"ci_covers:<term>"``; ``"posterior:level"``,
        ``"posterior:tau"`` (the largest integrated autocorrelation time,
        steps), ``"posterior:seconds"`` and ``"posterior:max_bias_shift_sd"``
        (the largest move of a sampled coefficient by the bias correction, in
        its standard deviations; 0 without the correction). The keys are
        built through the declared column families (:mod:`nlid.scoring.columns`);
        the study summary turns the ``ci_*`` families into one table.
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
    out: dict[str, float | bool] = {col.POSTERIOR_LEVEL.key(): level}
    for name, (lo, hi) in posterior.interval(level).items():
        out[col.CI_LO.key(name)], out[col.CI_HI.key(name)], out[col.CI_WIDTH.key(name)] = lo, hi, hi - lo
        if coeffs is not None and name in coeffs:
            out[col.CI_COVERS.key(name)] = bool(lo <= coeffs[name] <= hi)
    out[col.POSTERIOR_TAU.key()] = max(posterior.tau.values())
    out[col.POSTERIOR_SECONDS.key()] = posterior.seconds
    out[col.POSTERIOR_BIAS_SHIFT.key()] = max((abs(x) for x in posterior.bias_shifts.values()), default=0.0)
    return out
