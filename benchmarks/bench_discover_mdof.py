"""Discovery on a structure: does ``discover`` name the connection carrying an undeclared nonlinearity?

Two tables, on the ``beam-5mode`` preset (a cantilever lumped at 5 points, a cubic spring ``z5^3`` from
the tip to the ground -- the end contact -- and a friction contact ``tanh(v3/0.001)`` at point 3):

1. **Localisation**: the friction contact is declared, the end contact is not. For each seed and noise
   level, the connection and term ``discover`` names, its coefficient (truth 3e8 N/m^3), the cross-fitted
   held-out fraction it explains, and the free-run error on the test part before and after (mean over
   the 5 DOFs, % of std(z)). Every candidate of the library is tried on every one of the 15 connections.
2. **Calibration**: both elements declared (nothing is missing). The largest cross-fitted fraction any
   candidate explains (the acceptance threshold is 10 %), the largest remaining-structure probe (threshold
   5 %) and whether anything was added, at 1, 2 and 5 % noise.

Noise is a fraction of each response channel's standard deviation (z, v, a all measured). The records are
shortened to ``--duration`` seconds (default 30 s at 2048 Hz).

    python benchmarks/bench_discover_mdof.py [--seeds 1 2 3] [--duration 30] [--noise 0.005 0.01 0.02]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from nlid.discovery.structure import discover_structure
from nlid.simulation.structure_presets import STRUCTURE_PRESETS

TRUTH = {"connection": (5, 0), "element": "z5^3", "coefficient": 3e8}


def localisation(seeds, noises, duration):
    preset = STRUCTURE_PRESETS["beam-5mode"].with_overrides(duration=duration)
    print("| noise | seed | named | element | coefficient | explained % | free run % before -> after | right | s |")
    print("|---|---|---|---|---|---|---|---|---|")
    right = 0
    for noise in noises:
        for seed in seeds:
            record = preset.simulate(seed, noise=noise)
            start = time.perf_counter()
            res = discover_structure(record, "tanh(v3/0.001)", max_steps=1)
            seconds = time.perf_counter() - start
            ok = res.located == TRUTH["connection"] and TRUTH["element"] in res.found
            right += ok
            before, after = res.stages[0], res.final
            if res.steps:
                e = res.steps[0].evidence
                named, element = e.where, ", ".join(e.elements)
                coef, expl = f"{next(iter(e.coefficients.values())):.4g}", f"{100 * e.explained:.3g}"
            else:
                named, element, coef, expl = "none", "", "", ""
            print(
                f"| {noise:g} | {seed} | {named} | {element} | {coef} | {expl} | "
                f"{np.nanmean(before.freerun_percent):.3g} -> {np.nanmean(after.freerun_percent):.3g} | "
                f"{'yes' if ok else 'NO'} | {seconds:.0f} |",
                flush=True,
            )
    print(f"\nright connection and term: {right} of {len(seeds) * len(noises)}\n")


def calibration(seeds, noises, duration):
    preset = STRUCTURE_PRESETS["beam-5mode"].with_overrides(duration=duration)
    print("| noise | seed | best candidate | explained % | largest probe % | added |")
    print("|---|---|---|---|---|---|")
    for noise in noises:
        for seed in seeds:
            record = preset.simulate(seed, noise=noise)
            res = discover_structure(record, "z5^3, tanh(v3/0.001)", max_steps=1)
            best = next((e for e in res.ranking if e.explained is not None), None)
            probe = res.remaining_declared.best
            print(
                f"| {noise:g} | {seed} | {best.effect} on {best.where} | {100 * best.explained:.3g} | "
                f"{100 * probe.explained:.3g} ({probe.probe} on {probe.connection}) | "
                f"{', '.join(res.found) or 'nothing'} |",
                flush=True,
            )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    parser.add_argument("--noise", type=float, nargs="+", default=[0.005, 0.01, 0.02])
    parser.add_argument("--calibration-noise", type=float, nargs="+", default=[0.01, 0.02, 0.05])
    parser.add_argument("--duration", type=float, default=30.0)
    parser.add_argument("--skip-calibration", action="store_true")
    args = parser.parse_args()
    print(f"## Localisation (beam-5mode, {args.duration:g} s, end contact z5^3 undeclared)\n")
    localisation(args.seeds, args.noise, args.duration)
    if not args.skip_calibration:
        print(f"## Calibration (beam-5mode, {args.duration:g} s, fully declared)\n")
        calibration(args.seeds, args.calibration_noise, args.duration)


if __name__ == "__main__":
    main()
