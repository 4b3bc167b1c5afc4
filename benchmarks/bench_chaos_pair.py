"""The chaos check's pair of free runs in a study's scores: two whole runs against the pair that stops at the join.

For the first ``--runs`` runs of the paper-numerical study (the README's first study), builds the run's
records, identifies, and times the free-run pair of the held-out score both ways, in this process:

* *whole*: two :func:`nlid.simulation.free_run` calls (nlid's scores before issue 36's fourth session), at
  once on two threads with ``--threads 2`` (:func:`nlid.runtime.parallel.both`);
* *joined*: :func:`nlid.scoring.twin.free_run_pair`, the second run stopped where its state equals the
  first's.

Checks that the two give the same displacements to the bit, and prints the sample where the second run
joined the first, and the median wall and CPU time (``time.process_time``: every thread) of each, with
the 1-minute load. ``--threads 1`` is what a run gets with ``--jobs`` equal to the number of cores (the
default of ``nlid study run``), ``--threads 2`` what it gets with ``--jobs 1`` on two cores.

    python benchmarks/bench_chaos_pair.py [--runs 8] [--repeat 3] [--threads 1|2]
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--runs", type=int, default=8, help="runs of the study to score (default 8)")
    parser.add_argument("--repeat", type=int, default=3, help="timings of each (default 3)")
    parser.add_argument("--threads", type=int, default=2, help="the run's thread budget (default 2)")
    args = parser.parse_args()

    from nlid.identification.pipeline import as_model, identify
    from nlid.runtime.parallel import both, thread_budget
    from nlid.scoring import SENSITIVITY_DELTA, initial_state, twin
    from nlid.simulation import free_run
    from nlid.study import load_study, plan_study
    from nlid.study.data import build_data

    joins = []
    original = twin._Pair.joined

    def joined(self):  # the sample where the second run joined the first (None: it never did)
        joins.append(self.join)
        return original(self)

    twin._Pair.joined = joined
    times: dict[str, list[float]] = {"whole": [], "joined": []}
    cpu: dict[str, list[float]] = {"whole": [], "joined": []}
    load = os.getloadavg()[0]
    for run in plan_study(load_study("paper-numerical"))[: args.runs]:
        spec = run.spec
        data = build_data(spec)
        model = as_model(spec.terms, without=spec.without, px_roots=spec.px_roots)
        fit = identify(data.record, model, spec.method, mass=data.mass, options=dict(spec.options))
        rec = data.heldout
        x0 = initial_state(rec)
        x1 = (x0[0] + SENSITIVITY_DELTA * float(np.std(rec.z)), x0[1])
        common = (fit.model, fit.theta, float(fit.mass), rec.f, rec.fs)

        def whole(common=common, rec=rec, x0=x0, x1=x1):
            return tuple(
                r[0]
                for r in both(
                    lambda: free_run(*common, force_hold=rec.force_hold, x0=x0),
                    lambda: free_run(*common, force_hold=rec.force_hold, x0=x1),
                )
            )

        def pair(common=common, rec=rec, x0=x0, x1=x1):
            return twin.free_run_pair(*common, force_hold=rec.force_hold, x0=x0, x1=x1)

        with thread_budget(args.threads):
            results = {}
            for _ in range(args.repeat):
                for name, call in (("whole", whole), ("joined", pair)):
                    c, t = time.process_time(), time.perf_counter()
                    results[name] = call()
                    times[name].append(time.perf_counter() - t)
                    cpu[name].append(time.process_time() - c)
        same = all(
            np.array_equal(a.view(np.int64), b.view(np.int64))
            for a, b in zip(results["whole"], results["joined"], strict=True)
        )
        print(f"  {spec.method:10s} seed {spec.seed}: bitwise the same {same}; joined at sample {joins[-1]} of {rec.n}")
        if not same:
            raise SystemExit("the joined pair differs from the whole runs")
    print(
        f"{args.runs} runs x {args.repeat}, thread budget {args.threads}, 1-min load {load:.1f}: "
        + "; ".join(
            f"{k}: median {statistics.median(v):.3f} s wall, {statistics.median(cpu[k]):.3f} s CPU"
            for k, v in times.items()
        )
    )


if __name__ == "__main__":
    main()
