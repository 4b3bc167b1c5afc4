"""Timing and memory helpers shared by the benchmark scripts."""

from __future__ import annotations

import statistics
import time
import tracemalloc
from collections.abc import Callable
from typing import Any


def median_time(fn: Callable[[], Any], repeat: int = 7, warmup: int = 1) -> tuple[float, list[float]]:
    """Median wall time of ``fn()`` in seconds over ``repeat`` runs after ``warmup`` runs."""
    for _ in range(warmup):
        fn()
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times), times


def peak_memory(fn: Callable[[], Any]) -> tuple[Any, float]:
    """Run ``fn()`` and return its result and the peak traced allocation in MB.

    tracemalloc sees every NumPy array allocation, so this is the peak memory
    the call itself needed (not the interpreter's baseline).
    """
    tracemalloc.start()
    try:
        result = fn()
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    return result, peak / 1e6


def side_by_side_main(doc: str, side_by_side: Callable[[str], list[tuple]], peer: str, *, times: bool = False) -> None:
    """The command line of a peer's side-by-side script: run it on each benchmark, print the ratio table.

    ``side_by_side(name)`` returns one ``(test, side-by-side RMSE, row RMSE, rule)`` per test set, followed by
    the two fit times in seconds when ``times``. The row passes when it is within 2x of the side-by-side.
    """
    import argparse
    import math
    import os

    from nlid.benchmarking import load_protocol

    parser = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    parser.add_argument("--benchmark", default="silverbox,emps-internal,bouc-wen")
    args = parser.parse_args()
    print(f"load average at the start: {os.getloadavg()[0]:.1f} (2 cores shared)")
    results = []
    for name in [b.strip() for b in args.benchmark.split(",") if b.strip()]:
        unit = load_protocol(name).unit
        results += [(name, unit, *r) for r in side_by_side(name)]
    print()
    extra = " fit time (side-by-side / row) |" if times else ""
    print(f"| benchmark / test (rule) | {peer} as documented | nlid's {peer} row | row / side-by-side |{extra}")
    print("| --- | --- | --- | --- |" + (" --- |" if times else ""))
    worst = 0.0
    for name, unit, test, ours, row, rule, *seconds in results:
        ratio = row / ours if ours > 0 else math.nan
        worst = max(worst, ratio) if math.isfinite(ratio) else math.inf
        cells = f" {seconds[0]:.0f} s / {seconds[1]:.0f} s |" if times else ""
        print(f"| `{name}` / `{test}` (`{rule}`) | {ours:.4g} {unit} | {row:.4g} {unit} | {ratio:.2f} |{cells}")
    print(f"\nworst ratio {worst:.2f} (the row passes at <= 2); load average at the end: {os.getloadavg()[0]:.1f}")
