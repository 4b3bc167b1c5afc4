"""oe on the paper's numerical example: coefficient errors against rfs, one and several segments, and time.

``paper-numerical`` (Sec. 3), 60 s at 2048 Hz, 2 % noise on z and a (the velocity is estimated by rfs),
mass given, seeds 0-4. ``oe`` starts from ``rfs``; ``oversample=1`` (the preset's force is held over
each sample and one RK4 step per sample is the scheme that generated the record). Columns: rfs, oe with
its automatic segments (the free run of this record is predictable: one segment, after short segments
first) and oe with 1-s multiple-shooting segments. Also the chaotic ``paper-experimental`` analogue
(px(z) roots given) with segments from its predictability horizon::

    python benchmarks/accuracy_oe_numerical.py [--seeds 0-4] [--duration 60]
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

import nlid
from nlid.simulation.presets import get_preset
from nlid_oe import OutputError


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", default="0-4")
    parser.add_argument("--duration", type=float, default=60.0)
    parser.add_argument("--experimental", action="store_true", help="also the chaotic paper-experimental analogue")
    args = parser.parse_args()
    lo, _, hi = args.seeds.partition("-")
    seeds = range(int(lo), int(hi or lo) + 1)
    print(f"load average {os.getloadavg()[0]:.1f}")
    preset = get_preset("paper-numerical").with_overrides(duration=args.duration)
    truth = preset.truth()["coefficients"]
    rows = {}
    for seed in seeds:
        record = preset.simulate(seed, noise={"z": 0.02, "a": 0.02}, channels=("z", "a"))
        fits = {"rfs": (nlid.identify(record, preset.terms, "rfs", mass=preset.mass), 0.0)}
        for label, options in (("oe", {}), ("oe, 1-s segments", {"segment_seconds": 1.0})):
            clock = time.perf_counter()
            method = OutputError(init="rfs", oversample=1, **options)
            fit = nlid.identify(record, preset.terms, method, mass=preset.mass)
            fits[label] = (fit, time.perf_counter() - clock)
        for label, (fit, seconds) in fits.items():
            err = {n: 100 * (fit.coefficients[n] / truth[n] - 1) for n in fit.terms}
            rows.setdefault(label, []).append((err, seconds))
            extra = "" if label == "rfs" else f"  {seconds:.1f} s, segments {fit.diagnostics['segments']}, " \
                f"stages {[st['segments'] for st in fit.diagnostics['stages']]}"
            print(f"seed {seed} {label:18s} " + " ".join(f"{n} {e:+.3f}" for n, e in err.items()) + extra)
    print("\nmedian |error| (%) over seeds; max in brackets")
    for label, items in rows.items():
        names = list(items[0][0])
        cells = [f"{n} {np.median([abs(e[n]) for e, _ in items]):.3f} [{max(abs(e[n]) for e, _ in items):.3f}]"
                 for n in names]
        secs = [s for _, s in items]
        print(f"{label:18s} " + "  ".join(cells) + (f"  time median {np.median(secs):.1f} s" if max(secs) else ""))
    if args.experimental:
        exp = get_preset("paper-experimental").with_overrides(duration=args.duration)
        truth = exp.truth()["coefficients"]
        for seed in seeds:
            record = exp.simulate(seed, noise={"z": 0.02, "a": 0.02}, channels=("z", "a"))
            rfs = nlid.identify(record, exp.terms, "rfs", mass=exp.mass, px_roots=exp.model().px_roots)
            clock = time.perf_counter()
            fit = nlid.identify(record, exp.terms, OutputError(init="rfs", oversample=1), mass=exp.mass,
                                px_roots=exp.model().px_roots)
            seconds = time.perf_counter() - clock
            d = fit.diagnostics
            print(f"experimental seed {seed}: {seconds:.1f} s, horizon {d['predictability_horizon_s']:.3g} s, "
                  f"{d['segments']} segments; rms {d['rms_error_start']['z']:.3g} -> {d['rms_error_fit']['z']:.3g} m")
            for n in fit.terms:
                print(f"   {n:18s} rfs {100 * (rfs.coefficients[n] / truth[n] - 1):+8.3f} %  "
                      f"oe {100 * (fit.coefficients[n] / truth[n] - 1):+8.3f} %")


if __name__ == "__main__":
    main()
