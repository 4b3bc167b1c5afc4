"""Where a ``--jobs 1`` study's seconds go beside the identification (issue 36's study row).

Runs the built-in paper-numerical study in this process (``nlid.study.run_study`` with a
``LocalExecutor(1)``, as ``nlid study run paper-numerical --jobs 1`` does after its start-up), with
cProfile on this (the parent) process, and prints:

* the parent's phases: start of the fork server, ``load_study``, the runs, the report;
* the sum over the runs of each part a run child times itself (``payload["timings"]``: data,
  identify, scores, metrics, payload), the parent's save, and what is left of the runs' wall time
  (fork, transfer, waiting);
* the median of each part per identifier.

``--out DIR`` writes into DIR (default: a temporary folder, every figure drawn); ``--rerun`` re-runs
into a folder that already holds the study (as ``bench_study.py``'s later repetitions: only the
figures whose inputs changed are drawn). ``--stats N`` prints the parent's N most expensive calls
(cumulative).

    python benchmarks/profile_study.py [--out DIR] [--rerun] [--stats 30]
"""

from __future__ import annotations

import argparse
import cProfile
import os
import pstats
import statistics
import tempfile
import time
from pathlib import Path

PARTS = ("data", "identify", "scores", "metrics", "payload")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, help="study folder (default: a temporary one)")
    parser.add_argument("--rerun", action="store_true", help="run every run again into --out")
    parser.add_argument("--stats", type=int, default=0, help="print the parent's N most expensive calls")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        profile(args.out or Path(tmp) / "study", args.rerun, args.stats)


def profile(out: Path, rerun: bool, stats: int) -> None:
    """Run the study into ``out`` and print where its time went."""
    from nlid.runtime.isolation import start_fork_server
    from nlid.study import load_study, store
    from nlid.study.execute import LocalExecutor
    from nlid.study.runner import run_study

    load = os.getloadavg()[0]
    t0 = time.perf_counter()
    start_fork_server(pin_threads=True)
    t1 = time.perf_counter()
    config = load_study("paper-numerical")
    t2 = time.perf_counter()
    timings: list[dict] = []
    original = store.ResultStore.save

    def save(self, run, payload):  # the parent's save of each run, and the parts the child timed
        begin = time.perf_counter()
        done = original(self, run, payload)
        timings.append({**payload.get("timings", {}), "save": time.perf_counter() - begin, "method": run.spec.method})
        return done

    store.ResultStore.save = save
    import nlid.study.report as report

    written = report.write_report
    report_seconds = []

    def write(*a, **k):
        begin = time.perf_counter()
        try:
            return written(*a, **k)
        finally:
            report_seconds.append(time.perf_counter() - begin)

    report.write_report = write
    prof = cProfile.Profile()
    cpu = time.process_time()
    t3 = time.perf_counter()
    prof.enable()
    try:
        run_study(config, out, executor=LocalExecutor(1), rerun=rerun, progress=False)
    finally:
        prof.disable()
        store.ResultStore.save = original
        report.write_report = written
    t4 = time.perf_counter()
    total = {k: sum(t.get(k, 0.0) for t in timings) for k in (*PARTS, "save")}
    runs_wall = t4 - t3 - sum(report_seconds)
    print(
        f"paper-numerical, --jobs 1, {len(timings)} runs (1-min load {load:.1f}): fork server start {t1 - t0:.2f} s, "
        f"load_study {t2 - t1:.2f} s, run_study {t4 - t3:.2f} s (the parent's CPU {time.process_time() - cpu:.2f} s)"
    )
    print(f"  report {sum(report_seconds):.2f} s; the runs {runs_wall:.2f} s:")
    print("  " + ", ".join(f"{k} {v:.2f} s" for k, v in total.items()))
    rest = runs_wall - sum(total.values())
    print(f"  fork, transfer and waiting (the runs' wall less the parts above): {rest:.2f} s")
    for method in sorted({t["method"] for t in timings}):
        sub = [t for t in timings if t["method"] == method]
        parts = ", ".join(f"{k} {statistics.median(t.get(k, 0.0) for t in sub):.3f}" for k in (*PARTS, "save"))
        print(f"  {method:10s} median per run (s): {parts}")
    if stats:
        pstats.Stats(prof).sort_stats("cumulative").print_stats(stats)


if __name__ == "__main__":
    main()
