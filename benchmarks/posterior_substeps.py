"""How the errors-in-variables correction depends on the RK4 sub-steps of its simulation (issue 35).

For each case: the least-squares estimate of the force balance, then the corrected estimate
(:func:`nlid.bayes.bias.indirect_inference`, as ``nlid posterior`` forms it, 4 pairs, 3 steps, seed 0)
with 1, 2, 4, 8 and 16 sub-steps per sample and with the rule's choice
(:func:`nlid.bayes.bias.correction_substeps`): each term's move in sd of the corrected estimate, and the
time of the correction. The Silverbox case is the record where one step per sample (9 samples per period)
read the integration error as a bias of +2,693 sd on ``v``; on the presets (22 and more samples per
period) the sub-steps should change the corrected estimate by a small fraction of its sd.

Usage::

    NLID_DATA_DIR=/path/to/data python benchmarks/posterior_substeps.py [--cases silverbox,experimental,numerical]
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

import nlid
from nlid.bayes.bias import correction_substeps, indirect_inference
from nlid.bayes.likelihood import build_likelihood
from nlid.estimation.balance import regression_data


def silverbox():
    path = os.path.join(os.environ["NLID_DATA_DIR"], "silverbox", "SNLS80mV.mat")
    record = nlid.load(path, columns={"f": "V1", "z": "V2"}, units={"f": "V", "z": "V"}, fs=610.35)
    fit = nlid.identify(record, "z^3", "rfs")
    return "silverbox SNLS80mV, z^3", record, fit


def experimental():
    record = nlid.simulate("paper-experimental", seed=0, noise={"z": 0.02, "a": 0.02}, channels="z,a")
    terms = "z^3, z^2, sign(v)*|px(z)|, v*|px(z)|, v*|v|*|px(z)|, v^3*|px(z)|"
    return "paper-experimental 2 % z, a", record, nlid.identify(record, terms, "rfs", mass=record.mass)


def numerical():
    record = nlid.simulate("paper-numerical", seed=0, noise={"z": 0.02, "v": 0.02, "a": 0.02}, channels="z,v,a")
    return "paper-numerical 2 % z, v, a", record, nlid.identify(record, "z^3, z^2, v*|v|", "rfs", mass=record.mass)


CASES = {"silverbox": silverbox, "experimental": experimental, "numerical": numerical}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", default=",".join(CASES))
    parser.add_argument("--substeps", default="1,2,4,8,16")
    args = parser.parse_args()
    print(f"load {os.getloadavg()[0]:.1f}")
    for name in args.cases.split(","):
        label, record, fit = CASES[name]()
        model, mass = fit.model, fit.mass
        data = regression_data(record, model)
        lik = build_likelihood(record, model, mass, data=data, bias_correction=False)
        theta_hat, cov = lik.center, lik.covariance
        rule = correction_substeps(record, model, theta_hat, mass)
        print(f"{label}: {record.n} samples at {record.fs:g} Hz; the rule gives {rule} sub-steps")
        centres = {}
        for q in sorted({*(int(x) for x in args.substeps.split(",")), rule}):
            t0 = time.perf_counter()
            centre, c_cov, _ = indirect_inference(
                record, model, theta_hat, mass, data, cov, rng=np.random.default_rng(0), substeps=q
            )
            seconds = time.perf_counter() - t0
            sd = np.sqrt(np.diag(c_cov))
            centres[q] = (centre, sd)
            moves = ", ".join(f"{n} {x:+.2f}" for n, x in zip(model.names, (centre - theta_hat) / sd, strict=True))
            print(f"  q={q:2d}{' (rule)' if q == rule else '       '} {seconds:5.2f} s  move in sd: {moves}")
        ref, ref_sd = centres[max(centres)]
        for q, (centre, _) in centres.items():
            worst = np.max(np.abs(centre - ref) / ref_sd)
            print(f"  q={q:2d}: largest difference from q={max(centres)}: {worst:.3f} sd")


if __name__ == "__main__":
    main()
