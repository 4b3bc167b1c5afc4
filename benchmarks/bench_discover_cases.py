"""How often the loop names the missing effect: every validation case over several seeds.

For each case of :mod:`nlid.discovery.cases` (each library effect on the double
and the single well, plus complete models), each channel set (displacement
only; displacement and acceleration) and each seed, 1 % noise: run the loop
with rfs and count the runs whose steps are exactly ``[effect]`` (``[]`` for
complete models). Prints one line per case and the misses; writes a CSV when
``--out`` is given.

    python benchmarks/bench_discover_cases.py [--seeds 0-4] [--out cases.csv]
"""

from __future__ import annotations

import argparse
import itertools
import time

import pandas as pd

from nlid.discovery import discover
from nlid.discovery.cases import BOTH_WELLS, build_case

CHANNELS = {"z": ("z",), "z+a": ("z", "a")}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="0-4", help="seed range 'a-b' (inclusive) or list 'a,b,c'")
    parser.add_argument("--out", help="CSV file for one row per run")
    args = parser.parse_args()
    if "-" in args.seeds:
        a, b = (int(x) for x in args.seeds.split("-"))
        seeds = list(range(a, b + 1))
    else:
        seeds = [int(x) for x in args.seeds.split(",")]
    cases = [
        *itertools.product(("double", "single"), (*BOTH_WELLS, "none")),
        ("double", "position-dependent-friction"),
    ]
    rows = []
    for (well, effect), (chan, channels) in itertools.product(cases, CHANNELS.items()):
        preset, declared = build_case(well, effect)
        hits = 0
        for seed in seeds:
            record = preset.simulate(seed, noise=0.01, channels=channels)
            start = time.perf_counter()
            result = discover(record, declared, "rfs", simulate=False, views=False)
            steps = [s.effect for s in result.steps]
            ok = steps == ([] if effect == "none" else [effect])
            hits += ok
            rows.append(
                {
                    "well": well,
                    "effect": effect,
                    "channels": chan,
                    "seed": seed,
                    "steps": " ".join(steps),
                    "correct": ok,
                    "eps_initial": result.initial.scores.eps,
                    "eps_final": result.final.scores.eps,
                    "eps_initial_holdout": result.initial.scores.eps_holdout,
                    "eps_final_holdout": result.final.scores.eps_holdout,
                    "seconds": time.perf_counter() - start,
                }
            )
            if not ok:
                print(f"  miss: {well} {effect} {chan} seed {seed}: steps {steps}; {result.stop_reason}")
        done = rows[-len(seeds) :]
        eps = ", ".join(f"{r['eps_initial']:.3g}->{r['eps_final']:.3g}" for r in done)
        secs = sum(r["seconds"] for r in done) / len(done)
        print(f"{well:6s} {effect:28s} {chan:4s} {hits}/{len(seeds)} correct  eps % {eps}  ({secs:.1f} s per run)")
    frame = pd.DataFrame(rows)
    print(f"total: {int(frame['correct'].sum())}/{len(frame)} runs correct")
    if args.out:
        frame.to_csv(args.out, index=False)


if __name__ == "__main__":
    main()
