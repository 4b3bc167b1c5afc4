"""Bayesian posteriors on the friction (and other) coefficients, sampled with emcee.

Start from any identification (:func:`nlid.identify`); sample the chosen
coefficients with the others integrated out (or fixed at the identifier's
estimate, ``others="fixed"``)::

    from nlid import identify
    from nlid.bayes import sample_posterior

    result = identify(record, "z^3, z^2, v*|v|", "rfs", mass=0.2)
    post = sample_posterior(record, result, params="damping", seed=0)
    print(post.summary())   # the table (a nlid.report.summary.Summary; .as_html(), .as_markdown())
    post.summary_dict()     # {term: {"mean", "sd", "q05", "q50", "q95"}}
    post.save("out/")       # table, JSON, samples (NPZ), corner/trace/damping figures

Modules: :mod:`~nlid.bayes.likelihood` (the adjusted equation-error
likelihood from sufficient statistics), :mod:`~nlid.bayes.bias`
(errors-in-variables correction by simulation), :mod:`~nlid.bayes.noise`
(the noise levels that correction simulates), :mod:`~nlid.bayes.priors`,
:mod:`~nlid.bayes.sampler` (emcee until converged),
:mod:`~nlid.bayes.result`, :mod:`~nlid.bayes.plots`,
:mod:`~nlid.bayes.study` (the study runner's hook). The assumptions are
written out in ``docs/posterior.md``.
"""

from .bias import BiasCorrection, simulate_bias
from .inference import PosteriorSampler, sample_posterior, select_params
from .likelihood import DegenerateParametersError, Likelihood, SufficientStatistics, build_likelihood
from .noise import NoiseLevel, UnknownNoiseError, channel_noise
from .priors import Flat, Normal, PriorError, Uniform, default_priors, parse_prior
from .result import DampingBand, Posterior
from .sampler import Chains, ConvergenceError, run_until_converged
from .study import PosteriorMetrics, posterior_metrics

__all__ = [
    "PosteriorSampler",
    "sample_posterior",
    "select_params",
    "Posterior",
    "DampingBand",
    "Likelihood",
    "SufficientStatistics",
    "build_likelihood",
    "BiasCorrection",
    "simulate_bias",
    "channel_noise",
    "NoiseLevel",
    "UnknownNoiseError",
    "Normal",
    "Uniform",
    "Flat",
    "parse_prior",
    "default_priors",
    "Chains",
    "run_until_converged",
    "ConvergenceError",
    "DegenerateParametersError",
    "PriorError",
    "PosteriorMetrics",
    "posterior_metrics",
]
