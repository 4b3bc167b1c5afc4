"""Open-world discovery (issue 13): effects outside the first ten candidates, and complete models.

For each case of ``nlid.discovery.cases.OPEN_WORLD`` (single well, 2 % noise on z
only) and each seed: run the loop with rfs and check that the first step is the
expected effect, or, for a time skew (no candidate can express it), that no
step is taken and the force-rate probe is the dominant remaining structure.
Complete models at 1, 2 and 5 % noise must take zero steps and be reported
clean. Prints a Markdown table (successes per case) and the misses.

    python benchmarks/bench_discover_open.py [--seeds 5]
"""

from __future__ import annotations

import argparse
import time

import nlid
from nlid.discovery.cases import OPEN_WORLD, build_case, build_open_case


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, default=5)
    args = parser.parse_args()
    start = time.perf_counter()
    rows, misses = [], []
    for effect, (_, _, expected) in OPEN_WORLD.items():
        ok = 0
        for seed in range(args.seeds):
            record, declared, mass = build_open_case(effect, seed)
            result = nlid.discover(record, declared, "rfs", mass=mass, simulate=False, views=False)
            steps = [s.effect for s in result.steps]
            if expected == "force-rate":
                good = not steps and result.remaining.dominant == "force-rate"
            else:
                good = bool(steps) and steps[0] == expected
            ok += good
            if not good:
                misses.append(f"{effect} seed {seed}: steps {steps}; {result.stop_reason[:160]}")
        rows.append((effect, expected, ok))
    for noise in (0.01, 0.02, 0.05):
        preset, declared = build_case("single", "none")
        ok = 0
        for seed in range(args.seeds):
            record = preset.simulate(seed + 20, noise={"z": noise}, channels=("z",))
            result = nlid.discover(record, declared, "rfs", mass=preset.mass, simulate=False, views=False)
            good = not result.steps and not result.remaining.structured
            ok += good
            if not good:
                misses.append(f"complete {noise} seed {seed + 20}: {[s.effect for s in result.steps]}")
        rows.append((f"complete, {100 * noise:g} % noise", "no step, clean", ok))
    print("| case | expected | right |")
    print("| --- | --- | --- |")
    for case, expected, ok in rows:
        print(f"| {case} | {expected} | {ok}/{args.seeds} |")
    for m in misses:
        print("miss:", m)
    print(f"\n{time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()
