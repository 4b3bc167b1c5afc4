"""Calibration study of the posterior's 90 % intervals (issue 6), with the likelihoods it improves on.

For each replicate (2 % noise on z and a, velocity estimated, rfs with the
known mass, px(z) roots at the true ones) the 90 % interval of every
damping-family coefficient is formed four ways:

* ``iid``: rfs's estimate +/- 1.645 of its iid standard error (the raw
  likelihood with N independent samples);
* ``sandwich``: the adjusted likelihood without the bias correction
  (effective samples and sandwich covariance only; Gaussian limit);
* ``fixed``: the full likelihood with the unsampled (stiffness)
  coefficients held at rfs's estimate (``others="fixed"``; Gaussian limit);
* ``posterior``: ``sample_posterior`` with its defaults (emcee; the
  stiffness integrated out) - what the calibration test checks.

It prints the fraction of replicates whose interval contains the truth and
the standard deviation of the standardised error (1 when calibrated).

    python benchmarks/calibration_posterior.py [--seeds 1000:1050] [--preset NAME ...] [--workers 2]
"""

from __future__ import annotations

import argparse
import multiprocessing
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from nlid import balance, identify
from nlid.bayes import sample_posterior
from nlid.bayes.likelihood import build_likelihood
from nlid.presets import get_preset

Z90 = 1.6448536269514722


KINDS = ("iid", "sandwich", "fixed", "posterior")


def replicate(name: str, seed: int) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Standardised errors of each kind of interval and whether the posterior's contains the truth."""
    preset = get_preset(name)
    model = preset.model()
    truth = model.vector(preset.truth()["coefficients"])
    dam = [i for i, t in enumerate(model.terms) if t.family == "damping"]
    record = preset.simulate(seed, noise=0.02, channels=("z", "a"))
    result = identify(record, model, "rfs", mass=preset.mass)
    theta = model.vector(result.coefficients)
    se = model.vector(result.standard_errors)
    z = {"iid": (theta[dam] - truth[dam]) / se[dam]}
    data = balance.regression_data(record, model)
    plain = build_likelihood(record, model, preset.mass, data=data, bias_correction=False)
    mean, cov = plain.conditional(dam, theta)
    z["sandwich"] = (mean - truth[dam]) / np.sqrt(np.diag(cov))
    post = sample_posterior(record, result, params="damping", seed=seed)
    mean, cov = post.likelihood.conditional(dam, theta)
    z["fixed"] = (mean - truth[dam]) / np.sqrt(np.diag(cov))
    s = post.summary()
    z["posterior"] = np.array([(s[model.names[i]]["mean"] - truth[i]) / s[model.names[i]]["sd"] for i in dam])
    interval = post.interval(0.9)
    inside = np.array([interval[model.names[i]][0] <= truth[i] <= interval[model.names[i]][1] for i in dam])
    return z, inside


def study(name: str, seeds: range, workers: int) -> None:
    model = get_preset(name).model()
    dam = [t.name for t in model.terms if t.family == "damping"]
    start = time.perf_counter()
    with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn")) as pool:
        out = list(pool.map(replicate, [name] * len(seeds), seeds))
    seconds = time.perf_counter() - start
    z = {k: np.array([o[0][k] for o in out]) for k in KINDS}
    inside = {k: np.abs(z[k]) <= Z90 for k in ("iid", "sandwich", "fixed")}
    inside["posterior"] = np.array([o[1] for o in out])
    print(
        f"{name}: {len(seeds)} replicates (seeds {seeds.start}-{seeds.stop - 1}), {seconds:.0f} s with {workers} "
        "process(es); coverage of the 90 % intervals (sd of the standardised error)"
    )
    print(f"  {'coefficient':18s}" + "".join(f"{k:>22s}" for k in KINDS))
    for j, term in enumerate(dam):
        cells = [f"{100 * np.mean(inside[k][:, j]):5.0f} % (sd z {z[k][:, j].std():4.2f})" for k in KINDS]
        print(f"  {term:18s}" + "".join(f"{c:>22s}" for c in cells))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", default="1000:1050", help="first:stop of the replicate seeds (default 1000:1050)")
    parser.add_argument("--workers", type=int, default=2, help="processes (default 2)")
    parser.add_argument(
        "--preset", action="append", help="preset(s) to study (default paper-numerical and paper-experimental)"
    )
    args = parser.parse_args()
    first, stop = (int(x) for x in args.seeds.split(":"))
    for name in args.preset or ["paper-numerical", "paper-experimental"]:
        study(name, range(first, stop), args.workers)


if __name__ == "__main__":
    main()
