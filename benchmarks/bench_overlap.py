"""The overlap of a run's scores with the next identification, alone (issue 36's study row, fifth session).

Runs the built-in paper-numerical study in this process (``nlid.study.run_study`` with ``--rerun`` and no
report) with ``LocalExecutor(jobs=1)`` and with ``LocalExecutor(jobs=1, overlap=False)``, alternately, the
same tree: the difference is the overlap, without the start-up and the report that ``bench_study.py`` also
times. Prints, for each, the runs' wall time, the parent's CPU (the run children belong to the fork server
and are not counted), the sum of the ``seconds`` column and the 1-minute load before each repetition.

    python benchmarks/bench_overlap.py [--repeat 3] [--out DIR]
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import tempfile
import time
from pathlib import Path


def _cpu() -> float:
    """This (the parent) process's CPU seconds: the run children are the fork server's, not counted here."""
    own = resource.getrusage(resource.RUSAGE_SELF)
    return own.ru_utime + own.ru_stime


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeat", type=int, default=3, help="pairs of studies (default 3)")
    parser.add_argument("--out", type=Path, help="study folder (default: a temporary one)")
    args = parser.parse_args()

    from nlid.study import LocalExecutor, ResultStore, load_study, plan_study, run_study

    config = load_study("paper-numerical")
    runs = plan_study(config)
    figures: dict[bool, list[tuple[float, float, float, float]]] = {True: [], False: []}
    with tempfile.TemporaryDirectory() as tmp, open(os.devnull, "w") as quiet:
        out = args.out or Path(tmp) / "study"
        run_study(config, out, executor=LocalExecutor(jobs=1), rerun=True, report=False, progress=False, log=quiet)
        for _ in range(args.repeat):
            for overlap in (False, True):
                load = os.getloadavg()[0]
                cpu, start = _cpu(), time.perf_counter()
                executor = LocalExecutor(jobs=1, overlap=overlap)
                run_study(config, out, executor=executor, rerun=True, report=False, progress=False, log=quiet)
                wall, cpu = time.perf_counter() - start, _cpu() - cpu
                seconds = float(ResultStore(out).results(runs)["seconds"].sum())
                figures[overlap].append((wall, cpu, seconds, load))
                print(
                    f"  overlap={overlap!s:5}: runs {wall:.2f} s wall, parent CPU {cpu:.2f} s, "
                    f"sum of seconds {seconds:.2f} s, "
                    f"wall / sum {wall / seconds:.2f}, load {load:.1f}",
                    flush=True,
                )
    for overlap, rows in figures.items():
        walls, cpus, sums, loads = zip(*rows, strict=True)
        print(
            f"overlap={overlap!s:5}: median runs wall {statistics.median(walls):.2f} s, "
            f"parent CPU {statistics.median(cpus):.2f} s, "
            f"sum of seconds {statistics.median(sums):.2f} s, wall / sum "
            f"{statistics.median(w / s for w, s in zip(walls, sums, strict=True)):.2f} "
            f"(load {min(loads):.1f}-{max(loads):.1f})"
        )


if __name__ == "__main__":
    main()
