"""The ``discover-refine`` pipeline of ``nlid bench`` on one benchmark, in one process, with its oe fits (issue 36).

The pipeline that takes most of ``nlid bench`` (docs/performance.md, round four, fourth session): a search
whose candidates are judged by ``oe``'s cross-fitted fits, then ``oe`` on the whole estimation part. Prints,
per run, the wall and CPU time (``time.process_time``: every thread of the process) of
:func:`nlid.benchmarking.pipelines.fit_pipelines`, the 1-minute load before it, every ``oe`` fit (samples,
terms, evaluations of the free run, seconds), the effects the search added, and the row's figure on each of
the benchmark's test sets (what the leaderboard reports). ``--profile`` adds a cProfile of the last run.

    python benchmarks/bench_discover_refine.py --benchmark silverbox [--repeat 3] [--profile]

Needs ``$NLID_DATA_DIR``. Run it once first when numba's cache may be cold (a fresh tree compiles the
kernels in its first fit: ~50 s CPU).
"""

from __future__ import annotations

import argparse
import cProfile
import os
import pstats
import statistics
import time
from typing import Any

import nlid_oe.identifier as oe_identifier
from nlid.benchmarking.data import load_estimation, load_test
from nlid.benchmarking.jobs import score_model
from nlid.benchmarking.pipelines import fit_pipelines, parse_pipelines
from nlid.benchmarking.protocol import load_protocol
from nlid.errors import DataError

FITS: list[dict[str, Any]] = []
_IDENTIFY = oe_identifier.OutputError.identify


def _counted(self: Any, record: Any, model: Any, *, mass: float | None = None) -> Any:
    start = time.perf_counter()
    estimate = _IDENTIFY(self, record, model, mass=mass)
    FITS.append(
        {
            "samples": record.n,
            "terms": len(model.terms),
            "nfev": estimate.diagnostics.get("nfev"),
            "tol": self.settings["tol"],
            "seconds": time.perf_counter() - start,
        }
    )
    return estimate


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--benchmark", default="silverbox", help="emps-internal, silverbox or bouc-wen")
    parser.add_argument("--repeat", type=int, default=3, help="runs (default 3)")
    parser.add_argument("--profile", action="store_true", help="cProfile the last run")
    args = parser.parse_args()
    oe_identifier.OutputError.identify = _counted  # type: ignore[method-assign]
    protocol = load_protocol(args.benchmark)
    record, offsets = load_estimation(protocol)
    specs = parse_pipelines("discover-refine")
    walls, cpus = [], []
    fitted = None
    for i in range(args.repeat):
        FITS.clear()
        load = os.getloadavg()[0]
        profile = cProfile.Profile() if args.profile and i == args.repeat - 1 else None
        wall, cpu = time.perf_counter(), time.process_time()
        if profile is not None:
            profile.enable()
        fitted = fit_pipelines(record, protocol, specs)[0]
        if profile is not None:
            profile.disable()
        walls.append(time.perf_counter() - wall)
        cpus.append(time.process_time() - cpu)
        nfev = [f["nfev"] for f in FITS]
        print(
            f"  run {i + 1}: {walls[-1]:.1f} s wall, {cpus[-1]:.1f} s CPU, load {load:.1f}; {len(FITS)} oe fits "
            f"({sum(f['seconds'] for f in FITS):.1f} s wall), evaluations {nfev}",
            flush=True,
        )
    assert fitted is not None and not isinstance(fitted, str)
    print(
        f"{args.benchmark} discover-refine: median {statistics.median(walls):.1f} s wall, "
        f"{statistics.median(cpus):.1f} s CPU over {len(walls)} runs"
    )
    print("  added:", ", ".join(f"{s['effect']} ({', '.join(s['terms'])})" for s in fitted.choices["steps"]))
    for test in protocol.tests:
        try:
            scores = score_model(fitted, load_test(protocol, test, offsets), test.rule)
        except DataError as exc:  # a test set the user supplies (e.g. Bouc-Wen's multisine)
            print(f"  {test.name}: not scored ({exc})")
            continue
        print(f"  {test.name}: {scores['rmse']:.6g}")
    if profile is not None:
        pstats.Stats(profile).sort_stats("cumulative").print_stats(40)


if __name__ == "__main__":
    main()
