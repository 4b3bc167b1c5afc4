"""Speed and memory of the residual -> missing-effect loop (``nlid.discovery``), with rfs.

Cases: a 30-s record at 2 kHz (paper-numerical, 61 440 samples, 2 % noise on
z, declared model without its quadratic damping: one step, then the final
check; issue 13's timing target: under a minute on the 2-core machine), the
full paper-numerical record (122 880 samples) and, when ``$NLID_DATA_DIR``
holds them, EMPS (``v, 1`` -> Coulomb, then the dictionary), Silverbox (linear
-> cubic spring, held out on the arrow head) and Bouc-Wen (``z, v`` ->
hysteresis, scored on the sine sweep). Each run tests the whole library (15
candidates with their grids and refinements, the mass and dictionary
candidates where the probes call for them), probes the residual at every step
and simulates the kept models on the held-out record. No report is written.

    python benchmarks/bench_discover.py [--repeat 3]

Issue 36's rows (round four in docs/performance.md), EMPS alone, the defaults ``nlid discover dataset:emps
--declared "v, 1"`` runs, then with ``--refine``; each line gives the median wall time, the median CPU time
(every thread of the process) and the 1-minute load at the start of the runs::

    python benchmarks/bench_discover.py --case emps --repeat 5 --no-memory
    python benchmarks/bench_discover.py --case emps --repeat 5 --no-memory --refine
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

from _common import median_time, peak_memory  # noqa: E402

from nlid.discovery import discover  # noqa: E402
from nlid.errors import DataError  # noqa: E402
from nlid.simulation.presets import get_preset  # noqa: E402


def cases():
    preset = get_preset("paper-numerical")
    short = preset.with_overrides(duration=30.0).simulate(0, noise={"z": 0.02}, channels=("z",))
    yield "30 s at 2 kHz (z only)", short, "1, z, z^2, z^3, v", {}
    record = preset.simulate(0, noise={"z": 0.02}, channels=("z",))
    yield "paper-numerical (z only)", record, "1, z, z^2, z^3, v", {}
    try:
        from nlid.data.datasets import load

        yield "emps", load("emps"), "v, 1", {}
        # the benchmark's estimation part; the arrow head (a test set) is scored as validation, never decides
        silver = load("silverbox", part="estimation")
        yield "silverbox", silver, "1, z, v", {"validation": load("silverbox", part="arrow-full")}
        yield "bouc-wen", load("bouc-wen"), "z, v", {"validation": load("bouc-wen", part="sinesweep"), "mass": 2.0}
    except DataError as exc:
        print(f"measured data skipped: {exc}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="timed runs per case (median reported)")
    parser.add_argument("--case", default=None, help="only the case whose name starts with this (e.g. emps)")
    parser.add_argument("--refine", action="store_true", help="discover(..., refine=True): nlid discover --refine")
    parser.add_argument("--no-memory", action="store_true", help="skip the traced-memory run")
    args = parser.parse_args()
    for name, record, declared, kwargs in cases():
        if args.case and not name.startswith(args.case):
            continue
        cpu: list[float] = []
        last: list = []

        def once(record=record, declared=declared, kwargs=kwargs, cpu=cpu, last=last):
            start = time.process_time()
            out = discover(record, declared, "rfs", views=False, refine=args.refine, **kwargs)
            cpu.append(time.process_time() - start)
            last[:] = [out]
            return out

        load = os.getloadavg()[0]
        med, times = median_time(once, repeat=args.repeat)
        if args.no_memory:  # the last timed run's result
            result, peak = last[0], float("nan")
        else:
            result, peak = peak_memory(once)
        steps = ", ".join(s.effect for s in result.steps) or "none"
        fits = sum(1 for s in result.steps for e in s.ranking if e.explained_holdout is not None) + sum(
            1 for e in result.final_ranking if e.explained_holdout is not None
        )
        note = ", refine" if args.refine else ""
        print(
            f"{name:26s} {record.n:7d} samples  median {med:6.2f} s (min {min(times):.2f}, {args.repeat} runs; CPU "
            f"{statistics.median(cpu[1 : 1 + args.repeat]):.2f} s; load {load:.1f}{note})  "
            f"peak {peak:7.1f} MB  steps: {steps}  candidates fitted: {fits}"
        )


if __name__ == "__main__":
    main()
