"""Scaling of a study with the number of workers (issue 14: >= 12x on 16 workers for a 100-run study).

For each worker count in ``--jobs`` (and each executor in ``--executor``), a
fresh interpreter plans the study (default ``noise-sweep``: 5 noise levels x
5 records x every installed identifier = 100 runs), takes ``--runs`` of them
(spread evenly over the plan; default all) and executes them with
:func:`nlid.study.make_executor` exactly as ``nlid study run`` does (each run
isolated in its own child process), without writing the report. Printed and
written (``--csv``, ``--json``) per configuration: the wall time of the
executor (fork server or Dask cluster start included), the speed-up over 1
worker of the same executor, the efficiency (speed-up / workers), the median
and sum of the runs' identification times (``seconds``: the identify() call,
which grows when workers share cores or memory bandwidth) and the 1-minute
load average before the configuration started.

    python benchmarks/bench_scaling.py --jobs 1,2,4,8,16 [--executor local,dask] [--study noise-sweep]
                                       [--runs N] [--repeat 1] [--csv scaling.csv] [--json scaling.json]

``--costs``: the per-run fixed cost, measured one run at a time (as ``--jobs 1``)
over ``--runs`` runs of the study: each run's round trip (fork from the warm
server, data, identification, scores, metrics, the payload sent back) and the
parent's save, split into the parts the run's child times (``timings`` of
:func:`nlid.study.worker.execute_run`), with the start-up (fork server and its
preload, the study loaded); and from these the projected speed-up of the whole
study on ``--workers`` workers (default 16): ``T(W) = start-up + max(sum of
round trips / W, longest round trip, sum of parent saves)`` (the parent saves
each run while the others work) against ``T(1)``,
beside the bound of identification alone.

    python benchmarks/bench_scaling.py --costs [--runs 20] [--study noise-sweep] [--workers 16]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path


def _one(study: str, executor: str, jobs: int, runs: int | None) -> dict:
    """One configuration, in this (fresh) process."""
    from nlid.study import load_study, make_executor
    from nlid.study.plan import plan_study

    planned = plan_study(load_study(study))
    if runs and runs < len(planned):
        planned = [planned[i * len(planned) // runs] for i in range(runs)]
    rows: list[dict] = []
    ex = make_executor(executor, jobs=jobs)
    start = time.perf_counter()
    ex.run(planned, lambda run, payload: rows.append(payload["row"]))
    wall = time.perf_counter() - start
    seconds = [float(r.get("seconds") or 0.0) for r in rows if r.get("status") == "ok"]
    return {
        "study": study,
        "executor": executor,
        "jobs": jobs,
        "runs": len(rows),
        "failed": sum(r.get("status") != "ok" for r in rows),
        "wall_s": wall,
        "identification_median_s": statistics.median(seconds) if seconds else float("nan"),
        "identification_sum_s": sum(seconds),
    }


def costs(study: str, runs: int, workers: int) -> None:
    """Per-run fixed costs of a study, one run at a time, and the projected speed-up on ``workers`` workers."""
    import tempfile

    start = time.perf_counter()
    from nlid.runtime.isolation import start_fork_server
    from nlid.study import ResultStore, load_study
    from nlid.study.plan import plan_study
    from nlid.study.worker import run_isolated

    start_fork_server(pin_threads=True)
    planned = plan_study(load_study(study))
    loaded = time.perf_counter() - start
    picked = [planned[i * len(planned) // runs] for i in range(min(runs, len(planned)))]
    load = os.getloadavg()[0]
    trips, saves, ids, parts = [], [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        store = ResultStore(tmp)
        for run in picked:
            t0 = time.perf_counter()
            payload = run_isolated(run.spec)
            t1 = time.perf_counter()
            store.save(run, payload)
            saves.append(time.perf_counter() - t1)
            trips.append(t1 - t0)
            ids.append(float(payload["row"].get("seconds") or 0.0))
            parts.append(payload.get("timings") or {})
    names = ["data", "identify", "scores", "metrics", "posterior", "payload"]
    med = {n: statistics.median([p.get(n, 0.0) for p in parts]) for n in names}
    child = [sum(p.get(n, 0.0) for n in names) for p in parts]
    ipc = statistics.median([t - c for t, c in zip(trips[1:], child[1:], strict=True)] or [0.0])
    # the first run also waited for the fork server's preload: its round trip less its own work and transfer
    startup = loaded + max(trips[0] - child[0] - ipc, 0.0)
    trips[0] -= startup - loaded
    fixed = [t - i for t, i in zip(trips, ids, strict=True)]
    n = len(planned)
    scale = n / len(picked)  # the measured runs stand for the whole study
    t1 = startup + scale * max(sum(trips), sum(saves))  # the parent saves while the next run works
    tw = startup + max(scale * sum(trips) / workers, max(trips), scale * sum(saves))
    bound = (scale * sum(ids)) / max(scale * sum(ids) / workers, max(ids))
    print(
        f"{study}: {len(picked)} of {n} runs, one at a time (load {load:.1f} before; {os.cpu_count()} cores)\n"
        f"  start-up (fork server + preload, study loaded): {startup:.2f} s\n"
        f"  per run, median: round trip {statistics.median(trips):.2f} s, identification "
        f"{statistics.median(ids):.2f} s, fixed cost {statistics.median(fixed):.2f} s "
        f"({100 * statistics.median(fixed) / statistics.median(trips):.0f} % of the round trip)\n"
        f"  fixed cost parts, median: data {med['data']:.3f} s, free-run and held-out scores {med['scores']:.3f} s, "
        f"metrics {med['metrics']:.3f} s, posterior {med['posterior']:.3f} s, payload {med['payload']:.3f} s, "
        f"fork + transfer {ipc:.3f} s; parent's save {statistics.median(saves):.3f} s\n"
        f"  projected whole study ({n} runs): 1 worker {t1:.0f} s, {workers} workers {tw:.0f} s: speed-up "
        f"{t1 / tw:.1f} (identification alone bounds it at {bound:.1f}; report not included)"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--jobs", default="1,2,4,8,16", help="comma-separated worker counts (default 1,2,4,8,16)")
    parser.add_argument("--executor", default="local", help="local, dask or local,dask (default local)")
    parser.add_argument("--study", default="noise-sweep", help="built-in study or .toml (default noise-sweep)")
    parser.add_argument("--runs", type=int, help="execute only N runs, spread evenly over the plan (default all)")
    parser.add_argument("--repeat", type=int, default=1, help="times to run each configuration (median reported)")
    parser.add_argument("--csv", type=Path, help="write the table as CSV")
    parser.add_argument("--json", type=Path, help="write the table as JSON")
    parser.add_argument("--costs", action="store_true", help="measure the per-run fixed costs and project")
    parser.add_argument("--workers", type=int, default=16, help="workers of the --costs projection (default 16)")
    parser.add_argument("--one", help=argparse.SUPPRESS)  # internal: "executor,jobs" in a fresh process
    args = parser.parse_args()
    if args.costs:
        costs(args.study, args.runs or 20, args.workers)
        return
    if args.one:
        executor, jobs = args.one.split(",")
        print(json.dumps(_one(args.study, executor, int(jobs), args.runs)))
        return
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    table: list[dict] = []
    for executor in args.executor.split(","):
        base = None
        for jobs in (int(j) for j in args.jobs.split(",")):
            results = []
            for _ in range(args.repeat):
                load = os.getloadavg()[0]
                cmd = [sys.executable, __file__, "--one", f"{executor},{jobs}", "--study", args.study]
                if args.runs:
                    cmd += ["--runs", str(args.runs)]
                out = subprocess.run(cmd, check=True, capture_output=True, text=True)
                results.append({**json.loads(out.stdout.strip().splitlines()[-1]), "load_1min": load})
            row = sorted(results, key=lambda r: r["wall_s"])[len(results) // 2]  # the median run
            row["cores"] = cores
            base = base if base is not None else (row["wall_s"] if jobs == 1 else None)
            row["speedup"] = base / row["wall_s"] if base else float("nan")
            row["efficiency"] = row["speedup"] / jobs if base else float("nan")
            table.append(row)
            print(
                f"{executor:5s} jobs {jobs:2d} ({cores} cores): {row['runs']} runs ({row['failed']} failed) in "
                f"{row['wall_s']:.1f} s, speed-up {row['speedup']:.2f} (efficiency {row['efficiency']:.2f}); "
                f"identification median {row['identification_median_s']:.2f} s, sum "
                f"{row['identification_sum_s']:.1f} s; load {row['load_1min']:.1f}",
                flush=True,
            )
    if args.json:
        args.json.write_text(json.dumps(table, indent=1))
    if args.csv:
        import csv

        with args.csv.open("w", newline="") as fh:
            writer = csv.DictWriter(fh, fieldnames=list(table[0]))
            writer.writeheader()
            writer.writerows(table)


if __name__ == "__main__":
    main()
