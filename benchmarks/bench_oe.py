"""Time and accuracy of ``oe`` (and of ``nlid discover --refine``), before and after, interleaved.

Cases (``--case``):

* ``numerical``: ``paper-numerical`` (60 s at 2048 Hz, 2 % noise on z and a, mass given), ``oe`` at the
  **defaults a user gets** (``nlid identify FILE --method oe --terms "z^3, z^2, v*|v|" --mass 0.2``:
  ``init="rfs"``, ``oversample=8``, automatic segments); the coefficient errors against the preset's truth.
  ``--oversample 1`` times the setting of ``benchmarks/accuracy_oe_numerical.py`` instead (rounds one to
  three reported that figure; every line says which oversampling it timed).
* ``experimental``: the chaotic ``paper-experimental`` record (120 s at 512 Hz, px(z) roots given), the
  same call with multiple shooting from the predictability horizon; coefficients against the truth.
* ``discover``: ``discover(bouc-wen, "z, v", "rfs", mass=2, validation=sinesweep, refine=True)`` (the
  library call of ``nlid discover dataset:bouc-wen --declared "z, v" --mass 2 --validation
  dataset:bouc-wen:sinesweep --refine``; needs ``$NLID_DATA_DIR``).

Every timed run is a fresh process (``--one``) whose compiled kernels are loaded by a short warm-up fit
first; with ``--trees BEFORE,AFTER`` the runs alternate between the two source trees (each on its own
``PYTHONPATH``), so both see the same load. Each line prints the wall and CPU time, the 1-minute load
average at the start and end of the run, the kernel threads and the result::

    git archive main | tar -x -C /tmp/poe_base
    python benchmarks/bench_oe.py --case numerical --seeds 0-4 --trees /tmp/poe_base,.
    python benchmarks/bench_oe.py --case experimental --trees .
    python benchmarks/bench_oe.py --case discover --repeat 5 --trees /tmp/poe_base,.

``NLID_WORKERS=1`` (or 2) fixes the kernel threads of :mod:`nlid.runtime.parallel` (the "after" tree only).
``--busy 2`` keeps two other processes spinning while the runs are timed (the issue's "load 2")::

    python benchmarks/bench_oe.py --case numerical --seeds 0 --repeat 5 --busy 2

The figure of docs/performance.md (round four), the user's defaults, seed 0, five runs, and the profile
of one such fit (cProfile, the top entries by cumulative time)::

    python benchmarks/bench_oe.py --case numerical --seeds 0 --repeat 5
    python benchmarks/bench_oe.py --case numerical --seeds 0 --profile
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


def _warm_up() -> None:
    """Load the compiled kernels (on-disk numba cache) with a short oe fit, outside the timing."""
    import nlid
    from nlid.simulation.presets import get_preset
    from nlid_oe import OutputError

    preset = get_preset("paper-numerical").with_overrides(duration=2.0)
    record = preset.simulate(0, noise={"z": 0.02, "a": 0.02}, channels=("z", "a"))
    nlid.identify(record, preset.terms, OutputError(init="rfs", oversample=1, segment_seconds=1.0), mass=preset.mass)


def _errors(coefficients: dict[str, float], truth: dict[str, float]) -> dict[str, float]:
    return {n: 100 * (coefficients[n] / truth[n] - 1) for n in coefficients if truth.get(n)}


def one(case: str, seed: int, oversample: int | None = None) -> dict:
    """One timed run in this process (the record and the start outside the timing); ``oversample=None``: oe's
    default."""
    import nlid
    from nlid.simulation.presets import get_preset
    from nlid_oe import OutputError

    _warm_up()
    out: dict = {"case": case, "seed": seed}
    settings = {"init": "rfs"} if oversample is None else {"init": "rfs", "oversample": oversample}
    if case in ("numerical", "experimental"):
        preset = get_preset("paper-numerical" if case == "numerical" else "paper-experimental")
        record = preset.simulate(seed, noise={"z": 0.02, "a": 0.02}, channels=("z", "a"))
        extra = {} if case == "numerical" else {"px_roots": preset.model().px_roots}
        truth = preset.truth()["coefficients"]
        rfs = nlid.identify(record, preset.terms, "rfs", mass=preset.mass, **extra)
        out["load_start"] = os.getloadavg()[0]
        clock, cpu = time.perf_counter(), time.process_time()
        try:
            fit = nlid.identify(record, preset.terms, OutputError(**settings), mass=preset.mass, **extra)
        except nlid.errors.NlidError as exc:
            out.update(seconds=time.perf_counter() - clock, cpu=time.process_time() - cpu, error=str(exc))
        else:
            d = fit.diagnostics
            out.update(
                seconds=time.perf_counter() - clock,
                cpu=time.process_time() - cpu,
                errors=_errors(fit.coefficients, truth),
                rfs_errors=_errors(rfs.coefficients, truth),
                coefficients=dict(fit.coefficients),
                segments=d["segments"],
                stages=[(st["segments"], st.get("nfev")) for st in d["stages"]],
                nfev=d["nfev"],
                rms=(d["rms_error_start"]["z"], d["rms_error_fit"]["z"]),
                threads=d.get("threads"),
                oversample=d["oversample"],
            )
    elif case == "discover":
        from nlid.data.datasets import load
        from nlid.discovery import discover

        record, validation = load("bouc-wen"), load("bouc-wen", part="sinesweep")
        out["load_start"] = os.getloadavg()[0]
        clock, cpu = time.perf_counter(), time.process_time()
        result = discover(record, "z, v", "rfs", mass=2.0, validation=validation, refine=True, views=False)
        out.update(seconds=time.perf_counter() - clock, cpu=time.process_time() - cpu)
        refined = result.refined
        out["coefficients"] = dict(refined.identified.coefficients) if refined else None
        out["validation_rmse"] = refined.sim_rms_validation if refined else None
        out["threads"] = refined.identified.diagnostics.get("threads") if refined else None
    else:
        raise SystemExit(f"unknown case {case!r}")
    out["load_end"] = os.getloadavg()[0]
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--case", default="numerical", choices=("numerical", "experimental", "discover"))
    parser.add_argument("--seeds", default="0-4", help="seeds of the simulated records (a range or a list)")
    parser.add_argument("--repeat", type=int, default=1, help="runs per seed and tree")
    parser.add_argument("--trees", default=".", help="comma-separated source trees, run alternately")
    parser.add_argument(
        "--busy", type=int, default=0, help="keep N other processes busy (a load of N) while timing, e.g. 2"
    )
    parser.add_argument(
        "--oversample", type=int, default=None, help="oe's sub-steps per sample (default: oe's default, 8)"
    )
    parser.add_argument("--profile", action="store_true", help="cProfile one run of the first seed in this process")
    parser.add_argument("--one", type=int, default=None, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one is not None:
        print(json.dumps(one(args.case, args.one, args.oversample)))
        return
    if "-" in args.seeds:
        lo, hi = args.seeds.split("-")
        seeds = list(range(int(lo), int(hi) + 1))
    else:
        seeds = [int(s) for s in args.seeds.split(",")]
    if args.profile:
        import cProfile
        import pstats

        profiler = cProfile.Profile()
        profiler.enable()
        out = one(args.case, seeds[0], args.oversample)
        profiler.disable()
        print({k: out[k] for k in ("seconds", "cpu", "load_start", "oversample") if k in out})
        pstats.Stats(profiler).sort_stats("cumulative").print_stats(30)
        return
    if args.case == "discover":
        seeds = [0]
    trees = [str(Path(t).resolve()) for t in args.trees.split(",")]
    times: dict[str, list[float]] = {t: [] for t in trees}
    cpus: dict[str, list[float]] = {t: [] for t in trees}
    loads: dict[str, list[float]] = {t: [] for t in trees}
    print(
        f"{os.cpu_count()} cores; load average {os.getloadavg()[0]:.2f}; NLID_WORKERS={os.environ.get('NLID_WORKERS')}"
        f"; {args.busy} busy process(es)"
    )
    busy = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(args.busy)]
    try:
        _timed_runs(args, seeds, trees, times, cpus, loads)
    finally:
        for proc in busy:
            proc.kill()
            proc.wait()
    for tree in trees:
        if times[tree]:
            print(
                f"{tree}: median {statistics.median(times[tree]):.1f} s wall, "
                f"CPU {statistics.median(cpus[tree]):.1f} s, over {len(times[tree])} runs "
                f"(min {min(times[tree]):.1f}, max {max(times[tree]):.1f}); load at the starts "
                f"{min(loads[tree]):.1f}-{max(loads[tree]):.1f}"
            )


def _timed_runs(
    args: argparse.Namespace, seeds: list[int], trees: list[str], times: dict, cpus: dict, loads: dict
) -> None:
    """Every seed on every tree, ``args.repeat`` times, alternating the trees; prints each run."""
    for _ in range(args.repeat):
        for seed in seeds:
            for tree in trees:
                env = dict(os.environ, PYTHONPATH=f"{tree}:{tree}/plugins")
                proc = subprocess.run(
                    [sys.executable, __file__, "--case", args.case, "--one", str(seed)]
                    + ([] if args.oversample is None else ["--oversample", str(args.oversample)]),
                    env=env,
                    capture_output=True,
                    text=True,
                    check=False,
                )
                if proc.returncode:
                    print(f"{tree}: seed {seed} failed:\n{proc.stderr[-2000:]}")
                    continue
                r = json.loads(proc.stdout.strip().splitlines()[-1])
                times[tree].append(r["seconds"])
                cpus[tree].append(r["cpu"])
                loads[tree].append(r["load_start"])
                errs = r.get("errors") or {}
                print(
                    f"{Path(tree).name:>10s} seed {seed}: {r['seconds']:6.1f} s wall, {r['cpu']:6.1f} s CPU, load "
                    f"{r['load_start']:.1f}->{r['load_end']:.1f}, threads {r.get('threads')}"
                    + (f", oversample {r['oversample']}" if "oversample" in r else "")
                    + (f", segments {r['segments']} stages {r['stages']}" if "segments" in r else "")
                    + (f"  ERROR {r['error']}" if "error" in r else "")
                    + ("\n             errors %: " + " ".join(f"{n} {e:+.3f}" for n, e in errs.items()) if errs else "")
                    + (f"\n             coefficients: {r['coefficients']}" if args.case != "numerical" else "")
                    + (f"; validation RMSE {r['validation_rmse']:.4g} m" if r.get("validation_rmse") else ""),
                    flush=True,
                )


if __name__ == "__main__":
    main()
