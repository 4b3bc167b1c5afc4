"""How far the errors-in-variables correction moves the estimates where it is right (the presets), in sd.

For each preset, noise level and seed: the least-squares estimate of the force balance, the corrected one
(:func:`nlid.bayes.likelihood.build_likelihood`, as ``nlid posterior`` forms it), each term's shift in
standard deviations of the corrected estimate, and each estimate's distance from the truth in the same
sd. The bound :data:`nlid.bayes.result.CORRECTION_BOUND_SD` was chosen from the largest shift printed here.

Usage::

    python benchmarks/posterior_correction_sizes.py [--seeds 3]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import nlid
from nlid.bayes.likelihood import build_likelihood

#: (preset, terms, noise, channels, duration)
CASES = (
    ("paper-numerical", "z^3, z^2, v*|v|", {"z": 0.01}, "z", None),
    ("paper-numerical", "z^3, z^2, v*|v|", {"z": 0.02}, "z", None),
    ("paper-numerical", "z^3, z^2, v*|v|", {"z": 0.05}, "z", None),
    ("paper-numerical", "z^3, z^2, v*|v|", {"z": 0.10}, "z", None),
    ("paper-numerical", "z^3, z^2, v*|v|", {"z": 0.02, "a": 0.02}, "z,a", None),
    (
        "paper-experimental",
        "z^3, z^2, sign(v)*|px(z)|, v*|px(z)|, v*|v|*|px(z)|, v^3*|px(z)|",
        {"z": 0.02, "a": 0.02},
        "z,a",
        None,
    ),
    (
        "paper-experimental",
        "z^3, z^2, sign(v)*|px(z)|, v*|px(z)|, v*|v|*|px(z)|, v^3*|px(z)|",
        {"z": 0.05, "a": 0.02},
        "z,a",
        None,
    ),
)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3)
    args = parser.parse_args()
    start = time.perf_counter()
    largest = 0.0
    for preset, terms, noise, channels, duration in CASES:
        for seed in range(args.seeds):
            kw = {} if duration is None else {"duration": duration}
            record = nlid.simulate(preset, seed=seed, noise=noise, channels=channels, **kw)
            fit = nlid.identify(record, terms, "rfs", mass=record.mass)
            lik = build_likelihood(record, fit.model, record.mass, rng=np.random.default_rng(seed))
            sd = np.sqrt(np.diag(lik.covariance))
            truth = fit.model.vector(record.meta["reference"]["coefficients"])
            shift = (lik.center - lik.estimate) / sd
            before, after = (lik.estimate - truth) / sd, (lik.center - truth) / sd
            largest = max(largest, float(np.max(np.abs(shift))))
            worst = int(np.argmax(np.abs(shift)))
            print(
                f"{preset} noise {noise} seed {seed}: largest shift {shift[worst]:+.1f} sd ({fit.terms[worst]}); "
                f"max |LS - truth| {np.max(np.abs(before)):.1f} sd -> max |corrected - truth| "
                f"{np.max(np.abs(after)):.1f} sd",
                flush=True,
            )
    print(f"largest shift on the presets: {largest:.1f} sd; wall time {time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()
