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

    python benchmarks/bench_rfs_sindy.py [--repeat 7]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

import pysindy as ps  # noqa: E402
from _common import median_time, peak_memory  # noqa: E402

from nlid import identify  # noqa: E402
from nlid.presets import get_preset  # noqa: E402
from nlid.terms import Model  # noqa: E402
from nlid_rfs import RestoringForceSurface  # noqa: E402
from nlid_sindy import SparseIdentification  # noqa: E402
from nlid_sindy.identifier import FEATURE_NAMES, build_problem  # noqa: E402
from nlid_sindy.library import TermLibrary  # noqa: E402
from nlid_sindy.threshold import stlsq  # noqa: E402

TERMS = "z^3, z^2, v*|v|"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7, help="timed runs per measurement (default 7)")
    args = parser.parse_args(argv)
    preset = get_preset("paper-numerical")
    record = preset.simulate(0, noise={"z": 0.02, "a": 0.02}, channels=("z", "a"))
    model = Model.from_spec(TERMS)
    mass = preset.mass
    print(f"paper-numerical seed 0: {record.n} samples, 2 % noise on z and a, terms {model}, mass known")

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
    plugin = measure(
        f"sindy, threshold={chosen:.3g} given",
        lambda: SparseIdentification(threshold=chosen).identify(record, model, mass=mass),
    )

    problem = build_problem(record, model, mass)

    def direct():
        library = TermLibrary(model, fs=record.fs, cutoff=problem.filtered_at)
        fitted = ps.SINDy(optimizer=stlsq(chosen, problem.rows.size), feature_library=library)
        names = list(FEATURE_NAMES[: 2 if problem.u is None else 3])
        return fitted.fit(problem.x, t=problem.dt, x_dot=problem.x_dot, u=problem.u, feature_names=names)

    pysindy = measure("pysindy SINDy.fit on the same arrays", direct)

    width = max(len(r[0]) for r in rows)
    print(f"{'':{width}}  {'median':>9}  {'min':>9}  {'peak MB':>8}")
    for label, med, best, peak in rows:
        print(f"{label:{width}}  {1e3 * med:7.0f}ms  {1e3 * best:7.0f}ms  {peak:8.1f}")
    print(f"sindy plugin overhead over pysindy on the same arrays: {plugin / pysindy:.2f}x (target <= 1.5x)")


if __name__ == "__main__":
    main()
