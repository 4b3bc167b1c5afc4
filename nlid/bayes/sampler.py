"""Running emcee's ensemble sampler until it has converged.

Convergence rule
    The chains are extended in chunks; after each chunk the integrated
    autocorrelation time ``tau`` of every parameter is estimated with
    :func:`emcee.autocorr.integrated_time` (Sokal's adaptive window, over all
    walkers). The run has converged when its length is at least
    ``TAU_MULTIPLE`` (50) times the largest ``tau`` and that ``tau`` moved by
    less than ``TAU_STABILITY`` (10 %) since the previous check. Then the
    first ``BURN_TAUS`` (5) ``tau`` steps are discarded as burn-in and the
    rest thinned by ``tau / 2``. A run that reaches ``max_steps`` first raises
    :class:`ConvergenceError`, which says how many steps to ask for.

Moves
    The default is emcee's differential-evolution move (ter Braak 2006,
    Nelson et al. 2014), which on near-Gaussian posteriors of 2-9 parameters
    gave integrated autocorrelation times 2-4 times shorter than the default
    stretch move (measured: tau 18 vs 59 steps on a correlated 5-d
    Gaussian); ``move="stretch"`` selects the latter.

The log-probability is vectorised (``vectorize=True``): it receives all the
walkers of a half-ensemble at once.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass

import emcee
import numpy as np

from ..errors import IdentificationError, InputError
from ..runtime.progress import progress_line

__all__ = ["Chains", "ConvergenceError", "run_until_converged", "TAU_MULTIPLE", "MOVES"]

#: Required chain length in integrated autocorrelation times.
TAU_MULTIPLE = 50.0
#: Required relative stability of the largest tau between two checks.
TAU_STABILITY = 0.1
#: Burn-in discarded, in autocorrelation times.
BURN_TAUS = 5.0
#: Available moves.
MOVES = ("de", "stretch")


class ConvergenceError(IdentificationError):
    """The chains did not converge within the allowed number of steps."""


@dataclass(frozen=True)
class Chains:
    """A converged ensemble run.

    Attributes
    ----------
    chain
        Every step of every walker, shape ``(steps, walkers, d)`` (burn-in
        included, for trace plots).
    log_prob
        Log-probability of each, shape ``(steps, walkers)``.
    tau
        Integrated autocorrelation time of each parameter (steps).
    acceptance
        Mean acceptance fraction of the walkers.
    burn, thin
        Steps discarded at the start and the thinning of :attr:`samples`.
    """

    chain: np.ndarray
    log_prob: np.ndarray
    tau: np.ndarray
    acceptance: float
    burn: int
    thin: int

    @property
    def steps(self) -> int:
        """Length of the chains."""
        return int(self.chain.shape[0])

    @property
    def walkers(self) -> int:
        """Number of walkers."""
        return int(self.chain.shape[1])

    @property
    def samples(self) -> np.ndarray:
        """Posterior samples after burn-in and thinning, shape ``(n, d)``."""
        kept = self.chain[self.burn :: self.thin]
        return kept.reshape(-1, self.chain.shape[2])

    @property
    def n_effective(self) -> np.ndarray:
        """Effective sample size of each parameter: walkers x kept steps / tau."""
        return self.walkers * (self.steps - self.burn) / self.tau


class _Vectorised:
    """emcee's red-blue ``propose`` with the acceptance test of a half-ensemble as one array operation.

    emcee (3.1) draws one uniform number per walker and compares it in a Python loop; here the same
    numbers are drawn in one call (a legacy ``RandomState`` gives ``rand(k)`` as ``k`` calls of ``rand()``)
    and compared at once: the same proposals, the same acceptances, the same chains to the bit
    (``tests/bayes/test_sampler.py`` checks them against emcee's own moves). Everything else is emcee's.
    """

    def propose(self, model, state):  # noqa: D102 - emcee's RedBlueMove.propose
        nwalkers, ndim = state.coords.shape
        if nwalkers < 2 * ndim and not self.live_dangerously:
            raise RuntimeError("It is unadvisable to use a red-blue move with fewer walkers than twice the dimension")
        self.setup(state.coords)
        accepted = np.zeros(nwalkers, dtype=bool)
        all_inds = np.arange(nwalkers)
        inds = all_inds % self.nsplits
        if self.randomize_split:
            model.random.shuffle(inds)
        for split in range(self.nsplits):
            subset = inds == split
            sets = [state.coords[inds == j] for j in range(self.nsplits)]
            q, factors = self.get_proposal(sets[split], sets[:split] + sets[split + 1 :], model.random)
            new_log_probs, new_blobs = model.compute_log_prob_fn(q)
            members = all_inds[subset]
            lnpdiff = factors + new_log_probs - state.log_prob[members]
            accepted[members] = lnpdiff > np.log(model.random.rand(members.size))
            state = self.update(state, emcee.State(q, log_prob=new_log_probs, blobs=new_blobs), accepted, subset)
        return state, accepted


@functools.lru_cache(maxsize=4)
def _ordered_pairs(n: int) -> np.ndarray:
    """Every ordered pair ``(i, j)``, ``i != j``, of ``n`` walkers, in emcee's order (its DEMove draws from these)."""
    rows, cols = np.tril_indices(n, -1)
    pairs = np.column_stack([np.concatenate([rows, cols]), np.concatenate([cols, rows])])
    pairs.setflags(write=False)
    return pairs


class _DEMove(_Vectorised, emcee.moves.DEMove):
    """:class:`emcee.moves.DEMove` with the vectorised acceptance test of :class:`_Vectorised`.

    Its proposal is emcee's, drawn with less overhead: ``randint(0, n, size)`` is what a legacy
    ``RandomState.choice(n, size, replace=True)`` draws, and ``c[j] - c[i]`` is ``np.diff`` of the pair.
    """

    def get_proposal(self, s, c, random):  # noqa: D102 - emcee's DEMove.get_proposal
        c = np.concatenate(c, axis=0)
        ns = s.shape[0]
        pairs = _ordered_pairs(c.shape[0])
        picked = pairs[random.randint(0, pairs.shape[0], size=ns)]
        diffs = c[picked[:, 1]] - c[picked[:, 0]]
        gamma = self.g0 * (1 + self.sigma * random.randn(ns, 1))
        return s + gamma * diffs, np.zeros(ns, dtype=np.float64)


class _StretchMove(_Vectorised, emcee.moves.StretchMove):
    """:class:`emcee.moves.StretchMove` with the vectorised acceptance test of :class:`_Vectorised`."""


class _Sampler(emcee.EnsembleSampler):
    """emcee's sampler for a vectorised log-probability that returns one float per walker and no blobs.

    emcee (3.1) converts the returned array element by element while it looks for blobs; here it is taken
    as it is. The same checks (finite positions, no NaN returned) with emcee's messages.
    """

    @property
    def random_state(self):
        """``None``: the generator goes on where it stands.

        emcee copies the generator's whole state (624 words) into every step's
        :class:`emcee.State` (40 us a step) so that a run can be continued from
        that state; the next chunk of :func:`run_until_converged` continues with
        this sampler, whose generator is already there. A state given to
        :meth:`sample` (the first chunk's) is still set.
        """
        return None

    @random_state.setter
    def random_state(self, state):
        if state is not None:
            self._random.set_state(state)

    def compute_log_prob(self, coords):  # noqa: D102 - emcee's EnsembleSampler.compute_log_prob
        if not np.all(np.isfinite(coords)):
            return super().compute_log_prob(coords)  # emcee's own error for the infinite or NaN position
        log_prob = np.asarray(self.log_prob_fn(coords), dtype=float)
        if log_prob.shape != (coords.shape[0],):
            raise ValueError(f"the log-probability returned shape {log_prob.shape} for {coords.shape[0]} walkers")
        if np.any(np.isnan(log_prob)):
            raise ValueError("Probability function returned NaN")
        return log_prob, None


#: The faster classes above repeat emcee 3.1's draws exactly (checked by tests/bayes/test_sampler.py); another
#: emcee gets its own classes, so that a change in its internals can never change nlid's chains silently.
FAST_EMCEE = emcee.__version__.startswith("3.1.")


def _move(name: str):
    if name == "de":
        return _DEMove() if FAST_EMCEE else emcee.moves.DEMove()
    if name == "stretch":
        return _StretchMove() if FAST_EMCEE else emcee.moves.StretchMove()
    raise InputError(f"unknown move {name!r}; choose one of {', '.join(MOVES)}")


def run_until_converged(
    log_prob: Callable[[np.ndarray], np.ndarray],
    start: np.ndarray,
    spread: np.ndarray,
    *,
    walkers: int,
    max_steps: int,
    seed: int | np.random.SeedSequence = 0,
    move: str = "de",
    chunk: int = 250,
    tau_multiple: float = TAU_MULTIPLE,
    names: tuple[str, ...] | None = None,
) -> Chains:
    """Sample ``log_prob`` with emcee until the chains have converged.

    Parameters
    ----------
    log_prob
        Vectorised log-probability: ``(W, d)`` positions to ``(W,)`` values.
    start
        Centre of the initial ball (the identifier's estimate), shape ``(d,)``.
    spread
        Standard deviation of the initial ball per parameter.
    walkers
        Number of walkers (at least ``2 d``).
    max_steps
        Give up (:class:`ConvergenceError`) after this many steps.
    seed
        Seed of the initial ball and of emcee's random state.
    move
        ``"de"`` (differential evolution) or ``"stretch"``.
    chunk
        Steps between convergence checks.
    tau_multiple
        Required chain length in autocorrelation times.
    names
        Parameter names for messages.

    Raises
    ------
    InputError
        Too few walkers or steps, or an initial ball outside the prior.
    ConvergenceError
        When ``max_steps`` is reached before convergence.
    """
    start = np.asarray(start, dtype=float)
    spread = np.asarray(spread, dtype=float)
    ndim = start.size
    names = names or tuple(f"theta[{i}]" for i in range(ndim))
    if walkers < 2 * ndim:
        raise InputError(f"emcee needs at least 2 x {ndim} = {2 * ndim} walkers for {ndim} parameters, got {walkers}")
    if max_steps < 1:
        raise InputError(f"the number of steps must be positive, got {max_steps}")
    seq = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
    ball_seq, emcee_seq = seq.spawn(2)
    rng = np.random.default_rng(ball_seq)
    p0 = start + spread * rng.standard_normal((walkers, ndim))
    lp0 = log_prob(p0)
    for shrink in (0.1, 0.01, 0.0):  # walkers outside the prior are drawn again, closer to the start
        bad = ~np.isfinite(lp0)
        if not bad.any():
            break
        p0[bad] = start + shrink * spread * rng.standard_normal((int(bad.sum()), ndim))
        lp0[bad] = log_prob(p0[bad])
    if not np.all(np.isfinite(lp0)):
        raise InputError("the initial walkers have zero posterior density: the prior excludes the start")
    sampler_class = _Sampler if FAST_EMCEE else emcee.EnsembleSampler
    sampler = sampler_class(walkers, ndim, log_prob, vectorize=True, moves=_move(move))
    state = emcee.State(p0, log_prob=lp0, random_state=np.random.RandomState(np.random.MT19937(emcee_seq)).get_state())
    previous = np.inf
    tau = np.full(ndim, np.nan)
    steps = 0
    converged = False
    # a terminal-only line when the caller asked for progress (nlid.runtime.progress; emcee's own bar needs tqdm)
    with progress_line("posterior", total=max_steps, unit="steps") as line:
        while steps < max_steps and not converged:
            n = min(chunk, max_steps - steps)
            for state in sampler.sample(state, iterations=n, skip_initial_state_check=True):  # noqa: B007, B020
                steps += 1  # the generator emcee's run_mcmc drains: the same chains, step by step
                line.update(steps)
            tau = sampler.get_autocorr_time(tol=0, quiet=True)
            worst = float(np.max(tau))
            if np.isfinite(worst):  # drawn at once (once a chunk): a run shorter than the redraw interval shows it
                note = f"autocorrelation time {worst:.0f}, run needs {tau_multiple * worst:.0f}"
                line.update(steps, note=note, force=True)
            converged = steps >= tau_multiple * worst and abs(worst - previous) <= TAU_STABILITY * worst
            previous = worst
    if converged:
        burn = int(np.ceil(BURN_TAUS * worst))
        thin = max(1, int(0.5 * float(np.min(tau))))
        return Chains(
            chain=sampler.get_chain(),
            log_prob=sampler.get_log_prob(),
            tau=np.asarray(tau, dtype=float),
            acceptance=float(np.mean(sampler.acceptance_fraction)),
            burn=burn,
            thin=thin,
        )
    if not np.any(np.isfinite(tau)):  # a few steps: no autocorrelation time can be estimated yet
        raise ConvergenceError(
            f"the chains did not converge in {max_steps} steps: too few steps to estimate the autocorrelation "
            f"time; raise max_steps= (e.g. max_steps={max(1000, 10 * max_steps)})"
        )
    worst = float(np.nanmax(tau))
    slowest = names[int(np.nanargmax(tau))]
    need = int(np.ceil(tau_multiple * worst * 1.2 / 1000.0) * 1000)
    raise ConvergenceError(
        f"the chains did not converge in {max_steps} steps: the autocorrelation time of {slowest} is about "
        f"{worst:.0f} steps and a converged run needs at least {tau_multiple:g} of them "
        f"(~{int(tau_multiple * worst)} steps, and a stable estimate); "
        f"raise max_steps= (e.g. max_steps={max(need, 2 * max_steps)})"
    )
