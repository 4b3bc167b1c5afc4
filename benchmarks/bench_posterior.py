"""Posterior speed (issue 6).

1. The posterior of the four friction coefficients c0..c3 of the
   ``paper-experimental`` preset (61 440 samples, 2 % noise on z and a),
   started from rfs with the true px(z) roots: wall time of
   ``sample_posterior`` (force balance, bias correction by simulation,
   sandwich, emcee until converged), split into its parts, and its CPU time
   (all threads). Target (issue 26): <= 0.8 s on a quiet 2-core machine.
2. The posterior of ``v`` and ``v*|v|`` of ``paper-numerical`` (122 880
   samples) with 2 % noise on z, v and a (issue 15: the velocity's noise
   level is fitted from v - dz/dt and its uncertainty propagated).
3. The cost of one likelihood evaluation (32 walkers at once, as emcee calls
   it) built from records of 1e4 and 1e6 samples: it must not grow with the
   record length. The one-off cost of forming the sufficient statistics is
   shown beside it (it is linear in N).

    python benchmarks/bench_posterior.py [--repeat 5]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

import numpy as np  # noqa: E402
from _common import median_time  # noqa: E402

from nlid import identify  # noqa: E402
from nlid.bayes import sample_posterior  # noqa: E402
from nlid.bayes.likelihood import build_likelihood  # noqa: E402
from nlid.estimation import balance
from nlid.simulation.presets import get_preset  # noqa: E402

LOOPS = 2000
FRICTION = "sign(v)*|px(z)|, v*|px(z)|, v*|v|*|px(z)|, v^3*|px(z)|"


def friction_posterior(repeat: int) -> None:
    preset = get_preset("paper-experimental")
    model = preset.model()
    record = preset.simulate(0, noise=0.02, channels=("z", "a"))
    result = identify(record, model, "rfs", mass=preset.mass)
    sample_posterior(record, result, params=FRICTION, seed=0)  # warm-up (numba, imports)
    seconds, cpu, parts = [], [], []
    for seed in range(repeat):
        t0 = time.perf_counter()
        data = balance.regression_data(record, model)
        t1 = time.perf_counter()
        build_likelihood(record, model, preset.mass, data=data, bias_correction=False)
        t2 = time.perf_counter()
        build_likelihood(record, model, preset.mass, data=data, rng=np.random.default_rng(seed))
        t3 = time.perf_counter()
        c0 = time.process_time()
        post = sample_posterior(record, result, params=FRICTION, seed=seed)
        cpu.append(time.process_time() - c0)  # every thread of this process: steadier than the wall under load
        seconds.append(post.seconds)
        parts.append((t1 - t0, t2 - t1, t3 - t2))
    med = float(np.median(seconds))
    p = np.median(np.array(parts), axis=0)
    tau = max(post.tau.values())
    print(f"paper-experimental, {record.n} samples, 2 % noise on z and a, 4 friction coefficients:")
    print(
        f"  sample_posterior median {med:.2f} s over {repeat} seeds (min {min(seconds):.2f}, max {max(seconds):.2f}); "
        f"CPU {np.median(cpu):.2f} s; load {os.getloadavg()[0]:.1f}; target <= 0.8 s"
    )
    print(
        f"  parts: force balance {p[0]:.2f} s, sandwich {p[1]:.2f} s, sandwich + bias correction {p[2]:.2f} s, "
        f"emcee ~{med - p[0] - p[2]:.2f} s"
    )
    print(
        f"  last run: {post.chains.walkers} walkers x {post.chains.steps} steps, max tau {tau:.1f} "
        f"({post.chains.steps / tau:.0f} tau), acceptance {post.chains.acceptance:.2f}, "
        f"min ESS {min(post.n_effective.values()):.0f}"
    )


def velocity_posterior(repeat: int) -> None:
    preset = get_preset("paper-numerical")
    model = preset.model()
    record = preset.simulate(0, noise=0.02, channels=("z", "v", "a"))
    result = identify(record, model, "rfs", mass=preset.mass)
    sample_posterior(record, result, seed=0)  # warm-up
    seconds = [sample_posterior(record, result, seed=seed).seconds for seed in range(repeat)]
    print(f"paper-numerical, {record.n} samples, 2 % noise on z, v and a, v and v*|v|:")
    print(f"  sample_posterior median {np.median(seconds):.2f} s over {repeat} seeds")


def likelihood_cost(repeat: int) -> None:
    preset = get_preset("paper-numerical")
    model = preset.model()
    print("one likelihood evaluation (32 walkers at once), paper-numerical model, 2 % noise on z and a:")
    theta = None
    for n in (10_000, 1_000_000):
        record = preset.with_overrides(duration=n / preset.fs).simulate(1, noise=0.02, channels=("z", "a"))
        start = time.perf_counter()
        lik = build_likelihood(record, model, preset.mass, bias_correction=False)
        setup = time.perf_counter() - start
        rng = np.random.default_rng(0)
        sd = np.sqrt(np.diag(lik.covariance))
        theta = lik.center + sd * rng.standard_normal((32, sd.size))
        med, _ = median_time(lambda lik=lik, theta=theta: [lik(theta) for _ in range(LOOPS)], repeat=repeat)
        print(
            f"  N = {record.n:>9,d}: {1e6 * med / LOOPS:6.1f} us per evaluation "
            f"(median of {repeat} x {LOOPS}); building the statistics took {setup:.2f} s"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeat", type=int, default=5, help="runs per measurement (median reported)")
    args = parser.parse_args()
    friction_posterior(args.repeat)
    velocity_posterior(args.repeat)
    likelihood_cost(args.repeat)


if __name__ == "__main__":
    main()
