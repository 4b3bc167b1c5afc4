"""Posterior bands of the response against the truth's (issue 33, "Bands").

For each seed: ``paper-experimental`` simulated with 2 % noise on z and a (its 120 s random base excitation),
the model of Eq. 24 identified by the preferred method with the known mass, the posterior of every
coefficient (``nlid.posterior(..., params="all")``), and the response at ``--force`` N over ``--band`` Hz (a
curve per well, 7 harmonics). The 90 % band over ``--draws`` posterior draws is compared with the true model's
response computed the same way: the fraction of the *resolved* frequencies (where the draws agree on how many
stable solutions there are) at which every stable solution of the truth lies in its band, per curve, and the
part of the grid left unresolved.

    python benchmarks/response_bands.py [--seeds 1,2,3,4,5] [--draws 100] [--force 1.5] [--band 6:16]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

import numpy as np  # noqa: E402

import nlid  # noqa: E402
from nlid.identified.model import IdentifiedModel  # noqa: E402
from nlid.model import physics  # noqa: E402
from nlid.response import Settings  # noqa: E402
from nlid.simulation.presets import get_preset  # noqa: E402

TERMS = "z^3,z^2,sign(v)*|px(z)|,v*|px(z)|,v*|v|*|px(z)|,v^3*|px(z)|"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", default="1,2,3,4,5")
    parser.add_argument("--draws", type=int, default=100)
    parser.add_argument("--force", type=float, default=1.5)
    parser.add_argument("--band", default="6:16")
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    lo, hi = (float(x) for x in args.band.split(":"))
    settings = Settings(step=0.1)
    preset = get_preset("paper-experimental")
    model = preset.model()
    coefficients = preset.truth()["coefficients"]
    truth = IdentifiedModel(
        model=model,
        coefficients=coefficients,
        mass=preset.mass,
        method="truth",
        equilibria=physics.equilibria(model, model.vector(coefficients), (-0.05, 0.05)),
        z_range=(-0.05, 0.05),
    )
    reference = truth.frequency_response(args.force, (lo, hi), settings=settings, backbone=False)
    print("load {:.1f} {:.1f} {:.1f}".format(*os.getloadavg()))
    print(f"\n{args.draws} draws, 90 % band, {args.force:g} N, {lo:g}-{hi:g} Hz\n")
    print("| seed | method | curve (well) | resolved grid | truth inside the band (resolved) | failed draws | time |")
    print("|---|---|---|---|---|---|---|")
    passed = 0
    for seed in (int(s) for s in args.seeds.split(",")):
        t0 = time.perf_counter()
        record = nlid.simulate("paper-experimental", seed=seed, noise=0.02, channels="z,a")
        fit = nlid.identify(record, TERMS, mass=preset.mass)
        post = nlid.posterior(record, fit, params="all", seed=seed)
        resp = fit.frequency_response(args.force, (lo, hi), settings=settings, backbone=False)
        if len(resp.curves) != len(reference.curves):
            shown = f"the fit has {len(resp.curves)} curves, the truth {len(reference.curves)}"
            print(f"| {seed} | {fit.method} | {shown} | | | | |")
            continue
        band = resp.with_posterior(post, draws=args.draws, jobs=args.jobs, seed=seed).uncertainty
        cover = band.coverage(reference)
        ok = all(c >= 0.8 for c in cover)
        passed += ok
        for k, (b, c) in enumerate(zip(band.curves, cover, strict=True)):
            print(
                f"| {seed} | {fit.method} | {k} (z* = {b.start[0]:.4f}) | {np.mean(b.resolved):.0%} | {c:.1%} | "
                f"{band.failed} | {time.perf_counter() - t0:.0f} s |",
                flush=True,
            )
    print(f"\nseeds with every curve covered at >= 80 % of its resolved frequencies: {passed}")
    print("load {:.1f} {:.1f} {:.1f}".format(*os.getloadavg()))


if __name__ == "__main__":
    main()
