"""Wall time of ``nlid bench --jobs 2``: the three measured benchmarks, every default pipeline (issue 36).

Runs the README's command ``nlid bench --jobs 2 --out DIR`` into a fresh
folder each time (nothing resumed: every job runs) and prints, per run, the
wall time of the whole command, the CPU time of the process and its children
(user + system), the 1-minute load before it, and the sum of the jobs' fit
times (column ``seconds`` of ``leaderboard.csv``, one value per benchmark and
pipeline: a fit is scored on every test set of its benchmark, and each of
those rows repeats its time). ``--profile`` adds the ten slowest fits, so the
figure can be split into the fits and the fixed costs (start-up, data,
scoring, figures, the leaderboard). Target (issue 36): <= 60 s on the 2-core
machine.

    python benchmarks/bench_leaderboard.py [--repeat 3] [--jobs 2] [--profile]

Needs ``$NLID_DATA_DIR`` (or the ``nonlinear-benchmarks`` package). One run
takes 1-2 minutes on a quiet machine: the median is of fewer runs than the
other rows' five when time is short, and the printout says how many.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pandas as pd


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def fit_seconds(board: pd.DataFrame) -> pd.Series:
    """Each benchmark's and pipeline's fit time, once (the leaderboard repeats it on every test set)."""
    rows = board.dropna(subset=["seconds"])
    return rows.groupby(["benchmark", "pipeline"])["seconds"].first()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeat", type=int, default=3, help="runs (default 3)")
    parser.add_argument("--jobs", type=int, default=2, help="jobs at the same time (default 2, as the issue)")
    parser.add_argument("--profile", action="store_true", help="also print the ten slowest fits of the last run")
    args = parser.parse_args()
    walls, cpus, loads, sums = [], [], [], []
    fits = None
    for i in range(args.repeat):
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp) / "bench"
            cmd = [sys.executable, "-m", "nlid.cli.main", "bench", "--jobs", str(args.jobs), "--out", str(out)]
            cmd.append("--quiet")
            loads.append(os.getloadavg()[0])
            cpu0 = _children_cpu()
            start = time.perf_counter()
            subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
            walls.append(time.perf_counter() - start)
            cpus.append(_children_cpu() - cpu0)
            fits = fit_seconds(pd.read_csv(out / "leaderboard.csv"))
            sums.append(float(fits.sum()))
        print(
            f"  run {i + 1}: {walls[-1]:.1f} s wall, {cpus[-1]:.1f} s CPU (every process), fits {sums[-1]:.1f} s "
            f"({len(fits)} fits); load {loads[-1]:.1f}",
            flush=True,
        )
    print(
        f"nlid bench --jobs {args.jobs}: median {statistics.median(walls):.1f} s wall over {len(walls)} runs "
        f"(min {min(walls):.1f}, max {max(walls):.1f}), CPU median {statistics.median(cpus):.1f} s, sum of the fits "
        f"median {statistics.median(sums):.1f} s; 1-min load {min(loads):.1f}-{max(loads):.1f}"
    )
    if args.profile and fits is not None:
        print("  slowest fits (last run):")
        for (bench, pipeline), sec in fits.sort_values(ascending=False).head(10).items():
            print(f"    {bench:14s} {pipeline:16s} {sec:7.2f} s")


if __name__ == "__main__":
    main()
