"""Free-run errors on the measured benchmarks before (equation-error start) and after ``oe``.

Each benchmark: the start identifier (``rfs``) and ``oe`` from it on the estimation data, both scored by
:func:`nlid.scoring.free_run_error` (through ``IdentifiedModel.score``) on the validation data:

* Silverbox: estimated on the multisines, validated on the arrow head; terms ``z^2, z^3`` (+ ``1, z, v``),
  mass estimated (units V).
* EMPS: estimated on the first 75 % of the record, validated on the last 25 %; ``sign(v)`` without ``z``,
  mass estimated.
* Bouc-Wen: estimated on the training multisine, validated on the sine sweep; ``bouc_wen(a, b)`` with
  ``z, v`` (no ``1``), mass 2 kg given; started from the benchmark's shape (800, -1100) and from the
  grid shape ``nlid discover`` picks (755, -1060); ``oe`` refines the shape.

Needs ``$NLID_DATA_DIR``. Run::

    python benchmarks/accuracy_oe.py [--only silverbox,emps,bouc-wen]
"""

from __future__ import annotations

import argparse
import os
import time

import nlid
from nlid_oe import OutputError


def _cases():
    # the benchmark's split: its estimation part, scored on the arrow head (test set) only
    silver = nlid.load("dataset:silverbox:estimation")
    yield "silverbox", silver, nlid.load("dataset:silverbox:arrow-full"), "z^2, z^3", (), None
    emps = nlid.load("dataset:emps")
    est, val = emps.split(0.25)
    yield "emps", est, val, "sign(v)", ("z",), None
    bw, sweep = nlid.load("dataset:bouc-wen"), nlid.load("dataset:bouc-wen:sinesweep")
    for shape in ("800, -1100", "755, -1060"):
        yield f"bouc-wen ({shape})", bw, sweep, f"bouc_wen({shape})", ("1",), 2.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--only", default="", help="comma-separated benchmark names (prefixes)")
    args = parser.parse_args()
    os.environ.setdefault("NLID_DATA_DIR", os.path.join(os.path.dirname(__file__), "..", "..", "shared", "data"))
    only = [x.strip() for x in args.only.split(",") if x.strip()]
    for name, est, val, terms, without, mass in _cases():
        if only and not any(name.startswith(o) for o in only):
            continue
        start = nlid.identify(est, terms, "rfs", mass=mass, without=without)
        clock = time.perf_counter()
        fit = nlid.identify(est, terms, OutputError(init="rfs"), mass=mass, without=without)
        seconds = time.perf_counter() - clock
        before, after = start.score(val), fit.score(val)
        print(f"== {name}: {est.n} estimation samples, {val.n} validation samples; oe took {seconds:.1f} s")
        print(f"   free-run RMS error on validation: rfs {before.freerun_rmse:.4g} -> oe {after.freerun_rmse:.4g} "
              f"({est.units['z']}) {after.freerun_note}")
        print(f"   on estimation: {fit.diagnostics['rms_error_start']} -> {fit.diagnostics['rms_error_fit']}")
        print(f"   mass: rfs {start.mass:.6g} -> oe {fit.mass:.6g} (+/- {fit.mass_standard_error or 0:.3g})")
        for old, new in zip(start.terms, fit.terms, strict=True):
            se = (fit.standard_errors or {}).get(new, float("nan"))
            before, after = start.coefficients[old], fit.coefficients[new]
            print(f"   {old:>22s} {before:14.6g} -> {new:>24s} {after:14.6g} +/- {se:.3g}")
        for term, entry in fit.diagnostics["shapes"].items():
            print(f"   shape of {term}: {entry['values']} +/- {entry['standard_errors']}")
        print(f"   stages: {fit.diagnostics['stages']}")


if __name__ == "__main__":
    main()
