"""Calibration of the structure posterior's 90 % intervals (issue 24, item 7).

Cells: the structure presets ``3dof-cubic`` (element ``z3^3``) and
``2dof-double-well`` (elements ``(z1-z2)^3``, ``(z1-z2)^2``,
``(v1-v2)*|v1-v2|``) x noise on the accelerations only (z, v, a written; the regressors exact:
no errors-in-variables bias) or on the displacements and accelerations
(z, a written; the velocities estimated from noisy z; a structure's
posterior has no correction by simulation, so this cell measures what that
costs). In each replicate the record is simulated with its seed, ``rfs``
identifies the elements with the mass given, and ``sample_posterior(...,
params="elements")`` samples every element with K, C and the static force
integrated out.

Every replicate is appended to a CSV as soon as it finishes; a rerun with the
same ``--csv`` skips what is there (resumes). The summary prints, per cell and
element, the share of intervals that contain the truth, the binomial sd of
that share, and the sd of the standardised error ``(mean - truth) / sd``
(1 when calibrated).

    python benchmarks/calibration_structure_posterior.py [--seeds 0:40] [--duration 30]
        [--preset 3dof-cubic ...] [--cell a ...] [--csv FILE] [--summary-only]
"""

from __future__ import annotations

import argparse
import csv
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

TERMS = {"3dof-cubic": "z3^3", "2dof-double-well": "(z1-z2)^3, (z1-z2)^2, (v1-v2)*|v1-v2|"}
#: noise per cell, and the channels written (v estimated from z when it is not written)
CELLS = {"a": {"a": 0.02}, "z,a": {"z": 0.02, "a": 0.02}}
CHANNELS = {"a": ("z", "v", "a"), "z,a": ("z", "a")}
FIELDS = ("preset", "cell", "seed", "status", "term", "truth", "mean", "sd", "q05", "q95", "covers", "seconds")


def _seeds(text: str) -> list[int]:
    lo, _, hi = text.partition(":")
    return list(range(int(lo), int(hi))) if hi else [int(x) for x in text.split(",")]


def replicate(preset_name: str, cell: str, seed: int, duration: float) -> list[dict]:
    """One record, one identification, one posterior: a row per element."""
    import nlid
    from nlid.bayes import sample_posterior
    from nlid.simulation.presets import get_preset

    preset = get_preset(preset_name).with_overrides(duration=duration)
    record = preset.simulate(seed, noise=CELLS[cell], channels=CHANNELS[cell])
    truth = record.meta["reference"]["coefficients"]
    start = time.perf_counter()
    base = {"preset": preset_name, "cell": cell, "seed": seed}
    try:
        fit = nlid.identify(record, TERMS[preset_name], "rfs", mass=record.mass)
        post = sample_posterior(record, fit, params="elements", seed=seed)
    except nlid.errors.NlidError as exc:
        return [{**base, "status": f"failed: {exc}"}]
    seconds = time.perf_counter() - start
    rows = []
    summary = post.summary_dict()
    for name in post.names:
        s, ref = summary[name], float(truth[name])
        rows.append(
            {
                **base,
                "status": "ok",
                "term": name,
                "truth": ref,
                "mean": s["mean"],
                "sd": s["sd"],
                "q05": s["q05"],
                "q95": s["q95"],
                "covers": int(s["q05"] <= ref <= s["q95"]),
                "seconds": seconds,
            }
        )
    return rows


def summarise(path: Path) -> None:
    """Coverage per cell and element, with its binomial sd and the sd of the standardised error."""
    groups: dict[tuple, list[dict]] = defaultdict(list)
    failed: dict[tuple, int] = defaultdict(int)
    with path.open() as fh:
        for row in csv.DictReader(fh):
            if row["status"] != "ok":
                failed[(row["preset"], row["cell"])] += 1
                continue
            groups[(row["preset"], row["cell"], row["term"])].append(row)
    print(f"{'preset':18s} {'noise on':9s} {'element':18s} {'n':>4s} {'covered':>8s} {'binom sd':>8s} {'sd(z)':>6s}")
    for (preset, cell, term), rows in sorted(groups.items()):
        covers = np.array([int(r["covers"]) for r in rows])
        zs = np.array([(float(r["mean"]) - float(r["truth"])) / float(r["sd"]) for r in rows])
        share = 100 * covers.mean()
        binom = 100 * np.sqrt(0.9 * 0.1 / len(rows))
        print(f"{preset:18s} {cell:9s} {term:18s} {len(rows):4d} {share:7.1f}% {binom:7.1f}% {zs.std(ddof=1):6.2f}")
    for key, count in failed.items():
        print(f"failed replicates in {key}: {count}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", default="0:40", help="range lo:hi or a list (default 0:40)")
    parser.add_argument("--duration", type=float, default=30.0, help="record length in s (default 30)")
    parser.add_argument("--preset", nargs="*", default=list(TERMS), choices=list(TERMS))
    parser.add_argument("--cell", nargs="*", default=list(CELLS), choices=list(CELLS))
    parser.add_argument("--csv", default="calibration_structure_posterior.csv")
    parser.add_argument("--summary-only", action="store_true")
    args = parser.parse_args()
    path = Path(args.csv)
    if not args.summary_only:
        done = set()
        if path.exists():
            with path.open() as fh:
                done = {(r["preset"], r["cell"], int(r["seed"])) for r in csv.DictReader(fh)}
        new = not path.exists()
        with path.open("a", newline="") as fh:
            writer = csv.DictWriter(fh, fieldnames=FIELDS)
            if new:
                writer.writeheader()
            for preset in args.preset:
                for cell in args.cell:
                    for seed in _seeds(args.seeds):
                        if (preset, cell, seed) in done:
                            continue
                        for row in replicate(preset, cell, seed, args.duration):
                            writer.writerow(row)
                        fh.flush()
    summarise(path)


if __name__ == "__main__":
    main()
