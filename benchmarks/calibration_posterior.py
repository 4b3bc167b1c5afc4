"""Calibration study of the posterior's 90 % intervals (issue 6), with the likelihoods it improves on.

For each replicate (2 % noise on z and a, velocity estimated, rfs with the
known mass, px(z) roots at the true ones) the 90 % interval of every
damping-family coefficient is formed four ways:

* ``iid``: rfs's estimate +/- 1.645 of its iid standard error (the raw
  likelihood with N independent samples);
* ``sandwich``: the adjusted likelihood without the bias correction
  (effective samples and sandwich covariance only; Gaussian limit);
* ``posterior``: ``sample_posterior`` with its defaults (emcee; unsampled
  coefficients fixed at rfs's estimate) - what the calibration test checks;
* ``marginal``: the same likelihood with the unsampled coefficients
  integrated out (``others="marginal"``; Gaussian limit).

It prints the fraction of replicates whose interval contains the truth and
the standard deviation of the standardised error (1 when calibrated).

    python benchmarks/calibration_posterior.py [--seeds 1000:1050] [--preset NAME ...]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from nlid import identify, physics
from nlid.posterior import sample_posterior
from nlid.posterior.likelihood import build_likelihood
from nlid.presets import get_preset

Z90 = 1.6448536269514722


def study(name: str, seeds: range) -> None:
    preset = get_preset(name)
    model = preset.model()
    truth = model.vector(preset.truth()["coefficients"])
    dam = [i for i, t in enumerate(model.terms) if t.family == "damping"]
    z = {k: [] for k in ("iid", "sandwich", "posterior", "marginal")}
    inside = {k: [] for k in z}
    start = time.perf_counter()
    for seed in seeds:
        record = preset.simulate(seed, noise=0.02, channels=("z", "a"))
        result = identify(record, model, "rfs", mass=preset.mass)
        theta = model.vector(result.coefficients)
        se = model.vector(result.standard_errors)
        z["iid"].append((theta[dam] - truth[dam]) / se[dam])
        data = physics.regression_data(record, model)
        plain = build_likelihood(record, model, preset.mass, data=data, bias_correction=False)
        mean, cov = plain.conditional(dam, theta)
        z["sandwich"].append((mean - truth[dam]) / np.sqrt(np.diag(cov)))
        post = sample_posterior(record, result, model, params="damping", seed=seed)
        summary = post.summary()
        z["posterior"].append(
            np.array([(summary[model.names[i]]["mean"] - truth[i]) / summary[model.names[i]]["sd"] for i in dam])
        )
        interval = post.interval(0.9)
        inside["posterior"].append(
            [interval[model.names[i]][0] <= truth[i] <= interval[model.names[i]][1] for i in dam]
        )
        marg = post.likelihood.reduced(dam)
        z["marginal"].append((marg.center - truth[dam]) / np.sqrt(np.diag(marg.covariance)))
    seconds = (time.perf_counter() - start) / len(seeds)
    for k in ("iid", "sandwich", "marginal"):
        inside[k] = list(np.abs(np.array(z[k])) <= Z90)
    print(f"{name}: {len(seeds)} replicates (seeds {seeds.start}-{seeds.stop - 1}), {seconds:.1f} s per replicate")
    print(f"  {'coefficient':18s}" + "".join(f"{k:>22s}" for k in z))
    for j, i in enumerate(dam):
        cells = []
        for k in z:
            cov = 100 * np.mean(np.array(inside[k])[:, j])
            sd = np.array(z[k])[:, j].std()
            cells.append(f"{cov:5.0f} % (sd z {sd:4.2f})")
        print(f"  {model.names[i]:18s}" + "".join(f"{c:>22s}" for c in cells))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", default="1000:1050", help="first:stop of the replicate seeds (default 1000:1050)")
    parser.add_argument(
        "--preset", action="append", help="preset(s) to study (default paper-numerical and paper-experimental)"
    )
    args = parser.parse_args()
    first, stop = (int(x) for x in args.seeds.split(":"))
    for name in args.preset or ["paper-numerical", "paper-experimental"]:
        study(name, range(first, stop))


if __name__ == "__main__":
    main()
