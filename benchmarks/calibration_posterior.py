"""Calibration matrix of the posterior's 90 % intervals (issues 6 and 15).

Cells: presets ``paper-numerical`` and ``paper-experimental`` x the recorded
channels (z; z,a; z,v; z,v,a) x noise of 1, 2 and 5 % of each channel's
standard deviation. In each replicate the record is simulated with its seed,
rfs identifies the preset's model with the known mass (``paper-experimental``
with the px(z) roots at the true ones), and ``sample_posterior`` runs with its
defaults (bias correction by simulation with the noise levels established
from the record, the stiffness integrated out, emcee until converged). For
every damping-family coefficient it records the posterior mean, sd, 90 %
interval, whether the interval contains the truth and the bias correction's
shift in posterior standard deviations.

Every replicate is appended to a CSV as soon as it finishes (one row per
coefficient); a rerun with the same ``--csv`` skips what is there, so an
interrupted run resumes. The summary prints, per cell and coefficient, the
percentage of replicates whose interval contains the truth and the standard
deviation of the standardised error (mean - truth) / sd (1 when calibrated),
and the replicates that failed (e.g. a noise level that could not be
established).

    python benchmarks/calibration_posterior.py [--seeds 1000:1050] [--preset NAME ...]
        [--channels z,a ...] [--noise 0.02 ...] [--workers 2] [--csv FILE] [--summary-only]

With 50 replicates a perfectly calibrated 90 % interval lands outside 85-95 %
for a given coefficient about 25 % of the time (binomial sd 4.2 points); the
summary prints that sd beside each coverage, the number of coefficient-cells
within 85-95 %, and how many a perfectly calibrated posterior would put there
at the same replicate counts (the binomial expectation; :func:`expected_within`).
"""

from __future__ import annotations

import argparse
import csv
import multiprocessing
import time
from collections import defaultdict
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from pathlib import Path

import numpy as np

PRESETS = ("paper-numerical", "paper-experimental")
CHANNELS = ("z", "z,a", "z,v", "z,v,a")
NOISE = (0.01, 0.02, 0.05)
FIELDS = (
    "preset",
    "channels",
    "noise",
    "seed",
    "status",
    "term",
    "truth",
    "least_squares",
    "mean",
    "sd",
    "q05",
    "q95",
    "covers",
    "z",
    "shift_sd",
    "noise_z",
    "noise_v",
    "seconds",
    "message",
)
#: Default per-replicate file (the repository's results/ folder is not versioned).
DEFAULT_CSV = Path(__file__).resolve().parent.parent / "results" / "calibration_posterior.csv"


def replicate(preset_name: str, channels: str, noise: float, seed: int) -> list[dict[str, object]]:
    """One replicate of one cell: a row per damping coefficient (or one row saying why it failed)."""
    from nlid import identify
    from nlid.bayes import sample_posterior
    from nlid.errors import NlidError
    from nlid.simulation.presets import get_preset

    preset = get_preset(preset_name)
    model = preset.model()
    truth = preset.truth()["coefficients"]
    base = {"preset": preset_name, "channels": channels, "noise": noise, "seed": seed}
    start = time.perf_counter()
    record = preset.simulate(seed, noise=noise, channels=tuple(channels.split(",")))
    result = identify(record, model, "rfs", mass=preset.mass)
    try:
        post = sample_posterior(record, result, params="damping", seed=seed)
    except NlidError as exc:
        return [{**base, "status": type(exc).__name__, "message": str(exc), "seconds": time.perf_counter() - start}]
    seconds = time.perf_counter() - start
    lik = post.likelihood
    noise_sd = lik.info.get("noise_sd", {})
    shifts = post.bias_shifts
    rows = []
    for name, s in post.summary_dict().items():
        i = model.index(name)
        rows.append(
            {
                **base,
                "status": "ok",
                "term": name,
                "truth": truth[name],
                "least_squares": float(lik.estimate[i]),
                "mean": s["mean"],
                "sd": s["sd"],
                "q05": s["q05"],
                "q95": s["q95"],
                "covers": int(s["q05"] <= truth[name] <= s["q95"]),
                "z": (s["mean"] - truth[name]) / s["sd"],
                "shift_sd": shifts.get(name, float("nan")),
                "noise_z": noise_sd.get("z", float("nan")),
                "noise_v": noise_sd.get("v", float("nan")),
                "seconds": seconds,
                "message": "",
            }
        )
    return rows


def _key(row: dict[str, object]) -> tuple[str, str, float, int]:
    return (str(row["preset"]), str(row["channels"]), float(row["noise"]), int(row["seed"]))


def read_rows(path: Path) -> list[dict[str, object]]:
    """The rows written so far."""
    if not path.is_file():
        return []
    with path.open(newline="") as fh:
        return list(csv.DictReader(fh))


def run(cells: list[tuple[str, str, float]], seeds: range, workers: int, path: Path) -> None:
    """Run every (cell, seed) not yet in ``path``, appending rows as replicates finish."""
    done = {_key(r) for r in read_rows(path)}
    todo = [(p, c, x, s) for (p, c, x) in cells for s in seeds if (p, c, float(x), s) not in done]
    print(f"{len(todo)} replicates to run ({len(done)} already in {path})", flush=True)
    if not todo:
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    new = not path.is_file()
    start = time.perf_counter()
    with (
        path.open("a", newline="") as fh,
        ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn")) as pool,
    ):
        writer = csv.DictWriter(fh, FIELDS)
        if new:
            writer.writeheader()
        pending = {pool.submit(replicate, *job) for job in todo[: 2 * workers]}
        queue = iter(todo[2 * workers :])
        finished = 0
        while pending:
            ready, pending = wait(pending, return_when=FIRST_COMPLETED)
            for fut in ready:
                writer.writerows(fut.result())
                fh.flush()
                finished += 1
                nxt = next(queue, None)
                if nxt is not None:
                    pending.add(pool.submit(replicate, *nxt))
            if finished % 20 < len(ready) or not pending:
                print(f"  {finished}/{len(todo)} in {time.perf_counter() - start:.0f} s", flush=True)


def expected_within(replicates: list[int], level: float = 0.90, band: tuple[float, float] = (85.0, 95.0)) -> float:
    """Expected number of coefficient-cells whose coverage lands in ``band`` (percent) when every interval is exact.

    A calibrated ``level`` interval covers the truth in each replicate with probability ``level``, so a cell
    of ``n`` replicates covers ``k ~ Binomial(n, level)`` of them; the cell is within the band when
    ``100 k / n`` is. ``replicates`` holds one replicate count per coefficient-cell.
    """
    from scipy.stats import binom

    total = 0.0
    for n in replicates:
        lo = int(np.ceil(band[0] * n / 100 - 1e-9))
        hi = int(np.floor(band[1] * n / 100 + 1e-9))
        total += float(binom.cdf(hi, n, level) - binom.cdf(lo - 1, n, level))
    return total


def summary(path: Path, cells: list[tuple[str, str, float]], seeds: range) -> None:
    """Print coverage per cell and coefficient."""
    wanted = {(p, c, float(x)) for p, c, x in cells}
    rows = [r for r in read_rows(path) if _key(r)[:3] in wanted and int(r["seed"]) in seeds]
    by_cell: dict[tuple[str, str, float], list[dict[str, object]]] = defaultdict(list)
    for r in rows:
        by_cell[_key(r)[:3]].append(r)
    print(f"coverage of the 90 % intervals ({path}); in brackets the sd of the standardised error")
    print(f"{'preset':20s} {'channels':8s} {'noise':>5s} {'reps':>5s}  coefficient: coverage % (sd z)")
    outside = []
    counts: list[int] = []
    for cell in cells:
        cell = (cell[0], cell[1], float(cell[2]))
        got = by_cell.get(cell, [])
        ok = [r for r in got if r["status"] == "ok"]
        failed = sorted({int(r["seed"]) for r in got if r["status"] != "ok"})
        reps = len({int(r["seed"]) for r in ok})
        terms = list(dict.fromkeys(str(r["term"]) for r in ok))
        parts = []
        for t in terms:
            sel = [r for r in ok if r["term"] == t]
            cov = 100 * np.mean([int(r["covers"]) for r in sel])
            sdz = np.std([float(r["z"]) for r in sel])
            parts.append(f"{t}: {cov:.0f} ({sdz:.2f})")
            if len(sel) >= 20:
                counts.append(len(sel))
            if not 85 <= cov <= 95 and len(sel) >= 20:
                outside.append((cell, t, cov, len(sel)))
        note = f"  [{len(failed)} failed: {got[0]['message'] if failed else ''}]" if failed else ""
        binom = 100 * np.sqrt(0.09 / reps) if reps else float("nan")
        print(
            f"{cell[0]:20s} {cell[1]:8s} {100 * cell[2]:4.0f}% {reps:5d}  "
            + "; ".join(parts)
            + f"  (binomial sd {binom:.1f}){note}"
        )
    if counts:
        within = len(counts) - len(outside)
        print(
            f"within 85-95 %: {within} of {len(counts)} coefficient-cells (>= 20 replicates); "
            f"a perfectly calibrated posterior would put {expected_within(counts):.1f} there on average "
            "at these replicate counts"
        )
    if outside:
        print("outside 85-95 % (cells with at least 20 replicates):")
        for cell, t, cov, n in outside:
            print(f"  {cell[0]} {cell[1]} {100 * cell[2]:.0f}% {t}: {cov:.0f} % of {n}")


def markdown(path: Path, cells: list[tuple[str, str, float]], seeds: range) -> None:
    """The table of docs/posterior.md: per preset and channel set, each noise level's coverage range."""
    wanted = {(p, c, float(x)) for p, c, x in cells}
    rows = [r for r in read_rows(path) if _key(r)[:3] in wanted and int(r["seed"]) in seeds and r["status"] == "ok"]
    noises = sorted({float(x) for _, _, x in cells})
    print("| preset | channels | " + " | ".join(f"{100 * x:.0f} % noise" for x in noises) + " |")
    print("| --- | --- | " + " | ".join("---" for _ in noises) + " |")
    for preset, channels in dict.fromkeys((p, c) for p, c, _ in cells):
        out = []
        for x in noises:
            sel = [r for r in rows if (r["preset"], r["channels"], float(r["noise"])) == (preset, channels, x)]
            if not sel:
                out.append("–")
                continue
            reps = len({int(r["seed"]) for r in sel})
            cov, sdz = [], []
            for t in dict.fromkeys(str(r["term"]) for r in sel):
                ts = [r for r in sel if r["term"] == t]
                cov.append(100 * np.mean([int(r["covers"]) for r in ts]))
                sdz.append(np.std([float(r["z"]) for r in ts]))
            rng = f"{min(cov):.0f}" if min(cov) == max(cov) else f"{min(cov):.0f}–{max(cov):.0f}"
            out.append(f"{rng} % ({min(sdz):.2f}–{max(sdz):.2f}; n = {reps})")
        print(f"| {preset} | {channels} | " + " | ".join(out) + " |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", default="1000:1050", help="first:stop of the replicate seeds (default 1000:1050)")
    parser.add_argument("--workers", type=int, default=2, help="processes (default 2)")
    parser.add_argument("--preset", action="append", choices=PRESETS, help="preset(s) (default both)")
    parser.add_argument("--channels", action="append", choices=CHANNELS, help="channel set(s) (default all four)")
    parser.add_argument("--noise", action="append", type=float, help="noise fraction(s) (default 0.01 0.02 0.05)")
    parser.add_argument("--csv", type=Path, default=DEFAULT_CSV, help=f"per-replicate results (default {DEFAULT_CSV})")
    parser.add_argument("--summary-only", action="store_true", help="print the table from the CSV, run nothing")
    parser.add_argument("--markdown", action="store_true", help="also print the compact table of docs/posterior.md")
    args = parser.parse_args()
    first, stop = (int(x) for x in args.seeds.split(":"))
    seeds = range(first, stop)
    cells = [
        (p, c, x) for p in (args.preset or PRESETS) for c in (args.channels or CHANNELS) for x in (args.noise or NOISE)
    ]
    if not args.summary_only:
        run(cells, seeds, args.workers, args.csv)
    summary(args.csv, cells, seeds)
    if args.markdown:
        markdown(args.csv, cells, seeds)


if __name__ == "__main__":
    main()
