"""From an identification to a posterior: choose the coefficients, build the likelihood, sample."""

from __future__ import annotations

import time
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..base import numerics
from ..base.validate import Interval, Options, check_cutoff, check_noise_sd, check_seed
from ..data.forcehold import force_hold_source
from ..data.record import Record
from ..errors import IdentificationError, InputError, NlidError
from ..estimation.balance import regression_data
from ..identified.model import IdentifiedModel
from ..identified.reference import Reference
from ..identified.result import Identified
from ..model.terms import Model, parse_term
from .likelihood import build_likelihood, check_identifiable
from .priors import (
    Normal,
    Prior,
    PriorConflictError,
    PriorError,
    default_priors,
    joint_logpdf,
    parse_prior_assignments,
    prior_conflicts,
)
from .result import Posterior
from .sampler import MOVES, run_until_converged
from .trust import correction_flags

__all__ = ["PosteriorSampler", "sample_posterior", "select_params"]

#: Keywords of ``params=`` (``elements``: a structure's element coefficients).
PARAM_KEYWORDS = ("damping", "friction", "all", "elements")
#: Treatments of the coefficients that are not sampled.
OTHERS = ("fixed", "marginal")
#: Spread of the initial walker ball, in Gaussian-limit posterior standard deviations.
START_SPREAD = 0.1
#: Largest settings accepted (beyond them a run would not finish in any reasonable time).
MAX_WALKERS = 10_000
MAX_STEPS = 10_000_000
MAX_BIAS_PAIRS = 1_000
MAX_BIAS_ITERATIONS = 100


def _integer(name: str, value: object, minimum: int, maximum: int) -> int:
    rule = Interval(minimum, maximum, "both", f"an integer from {minimum} to {maximum}", integer=True)
    return rule.check(value, f"{name}=")


def _precision(covariance: np.ndarray) -> np.ndarray:
    """Inverse of a covariance, computed on its correlation matrix (scale-safe)."""
    sd = np.sqrt(np.diag(covariance))
    return np.linalg.pinv(covariance / np.outer(sd, sd), hermitian=True) / np.outer(sd, sd)


def _schur(gram: np.ndarray, keep: list[int]) -> np.ndarray:
    """Information on the kept coefficients with the others unknown (Schur complement)."""
    rest = [i for i in range(gram.shape[0]) if i not in keep]
    out = gram[np.ix_(keep, keep)]
    if rest:
        sd = np.sqrt(np.diag(gram))
        g_oo = gram[np.ix_(rest, rest)] / np.outer(sd[rest], sd[rest])
        g_ok = gram[np.ix_(rest, keep)] / sd[rest][:, None]
        out = out - g_ok.T @ np.linalg.pinv(g_oo, hermitian=True) @ g_ok
    return 0.5 * (out + out.T)


def _check_start(name: str, prior: Prior, value: float, unit: str) -> None:
    if not np.isfinite(prior.logpdf(np.array([value]))[0]):
        raise PriorError(
            f"the prior of {name} ({prior.describe()}) excludes the identifier's estimate {value:.6g} "
            f"{unit}: widen the prior of {name} (priors=) or check its units"
        )


def select_params(model: Model, params: str | Iterable[str]) -> list[int]:
    """Indices of the coefficients to sample.

    Parameters
    ----------
    params
        ``"damping"`` (every velocity-dependent term, the friction of Eq. 14
        and 24 with the viscous ``v``), ``"all"``, or terms (a comma-separated
        string or a list, any spelling).
    """
    if isinstance(params, str) and params.strip().lower() in ("damping", "friction"):
        idx = [i for i, t in enumerate(model.terms) if t.family == "damping"]
        if not idx:
            raise InputError(f"the model ({model}) has no damping (velocity-dependent) terms to sample")
        return idx
    if isinstance(params, str) and params.strip().lower() == "all":
        return list(range(len(model)))
    wanted = Model.from_spec(params, defaults=False)
    missing = [t.name for t in wanted.terms if t.name not in model.names]
    if missing:
        raise InputError(f"params= names {', '.join(missing)}, which the model ({model}) does not contain")
    return sorted(model.index(t) for t in wanted.terms)


def check_params_spelling(params: str | Iterable[str]) -> None:
    """Refuse sampled-coefficient names no model could have, before any work (a typo fails at once).

    Keywords (``damping``, ``friction``, ``all``, ``elements``), one-DOF terms, a
    structure's elements on connections (``(z1-z2)^3``) and its linear
    unknowns (``K[1,2]``, ``C[2,2]``, ``s[1]``) are accepted; whether the model
    has them is checked when the posterior runs.
    """
    if isinstance(params, str):
        if params.strip().lower() in PARAM_KEYWORDS:
            return
        try:
            Model.from_spec(params, defaults=False)
            return
        except NlidError as exc:
            first = exc
        from .structure import check_structure_names

        try:
            check_structure_names(params)
        except NlidError:
            raise first from None
        return
    if not all(isinstance(p, str) for p in params):
        raise InputError(f"params must be 'damping', 'all' or terms, got {params!r}")
    for name in params:
        check_params_spelling(name)


class PosteriorSampler:
    """Posterior over chosen coefficients with emcee, started from an identification.

    The constructor only stores settings; :meth:`run` does the work.

    Parameters
    ----------
    params
        ``"damping"`` (default), ``"all"`` or a list of terms; the other
        coefficients stay fixed at the identifier's estimate.
    priors
        Priors overriding the defaults, ``{term: "normal(m, s)" | Prior}`` or
        ``["term=spec", ...]`` (see :mod:`nlid.bayes.priors`).
    walkers
        Number of walkers (default ``max(32, 8 d)``).
    max_steps
        Give up after this many steps without convergence.
    seed
        Seed of the bias simulation, the initial ball and the sampler.
    move
        ``"de"`` (differential evolution, default) or ``"stretch"``.
    bias_correction
        Correct the errors-in-variables bias by simulation (see
        :mod:`nlid.bayes.bias`; for a structure :func:`nlid.bayes.structure.correct_bias`).
        Default (``None``): on.
    bias_pairs
        Antithetic noise pairs per step of that correction (at least 2).
    bias_iterations
        Fixed-point steps of that correction.
    noise
        Known noise standard deviation on ``z`` (and ``v``), e.g. ``{"z": 4e-4}``
        (m, m/s); the others are established from the record or refused
        (:func:`nlid.bayes.noise.channel_noise`).
    cutoff
        Equation band in Hz (default: the shared filter's suggestion).
    others
        What happens to the coefficients that are not sampled:
        ``"marginal"`` (default) integrates them out of the likelihood
        analytically (exact for the linear-in-coefficients model), which
        carries their uncertainty into the sampled ones; ``"fixed"`` keeps
        them at the identifier's estimate (narrower intervals that covered
        the truth less often: see docs/posterior.md).
    """

    def __init__(
        self,
        params: str | Iterable[str] = "damping",
        *,
        priors: Mapping[str, str | Prior] | Iterable[str] | None = None,
        walkers: int | None = None,
        max_steps: int = 20000,
        seed: int = 0,
        move: str = "de",
        bias_correction: bool | None = None,
        bias_pairs: int = 4,
        bias_iterations: int = 3,
        noise: Mapping[str, float] | None = None,
        cutoff: float | None = None,
        others: str = "marginal",
    ) -> None:
        Options(OTHERS).check(others, "others")
        check_seed(seed)
        if walkers is not None:
            _integer("walkers", walkers, 2, MAX_WALKERS)
        _integer("max_steps", max_steps, 1, MAX_STEPS)
        _integer("bias_pairs", bias_pairs, 1, MAX_BIAS_PAIRS)
        _integer("bias_iterations", bias_iterations, 1, MAX_BIAS_ITERATIONS)
        if bias_correction is not None and not isinstance(bias_correction, (bool, np.bool_)):
            raise InputError(f"bias_correction must be true or false, got {bias_correction!r}")
        check_cutoff(cutoff)  # the record's Nyquist frequency is checked when it is known (run)
        check_noise_sd(noise)  # and each level against the record's channel
        check_params_spelling(params)
        for name in parse_prior_assignments(priors, canonical=lambda name: name):  # specs, then each name
            check_params_spelling([name])
        if move not in MOVES:
            raise InputError(f"unknown move {move!r}; choose one of {', '.join(MOVES)}")
        self.params = params
        self.priors = priors
        self.walkers = walkers
        self.max_steps = int(max_steps)
        self.seed = int(seed)
        self.move = move
        self.bias_correction = None if bias_correction is None else bool(bias_correction)
        self.bias_pairs = int(bias_pairs)
        self.bias_iterations = int(bias_iterations)
        self.noise = None if noise is None else dict(noise)
        self.cutoff = cutoff
        self.others = others

    def run(self, record: Record, fit: IdentifiedModel) -> Posterior:
        """Sample the posterior of the chosen coefficients.

        Parameters
        ----------
        record
            The data the identification used.
        fit
            The identified model (:func:`nlid.identify`): the model, the
            starting point, the mass, and the values of the coefficients
            that are not sampled.

        Raises
        ------
        InputError
            Bad parameters or priors, a prior that excludes the estimate,
            degenerate (collinear) parameters, unknown mass.
        PriorConflictError
            A prior lies far from what the data say (:func:`~nlid.bayes.priors.prior_conflicts`).
        ConvergenceError
            The chains did not converge within ``max_steps``.
        IdentificationError
            The samples contradict themselves or their priors
            (:meth:`Posterior.problems`), or a figure is not finite.
        """
        with numerics.collect_warnings() as caught:
            try:
                posterior, prior_sd = self._run(record, fit)
            except IdentificationError as exc:
                failed: IdentificationError | None = exc
            else:
                failed = None
        if failed is not None:
            if caught:
                raise type(failed)(f"{failed} (numpy: {numerics.describe_warnings(caught)})") from None
            raise failed
        problems = posterior.problems(prior_sd)
        if problems:
            why = f" (numpy: {numerics.describe_warnings(caught)})" if caught else ""
            raise IdentificationError(
                f"the posterior cannot be trusted: {'; '.join(problems)}{why}; the walkers have not explored "
                "one posterior: check the priors and the model, or sample longer (max_steps=)"
            )
        if caught:
            posterior.warnings = (*posterior.warnings, f"numerical warnings: {numerics.describe_warnings(caught)}")
        posterior.record = record
        posterior.force_hold = (record.force_hold, force_hold_source(record.meta))
        if not fit.indexed:  # what physics forbids, and a correction beyond its bound
            force, unit = str(dict(record.units).get("f", "N")), str(dict(record.units).get("z", "m"))
            posterior.channel_units = {"f": force, "z": unit}
            if posterior.units is None:  # each coefficient in the record's own units (s^2/V for volts)
                posterior.units = {n: parse_term(n).coefficient_unit_in(force, unit) for n in posterior.names}
            shifts = dict(posterior.likelihood.info.get("bias_shift_sd") or {})  # every term the correction moved
            found = correction_flags(shifts, fit, record, posterior.likelihood, unit)
            posterior.flags = (*fit.flags, *found)
        return posterior

    def _run(self, record: Record, fit: IdentifiedModel) -> tuple[Posterior, dict[str, float]]:
        start_time = time.perf_counter()
        if not isinstance(fit, Identified):
            raise InputError(f"fit must be the IdentifiedModel nlid.identify returns, got {type(fit).__name__}")
        if fit.indexed:
            return self._sample(self._prepare_structure(record, fit), start_time)
        return self._sample(self._prepare(record, fit), start_time)

    def _check_sampled(self, gram: np.ndarray, idx: list[int], names: tuple[str, ...]) -> None:
        """Refuse collinear sampled coefficients: their information with the others integrated out (or fixed)."""
        check_identifiable(_schur(gram, idx) if self.others == "marginal" else gram[np.ix_(idx, idx)], names)

    def _user_priors(self, names: tuple[str, ...], canonical: Any = None) -> dict[str, Prior]:
        user_priors = parse_prior_assignments(self.priors, canonical=canonical)
        not_sampled = [n for n in user_priors if n not in names]
        if not_sampled:
            raise PriorError(
                f"a prior is given for {', '.join(not_sampled)}, which is not sampled; "
                "sample it too (params=) or drop the prior"
            )
        return user_priors

    def _prepare(self, record: Record, fit: IdentifiedModel) -> _Problem:
        """The one-DOF likelihood (Eq. 25's balance, bias-corrected by simulation)."""
        model = fit.model
        if fit.mass is None:
            raise InputError("the posterior needs the mass: give mass= (in kg) or use a method that estimates it")
        # each known noise level against its channel, whether or not the bias correction uses it
        scales = {
            c: float(np.std(getattr(record, c))) for c in (self.noise or {}) if getattr(record, c, None) is not None
        }
        check_noise_sd(self.noise, scales=scales)
        idx = select_params(model, self.params)
        names = tuple(model.names[i] for i in idx)
        theta0 = fit.theta.copy()
        user_priors = self._user_priors(names)
        for name, prior in user_priors.items():
            _check_start(name, prior, theta0[model.index(name)], parse_term(name).coefficient_unit)
        seq_bias, seq_mcmc = np.random.SeedSequence(self.seed).spawn(2)
        data = regression_data(record, model, cutoff=self.cutoff)
        # collinear sampled terms are refused before the (slower) bias correction
        self._check_sampled(data.G.T @ data.G, idx, names)
        lik = build_likelihood(
            record,
            model,
            float(fit.mass),
            bias_correction=self.bias_correction is not False,
            pairs=self.bias_pairs,
            iterations=self.bias_iterations,
            noise=self.noise,
            rng=np.random.default_rng(seq_bias),
            data=data,
        )
        return _Problem(
            model=model,
            idx=idx,
            theta0=theta0,
            lik=lik,
            user_priors=user_priors,
            seed=seq_mcmc,
            mass=float(fit.mass),
            method=fit.method,
            data=data,
            reference=dict(Reference.from_meta(record.meta).coefficients or {}),
        )

    def _prepare_structure(self, record: Any, fit: Any) -> _Problem:
        """A structure's likelihood (:mod:`nlid.bayes.structure`): every DOF's balance, bias-corrected by simulation."""
        from .structure import select_structure_params, structure_likelihood, structure_warnings

        if not (isinstance(record, Record) and record.indexed):
            raise InputError(
                f"the fit is a structure of {fit.structure.n_dofs} DOFs but the record is not a structure record"
            )
        if self.noise:
            raise InputError(
                "noise= sets the one-DOF correction's levels; a structure's are each displacement's noise floor"
            )
        seq_bias, seq_mcmc = np.random.SeedSequence(self.seed).spawn(2)
        correct = self.bias_correction is not False
        chosen: dict[str, Any] = {}

        def choose(gram: np.ndarray, parameters: Any) -> None:
            # the sampled unknowns, refused when collinear before the (slower) bias correction
            chosen["idx"] = select_structure_params(parameters, self.params)
            self._check_sampled(gram, chosen["idx"], tuple(parameters.names[i] for i in chosen["idx"]))

        lik, parameters, _, start = structure_likelihood(
            record,
            fit,
            cutoff=self.cutoff,
            bias_correction=correct,
            pairs=self.bias_pairs,
            iterations=self.bias_iterations,
            rng=np.random.default_rng(seq_bias),
            check=choose,
        )
        idx = chosen["idx"]
        names = tuple(parameters.names[i] for i in idx)
        theta0 = parameters.vector(start)
        user_priors = self._user_priors(names, canonical=parameters.canonical)
        for name, prior in user_priors.items():
            _check_start(name, prior, theta0[parameters.index(name)], parameters.unit(name))
        reference = {}
        # a structure preset's truth (nlid.simulation.structure_presets)
        truth = (record.meta or {}).get("reference") or {}
        for name, value in dict(truth.get("coefficients") or {}).items():
            try:
                reference[parameters.canonical(name)] = float(value)
            except NlidError:  # a reference in the other orientation, or not an unknown of this fit
                continue
        return _Problem(
            model=parameters,
            idx=idx,
            theta0=theta0,
            lik=lik,
            user_priors=user_priors,
            seed=seq_mcmc,
            mass=np.asarray(fit.structure.M, dtype=float).tolist(),
            method=fit.method,
            data=None,
            reference=reference,
            warnings=structure_warnings(record, corrected=correct),
            units={n: parameters.unit(n) for n in parameters.names},
        )

    def _sample(self, problem: _Problem, start_time: float) -> tuple[Posterior, dict[str, float]]:
        """Priors, the sampled coefficients' target (marginal or conditional) and emcee until converged."""
        model, idx, lik, theta0 = problem.model, problem.idx, problem.lik, problem.theta0
        names = tuple(model.names[i] for i in idx)
        priors = default_priors(lik.stats, model.names)
        priors.update(problem.user_priors)
        prior_logpdf = joint_logpdf([priors[n] for n in names])
        if self.others == "marginal":
            target = lik.reduced(idx)
            mean, cov = target.center, target.covariance
            check_identifiable(_precision(cov), names)

            def log_prob(x: np.ndarray) -> np.ndarray:
                lp = prior_logpdf(x)
                good = np.isfinite(lp)
                lp[good] += target(x[good])
                return lp

        else:
            # the conditional precision of the sampled block decides identifiability
            check_identifiable(_precision(lik.covariance)[np.ix_(idx, idx)], names)
            mean, cov = lik.conditional(idx, theta0)
            full = theta0.copy()

            def log_prob(x: np.ndarray) -> np.ndarray:
                lp = prior_logpdf(x)
                good = np.isfinite(lp)
                theta = np.tile(full, (int(good.sum()), 1))
                theta[:, idx] = x[good]
                lp[good] += lik(theta)
                return lp

        conflicts = prior_conflicts(names, priors, mean, cov)
        if conflicts:
            raise PriorConflictError(
                f"prior in conflict with the data: {'; '.join(conflicts)}; a posterior between the two would "
                "describe neither: correct or widen the prior (priors=), or check the model and the data"
            )
        walkers = self.walkers if self.walkers is not None else max(32, 8 * len(idx))
        chains = run_until_converged(
            log_prob,
            theta0[idx],
            START_SPREAD * np.sqrt(np.diag(cov)),
            walkers=walkers,
            max_steps=self.max_steps,
            seed=problem.seed,
            move=self.move,
            names=names,
        )
        prior_sd = {n: priors[n].sd for n in names if isinstance(priors[n], Normal)}
        return Posterior(
            model=model,
            names=names,
            chains=chains,
            start=model.as_dict(theta0),
            priors={n: priors[n].describe() for n in names},
            likelihood=lik,
            mass=problem.mass,
            method=problem.method,
            seconds=time.perf_counter() - start_time,
            others=self.others,
            gaussian=(mean, cov),
            data=problem.data,
            reference=problem.reference,
            warnings=problem.warnings,
            units=problem.units,
        ), prior_sd


@dataclass(frozen=True)
class _Problem:
    """What the sampler needs from a one-DOF model or a structure: the likelihood and the sampled block."""

    model: Any
    idx: list[int]
    theta0: np.ndarray
    lik: Any
    user_priors: dict[str, Prior]
    seed: np.random.SeedSequence
    mass: Any
    method: str
    data: Any
    reference: dict[str, float]
    warnings: tuple[str, ...] = ()
    units: dict[str, str] | None = None


def sample_posterior(record: Record, fit: IdentifiedModel, **settings: Any) -> Posterior:
    """``PosteriorSampler(**settings).run(record, fit)``."""
    return PosteriorSampler(**settings).run(record, fit)
