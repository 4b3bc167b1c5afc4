"""Speed of the rfs and sindy identifiers on one paper-numerical record.

One record (seed 0, 122 880 samples, 2 % noise on z and a, velocity
estimated; terms z^3, z^2, v*|v| plus 1, z, v; mass known) is identified by

* ``rfs`` (the identifier alone, and through :func:`nlid.identify`, which adds
  equilibria, modal parameters and epsilon);
* ``sindy`` with its default cross-validated threshold, and with the threshold
  it chose given explicitly;
* pysindy called directly on the arrays the plugin gives it (the same state,
  derivatives, library and optimizer): ``SINDy(...).fit(x, t, x_dot, u)``.

The overhead of the sindy plugin is its time with the threshold given divided
by the direct pysindy call (target <= 1.5x): the plugin's own work is nlid's
filtering of the record, mapping the coefficients back to R and the standard
errors. Median of several runs after a warm-up; the machine is shared, so
re-measure on a quiet one.

    python benchmarks/bench_rfs_sindy.py [--repeat 7] [--threads 1]

``--threads`` limits the BLAS threads (threadpoolctl): on a shared, loaded
machine two-thread BLAS calls wait for each other and their times scatter by
an order of magnitude; one thread gives stable figures.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

import pysindy as ps  # noqa: E402
from _common import median_time, peak_memory  # noqa: E402

from nlid import identify  # noqa: E402
from nlid.model.terms import Model  # noqa: E402
from nlid.simulation.presets import get_preset  # noqa: E402
from nlid_rfs import RestoringForceSurface  # noqa: E402
from nlid_sindy import SparseIdentification  # noqa: E402
from nlid_sindy.identifier import FEATURE_NAMES, build_problem  # noqa: E402
from nlid_sindy.library import TermLibrary  # noqa: E402
from nlid_sindy.threshold import stlsq  # noqa: E402

TERMS = "z^3, z^2, v*|v|"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7, help="timed runs per measurement (default 7)")
    parser.add_argument("--threads", type=int, default=None, help="limit BLAS threads (default: library default)")
    args = parser.parse_args(argv)
    if args.threads is not None:
        from threadpoolctl import threadpool_limits

        with threadpool_limits(limits=args.threads, user_api="blas"):
            return measure_all(args)
    return measure_all(args)


def measure_all(args: argparse.Namespace) -> None:
    """Run and print every measurement."""
    preset = get_preset("paper-numerical")
    record = preset.simulate(0, noise={"z": 0.02, "a": 0.02}, channels=("z", "a"))
    model = Model.from_spec(TERMS)
    mass = preset.mass
    threads = "default" if args.threads is None else args.threads
    print(f"paper-numerical seed 0: {record.n} samples, 2 % noise on z and a, terms {model}, mass known")
    print(f"median of {args.repeat} runs after one warm-up; BLAS threads: {threads}")

    rows = []

    def measure(label, fn):
        med, times = median_time(fn, repeat=args.repeat)
        _, peak = peak_memory(fn)
        rows.append((label, med, min(times), peak))
        return med

    measure("rfs (identifier)", lambda: RestoringForceSurface().identify(record, model, mass=mass))
    measure("rfs (nlid.identify)", lambda: identify(record, model, "rfs", mass=mass))
    chosen = SparseIdentification().identify(record, model, mass=mass).diagnostics["threshold"]
    measure("sindy, threshold by CV (identifier)", lambda: SparseIdentification().identify(record, model, mass=mass))
    measure("sindy (nlid.identify)", lambda: identify(record, model, "sindy", mass=mass))
    given = SparseIdentification(threshold=chosen)
    problem = build_problem(record, model, mass)

    def plugin():
        return given.identify(record, model, mass=mass)

    def direct():
        library = TermLibrary(model, fs=record.fs, cutoff=problem.filtered_at)
        fitted = ps.SINDy(optimizer=stlsq(chosen, problem.rows.size), feature_library=library)
        names = list(FEATURE_NAMES[: 2 if problem.u is None else 3])
        return fitted.fit(problem.x, t=problem.dt, x_dot=problem.x_dot, u=problem.u, feature_names=names)

    measure(f"sindy, threshold={chosen:.3g} given", plugin)
    measure("pysindy SINDy.fit on the same arrays", direct)
    # the overhead: the two calls alternate, so that both see the same load on a shared machine
    plugin(), direct()
    ratios, pairs = [], []
    for _ in range(2 * args.repeat + 1):
        t0 = time.perf_counter()
        plugin()
        t1 = time.perf_counter()
        direct()
        t2 = time.perf_counter()
        ratios.append((t1 - t0) / (t2 - t1))
        pairs.append((t1 - t0, t2 - t1))
    width = max(len(r[0]) for r in rows)
    print(f"{'':{width}}  {'median':>9}  {'min':>9}  {'peak MB':>8}")
    for label, med, best, peak in rows:
        print(f"{label:{width}}  {1e3 * med:7.0f}ms  {1e3 * best:7.0f}ms  {peak:8.1f}")
    best = min(p for p, _ in pairs) / min(d for _, d in pairs)
    print(
        f"sindy plugin overhead over pysindy on the same arrays: median of {len(ratios)} alternating pairs "
        f"{statistics.median(ratios):.2f}x, ratio of the fastest runs {best:.2f}x (target <= 1.5x)"
    )


if __name__ == "__main__":
    main()
