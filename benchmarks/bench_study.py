"""Wall time of the built-in paper-numerical study (the README's first Quickstart command).

Runs ``nlid study run paper-numerical --rerun`` into a temporary folder several
times (every installed identifier, 5 records) and prints the median wall time
of the whole command (start-up, simulation, identification, metrics, report)
and the median identification time per run and method. Targets: <= 5 min on
the 2-core machine; with ``--jobs 1``, wall <= 1.3 x the sum of the runs'
identification times (column ``seconds`` of results.csv: the identify() call
in the run's child), so the start-up, data, scoring and report overhead is
below 30 %. The first repetition writes into an empty folder (every figure is
drawn); the later ones re-run into the same folder (``--rerun``: new rows, so a
new report, but figures whose inputs did not change are kept). Each line shows
the 1-minute load average before the run.

``--noop``: the whole command re-run with everything already done (no
``--rerun``): it reads the store and keeps the up-to-date report. Target
<= 3 s. The study is run once first (not timed) unless ``--out`` already
holds it.

    python benchmarks/bench_study.py [--repeat 3] [--jobs N] [--noop] [--out DIR]
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
    """User + system CPU seconds of the waited-for child processes (the command and what it waited for)."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeat", type=int, default=3, help="times to run the study (default 3)")
    parser.add_argument("--jobs", type=int, help="runs at the same time (default: every core)")
    parser.add_argument("--study", default="paper-numerical", help="built-in study or .toml (default paper-numerical)")
    parser.add_argument("--noop", action="store_true", help="time a re-run with everything already done")
    parser.add_argument("--out", type=Path, help="study folder to use (default: a temporary one)")
    args = parser.parse_args()
    if args.noop:
        noop(args)
        return
    times = []
    cpus = []
    loads = []
    sums = []
    frame = None
    with tempfile.TemporaryDirectory() as tmp:
        out = args.out or Path(tmp) / "study"
        cmd = [sys.executable, "-m", "nlid.cli.main", "study", "run", args.study, "--out", str(out), "--rerun"]
        if args.jobs:
            cmd += ["--jobs", str(args.jobs)]
        for i in range(args.repeat):
            loads.append(os.getloadavg()[0])
            cpu0 = _children_cpu()
            start = time.perf_counter()
            subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            times.append(time.perf_counter() - start)
            cpus.append(_children_cpu() - cpu0)
            frame = pd.read_csv(out / "results.csv")
            sums.append(float(frame["seconds"].sum()))
            print(
                f"  run {i + 1}: {times[-1]:.1f} s (CPU {cpus[-1]:.1f} s), sum of identification times "
                f"{sums[-1]:.1f} s, wall / sum "
                f"{times[-1] / sums[-1]:.2f}, load {loads[-1]:.1f}",
                flush=True,
            )
    ratios = [t / s for t, s in zip(times, sums, strict=True)]
    print(
        f"nlid study run {args.study}: median {statistics.median(times):.1f} s "
        f"(min {min(times):.1f}, max {max(times):.1f}, {len(times)} runs; CPU median {statistics.median(cpus):.1f} s; "
        f"{len(frame)} identifications each; "
        f"1-min load {min(loads):.1f}-{max(loads):.1f})"
    )
    print(
        f"  sum of identification times: median {statistics.median(sums):.1f} s; wall / sum: median "
        f"{statistics.median(ratios):.2f} (each run: {', '.join(f'{r:.2f}' for r in ratios)})"
    )
    for method, sub in frame.groupby("method"):
        status = {k: int(v) for k, v in sub["status"].value_counts().items()}
        print(f"  {method:12s} identification median {sub['seconds'].median():.2f} s per run, status {status}")


def noop(args: argparse.Namespace) -> None:
    """Time ``nlid study run`` with every run stored and the report up to date."""
    with tempfile.TemporaryDirectory() as tmp:
        out = args.out or Path(tmp) / "study"
        cmd = [sys.executable, "-m", "nlid.cli.main", "study", "run", args.study, "--out", str(out), "--quiet"]
        if args.jobs:
            cmd += ["--jobs", str(args.jobs)]
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)  # finish the study and its report (not timed)
        times, loads = [], []
        for _ in range(args.repeat):
            loads.append(os.getloadavg()[0])
            start = time.perf_counter()
            timed = [c for c in cmd if c != "--quiet"]  # its status line says how many runs it executed
            done = subprocess.run(timed, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
            times.append(time.perf_counter() - start)
            if " 0 to run " not in done.stderr:
                raise SystemExit(f"the re-run executed runs: {done.stderr.strip()}")
    print(
        f"no-op re-run of nlid study run {args.study}: median {statistics.median(times):.2f} s "
        f"(each: {', '.join(f'{t:.2f}' for t in times)}; 1-min load {min(loads):.1f}-{max(loads):.1f}); target <= 3 s"
    )


if __name__ == "__main__":
    main()
