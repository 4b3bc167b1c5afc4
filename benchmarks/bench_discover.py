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
"""

from __future__ import annotations

import argparse
import sys
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
    args = parser.parse_args()
    for name, record, declared, kwargs in cases():

        def once(record=record, declared=declared, kwargs=kwargs):
            return discover(record, declared, "rfs", views=False, **kwargs)

        med, times = median_time(once, repeat=args.repeat)
        result, peak = peak_memory(once)
        steps = ", ".join(s.effect for s in result.steps) or "none"
        fits = sum(1 for s in result.steps for e in s.ranking if e.explained_holdout is not None) + sum(
            1 for e in result.final_ranking if e.explained_holdout is not None
        )
        print(
            f"{name:26s} {record.n:7d} samples  median {med:6.2f} s (min {min(times):.2f}, {args.repeat} runs)  "
            f"peak {peak:7.1f} MB  steps: {steps}  candidates fitted: {fits}"
        )


if __name__ == "__main__":
    main()
