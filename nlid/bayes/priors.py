"""Priors on the coefficients: weakly informative defaults scaled to the data, overridable.

Default (:func:`default_priors`)
    ``normal(0, s_i)`` with ``s_i = 10 RMS(y) / RMS(g_i)``: a priori a term is
    unlikely to contribute more than about ten times the whole measured
    restoring force ``y = f - m a``. The scale follows each term's unit
    (N s/m for ``v``, N for ``sign(v)``...) and the record's amplitudes, so
    it is weak for every term and every record; with thousands of effective
    samples the likelihood dominates it by orders of magnitude.

Overrides (:func:`parse_prior`), per term, written as text (never
evaluated as code)
    ``normal(MEAN, SD)``, ``uniform(LOW, HIGH)`` (density zero outside) and
    ``flat`` (improper, constant).
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import IdentificationError, InputError, brief
from ..model.terms import parse_term
from .likelihood import SufficientStatistics

__all__ = [
    "joint_logpdf",
    "Prior",
    "Normal",
    "Uniform",
    "Flat",
    "PriorError",
    "PriorConflictError",
    "prior_conflicts",
    "PRIOR_CONFLICT_SIGMAS",
    "parse_prior",
    "parse_prior_assignments",
    "default_priors",
    "DEFAULT_SCALE",
]

#: The default prior's standard deviation, in units of ``RMS(y) / RMS(g_i)``.
DEFAULT_SCALE = 10.0


#: A prior conflicts with the data when its centre lies more than this many standard deviations
#: (prior and likelihood combined) from the likelihood's centre (a prior-predictive check in the
#: Gaussian limit: 5 sd happen by chance with probability 6e-7).
PRIOR_CONFLICT_SIGMAS = 5.0


class PriorError(InputError):
    """A prior is malformed or excludes the identifier's estimate."""


class PriorConflictError(IdentificationError):
    """A prior and the likelihood disagree so much that a posterior between them describes neither."""


class Prior:
    """A prior on one coefficient: ``logpdf`` of an array and a one-line description."""

    def logpdf(self, x: np.ndarray) -> np.ndarray:  # pragma: no cover - interface
        raise NotImplementedError

    def describe(self) -> str:  # pragma: no cover - interface
        raise NotImplementedError

    def __str__(self) -> str:
        return self.describe()


@dataclass(frozen=True)
class Normal(Prior):
    """Gaussian prior ``normal(mean, sd)``."""

    mean: float
    sd: float

    def __post_init__(self) -> None:
        if not (math.isfinite(self.mean) and math.isfinite(self.sd) and self.sd > 0):
            raise PriorError(f"normal prior needs a finite mean and a positive sd, got normal({self.mean}, {self.sd})")

    def logpdf(self, x: np.ndarray) -> np.ndarray:
        """Log density (normalised)."""
        u = (np.asarray(x, dtype=float) - self.mean) / self.sd
        return -0.5 * u * u - math.log(self.sd * math.sqrt(2.0 * math.pi))

    def describe(self) -> str:
        """``normal(mean, sd)``."""
        return f"normal({self.mean:.6g}, {self.sd:.6g})"


@dataclass(frozen=True)
class Uniform(Prior):
    """Uniform prior on ``[low, high]`` (zero density outside)."""

    low: float
    high: float

    def __post_init__(self) -> None:
        if not (math.isfinite(self.low) and math.isfinite(self.high) and self.low < self.high):
            raise PriorError(f"uniform prior needs finite bounds low < high, got uniform({self.low}, {self.high})")

    def logpdf(self, x: np.ndarray) -> np.ndarray:
        """Log density: ``-log(high - low)`` inside, ``-inf`` outside."""
        x = np.asarray(x, dtype=float)
        inside = (x >= self.low) & (x <= self.high)
        return np.where(inside, -math.log(self.high - self.low), -np.inf)

    def describe(self) -> str:
        """``uniform(low, high)``."""
        return f"uniform({self.low:.6g}, {self.high:.6g})"


@dataclass(frozen=True)
class Flat(Prior):
    """Improper constant prior."""

    def logpdf(self, x: np.ndarray) -> np.ndarray:
        """Zero everywhere."""
        return np.zeros(np.shape(x))

    def describe(self) -> str:
        """``flat``."""
        return "flat"


_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_CALL = re.compile(rf"^\s*(normal|uniform)\s*\(\s*({_NUMBER})\s*,\s*({_NUMBER})\s*\)\s*$", re.IGNORECASE)


def parse_prior(text: str) -> Prior:
    """Parse ``normal(MEAN, SD)``, ``uniform(LOW, HIGH)`` or ``flat``.

    Raises
    ------
    PriorError
        Naming the text and the accepted forms.
    """
    if not isinstance(text, str):
        raise PriorError(f"a prior is written as text such as 'normal(0, 5)', got {text!r}")
    if text.strip().lower() == "flat":
        return Flat()
    match = _CALL.match(text)
    if not match:
        raise PriorError(f"cannot read the prior {brief(text)}: write normal(MEAN, SD), uniform(LOW, HIGH) or flat")
    kind, a, b = match.group(1).lower(), float(match.group(2)), float(match.group(3))
    return Normal(a, b) if kind == "normal" else Uniform(a, b)


def parse_prior_assignments(
    items: Sequence[str] | Mapping[str, str | Prior] | None, canonical: Callable[[str], str] | None = None
) -> dict[str, Prior]:
    """Priors by canonical term name from ``["TERM=SPEC", ...]`` or a mapping.

    The term may be written in any spelling (``sign(v)*|v|^2`` is ``v*|v|``).
    ``canonical`` names a term (default: the one-DOF grammar's canonical name;
    a structure passes its unknowns' :meth:`~nlid.bayes.structure.StructureParameters.canonical`).
    """
    if not items:
        return {}
    pairs: list[tuple[str, str | Prior]] = []
    if isinstance(items, Mapping):
        pairs = list(items.items())
    else:
        for item in items:
            if "=" not in item:
                raise PriorError(f"a prior is given as TERM=SPEC, e.g. 'v*|v|=normal(5, 1)'; got {brief(item)}")
            term, spec = item.split("=", 1)
            pairs.append((term, spec))
    out: dict[str, Prior] = {}
    for term, spec in pairs:
        name = canonical(term.strip()) if canonical is not None else parse_term(term.strip()).name
        if name in out:
            raise PriorError(f"two priors given for the term {name}")
        out[name] = spec if isinstance(spec, Prior) else parse_prior(spec)
    return out


def default_priors(stats: SufficientStatistics, names: Sequence[str], scale: float = DEFAULT_SCALE) -> dict[str, Prior]:
    """``normal(0, scale * RMS(y) / RMS(g_i))`` for each term (see the module docstring)."""
    rms_y = math.sqrt(stats.yty / stats.n)
    rms_g = np.sqrt(np.diag(stats.gtg) / stats.n)
    out: dict[str, Prior] = {}
    for name, g in zip(names, rms_g, strict=True):
        out[name] = Normal(0.0, scale * rms_y / g) if g > 0 and rms_y > 0 else Flat()
    return out


def joint_logpdf(priors: Sequence[Prior]) -> Callable[[np.ndarray], np.ndarray]:
    """The summed log density of independent priors, vectorised over rows ``(W, d)``.

    Normal and uniform priors are evaluated as one array operation each.
    """
    normal = [i for i, p in enumerate(priors) if isinstance(p, Normal)]
    uniform = [i for i, p in enumerate(priors) if isinstance(p, Uniform)]
    other = [i for i, p in enumerate(priors) if not isinstance(p, (Normal, Uniform, Flat))]
    mu = np.array([priors[i].mean for i in normal])
    sd = np.array([priors[i].sd for i in normal])
    norm_const = -float(np.sum(np.log(sd * math.sqrt(2.0 * math.pi)))) if normal else 0.0
    lo = np.array([priors[i].low for i in uniform])
    hi = np.array([priors[i].high for i in uniform])
    unif_const = -float(np.sum(np.log(hi - lo))) if uniform else 0.0

    def logpdf(x: np.ndarray) -> np.ndarray:
        x = np.atleast_2d(np.asarray(x, dtype=float))
        out = np.full(x.shape[0], norm_const + unif_const)
        if normal:
            u = (x[:, normal] - mu) / sd
            out -= 0.5 * np.einsum("wi,wi->w", u, u)
        if uniform:
            xu = x[:, uniform]
            out[~np.all((xu >= lo) & (xu <= hi), axis=1)] = -np.inf
        for i in other:
            out += priors[i].logpdf(x[:, i])
        return out

    return logpdf


def prior_conflicts(names: Sequence[str], priors: Mapping[str, Prior], mean: np.ndarray, cov: np.ndarray) -> list[str]:
    """The sampled terms whose prior conflicts with the likelihood's Gaussian limit (see :data:`PRIOR_CONFLICT_SIGMAS`).

    Parameters
    ----------
    names
        The sampled terms.
    priors
        Their priors.
    mean, cov
        Centre and covariance of the likelihood of the sampled coefficients.

    Returns
    -------
    list of str
        One description per conflicting term (empty when none conflicts).
    """
    out = []
    sd = np.sqrt(np.clip(np.diag(np.asarray(cov, dtype=float)), 0.0, None))
    for i, name in enumerate(names):
        prior = priors[name]
        if isinstance(prior, Normal):
            distance = abs(prior.mean - float(mean[i])) / math.hypot(prior.sd, float(sd[i]))
        elif isinstance(prior, Uniform) and sd[i] > 0:
            distance = max(prior.low - float(mean[i]), float(mean[i]) - prior.high, 0.0) / float(sd[i])
        else:
            continue
        if distance > PRIOR_CONFLICT_SIGMAS:
            out.append(
                f"the prior of {name} ({prior.describe()}) lies {distance:.3g} standard deviations from what the "
                f"data say ({float(mean[i]):.4g} +/- {float(sd[i]):.2g} {parse_term(name).coefficient_unit})"
            )
    return out
