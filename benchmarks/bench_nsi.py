"""nsi-ip speed and memory, and a side-by-side with the N4SID package ``nfoursid``.

Targets on the 2-core machine (issue 14, "Performance"; issue 3 before it):

* nsi-ip on one paper-numerical record (122 880 samples, 2 % noise on z, 4
  extended inputs f + k~1 z, z^3, z^2, v*|v|, default block rows, including
  the k~1 search and the 5-value ensemble): <= 0.3 s wall (issue 3: <= 2 s);
* 10^6 samples: <= 3 s and <= 400 MB peak RSS for the whole ``nlid identify``
  process (measured here on a file written by ``nlid simulate``, the child
  process's wall time and ``ru_maxrss``);
* nfoursid (optional: ``pip install ".[bench]"``) on the same extended-input
  problem at 16 384 samples: time ratio and the coefficient errors of both.

Each API memory figure is measured in a fresh subprocess with tracemalloc
(every NumPy allocation of the call) and the process's peak RSS; the load
average and the CPU time are printed with the wall times (the machine is
shared: compare before/after in the same session).

    python benchmarks/bench_nsi.py               # everything
    python benchmarks/bench_nsi.py --quick       # skip the 10^6-sample runs and nfoursid
    python benchmarks/bench_nsi.py --profile 122880 [--by tottime]   # cProfile (CPU time) of one call, top entries
    python benchmarks/bench_nsi.py --cli-phases 1000000   # nlid identify's steps timed in one process
    python benchmarks/bench_nsi.py --cli 1000000 [--repeat 5]   # only the whole-process nlid identify
    python benchmarks/bench_nsi.py --cli 1000000 --against /tmp/base   # the same, alternating with another tree
    python benchmarks/bench_nsi.py --cli 122880 --rfs   # the same with --method rfs --mass 0.2 (for comparison)

``--profile`` measures whatever ``nlid`` and ``nlid_nsi`` are importable: to
profile another version put its tree first on ``PYTHONPATH`` (docs/performance.md).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))

from _common import median_time  # noqa: E402

from nlid.model.terms import Model  # noqa: E402
from nlid.simulation.presets import get_preset  # noqa: E402
from nlid_nsi import NSIInputPerturbation  # noqa: E402

TERMS = "z^3, z^2, v*|v|"
TRUTH = {"z^3": 1e6, "z^2": 5e3, "z": -500.0, "v*|v|": 5.0, "v": 1.0}


def record(n: int, seed: int = 0):
    preset = get_preset("paper-numerical")
    return preset.with_overrides(duration=n / preset.fs).simulate(seed, noise={"z": 0.02}, channels=("z",))


def errors(coefs: dict[str, float]) -> dict[str, float]:
    return {k: 100 * (coefs[k] / TRUTH[k] - 1) for k in TRUTH}


def fmt(err: dict[str, float]) -> str:
    return ", ".join(f"{k} {x:+.3f} %" for k, x in err.items())


_MEMORY = r"""
import json, resource, sys, time, tracemalloc
sys.path.insert(0, {bench!r})
from bench_nsi import record, errors, TERMS
from nlid.model.terms import Model
from nlid_nsi import NSIInputPerturbation
rec = record({n})
model = Model.from_spec(TERMS)
ident = NSIInputPerturbation()
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
tracemalloc.start()
t0 = time.perf_counter()
res = ident.identify(rec, model)
wall = time.perf_counter() - t0
peak = tracemalloc.get_traced_memory()[1] / 1e6
tracemalloc.stop()
rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
print(json.dumps(dict(wall=wall, peak=peak, rss=rss, before=before, k=res.diagnostics["k_tilde"],
                      err=errors(res.coefficients))))
"""


def memory(n: int) -> None:
    code = _MEMORY.format(bench=str(Path(__file__).parent), n=n)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    d = json.loads(out.strip().splitlines()[-1])
    print(
        f"  N = {n:>9,}: wall {d['wall']:.2f} s (tracemalloc on), tracemalloc peak {d['peak']:.0f} MB, "
        f"process peak RSS {d['rss']:.0f} MB (before the call {d['before']:.0f} MB); k~1 = {d['k']:g}; "
        f"errors {fmt(d['err'])}"
    )


#: Runs a command and prints its wall time, peak RSS (MB) and CPU time (user + system): a wrapper process
#: with that one child, so ``RUSAGE_CHILDREN`` is the child's own.
_WRAPPER = r"""
import resource, subprocess, sys, time
t0 = time.perf_counter()
subprocess.run(sys.argv[1:], check=True, capture_output=True)
usage = resource.getrusage(resource.RUSAGE_CHILDREN)
print(time.perf_counter() - t0, usage.ru_maxrss / 1024, usage.ru_utime + usage.ru_stime)
"""


def _record_file(folder: Path, n: int) -> Path:
    """An ``n``-sample paper-numerical record (seed 0, 2 % noise on z) written by ``nlid simulate`` into ``folder``."""
    path = folder / "record.npz"
    args = ["simulate", "--preset", "paper-numerical", "--seed", "0", "--noise", "0.02"]
    args += ["--duration", repr(n / get_preset("paper-numerical").fs), "--out", str(path)]
    subprocess.run([sys.executable, "-m", "nlid.cli.main", *args], check=True, capture_output=True)
    return path


def cli(
    n: int, repeat: int = 5, method: str = "nsi-ip", extra: tuple[str, ...] = (), against: str | None = None
) -> None:
    """``nlid identify`` on a file of ``n`` samples (paper-numerical, seed 0, 2 % noise on z), in a child process.

    Reports the median wall time of ``repeat`` runs, the median CPU time
    (user + system: the steadier figure on a shared machine) and the largest
    peak RSS (``ru_maxrss`` of the child: imports, reading the file, the
    identifier and the core's post-processing, i.e. what the user waits for
    and pays for).

    ``against``: a second source tree (e.g. ``main`` exported with ``git
    archive``), whose ``nlid`` and ``plugins`` are put first on ``PYTHONPATH``
    for its runs; the two trees' runs alternate (one of each per round, the
    same file), which is the only fair comparison on a shared machine.
    """
    import statistics
    import tempfile

    trees: dict[str, dict[str, str] | None] = {"this tree": None}
    if against is not None:
        root = str(Path(against).resolve())
        trees[f"against {root}"] = dict(os.environ, PYTHONPATH=os.pathsep.join((root, os.path.join(root, "plugins"))))
    runs: dict[str, list[tuple[float, float, float, float]]] = {label: [] for label in trees}
    with tempfile.TemporaryDirectory() as tmp:
        path = _record_file(Path(tmp), n)
        cmd = [sys.executable, "-m", "nlid.cli.main", "identify", str(path), "--method", method, "--terms", TERMS]
        cmd += list(extra)
        for _ in range(repeat):
            for label, env in trees.items():
                out = subprocess.run(
                    [sys.executable, "-c", _WRAPPER, *cmd], check=True, capture_output=True, text=True, env=env
                )
                wall, peak, cpu = (float(x) for x in out.stdout.split())
                runs[label].append((wall, cpu, peak, os.getloadavg()[0]))
    for label, rows in runs.items():
        walls, cpus, peaks, loads = (list(col) for col in zip(*rows, strict=True))
        print(
            f"  nlid identify --method {' '.join((method, *extra))}, N = {n:,} ({label}): "
            f"wall median {statistics.median(walls):.2f} s over {repeat} runs "
            f"(min {min(walls):.2f}), CPU median {statistics.median(cpus):.2f} s, peak RSS {max(peaks):.0f} MB "
            f"(whole process, largest of the runs); load {min(loads):.2f}-{max(loads):.2f}"
        )


_PHASES = r"""
import resource, sys, time
t0, c0 = time.perf_counter(), time.process_time()
import nlid.cli.main  # noqa: F401 - what the CLI imports
from nlid.identification import pipeline
from nlid.identified.model import IdentifiedModel
from nlid.data.io import read_record
from nlid.contract.registry import registry_for
registry_for("nsi-ip")
t1, c1 = time.perf_counter(), time.process_time()
rec = read_record(sys.argv[1])
t2, c2 = time.perf_counter(), time.process_time()
core = {}
complete = IdentifiedModel.from_estimate.__func__
def timed(cls, *args, **kwargs):
    s, sc = time.perf_counter(), time.process_time()
    out = complete(cls, *args, **kwargs)
    core["t"] = (time.perf_counter() - s, time.process_time() - sc)
    return out
IdentifiedModel.from_estimate = classmethod(timed)
pipeline.identify(rec, sys.argv[2], "nsi-ip")
t3, c3 = time.perf_counter(), time.process_time()
w, c = core["t"]
rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
print(f"    imports + plugin {t1 - t0:.2f} s wall / {c1 - c0:.2f} s CPU; reading {t2 - t1:.2f} / {c2 - c1:.2f}; "
      f"identify (plugin) {t3 - t2 - w:.2f} / {c3 - c2 - c:.2f}; core post-processing {w:.2f} / {c:.2f}; "
      f"total {t3 - t0:.2f} / {c3 - c0:.2f}; peak RSS {rss:.0f} MB")
"""


def cli_phases(n: int) -> None:
    """Where the time of ``nlid identify`` goes: the CLI's steps run in one fresh process, each timed (wall, CPU)."""
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        path = _record_file(Path(tmp), n)
        out = subprocess.run(
            [sys.executable, "-c", _PHASES, str(path), TERMS], check=True, capture_output=True, text=True
        )
    print(f"  nlid identify's steps, N = {n:,} (load {os.getloadavg()[0]:.2f}):")
    print(out.stdout.rstrip())


def nfoursid_side_by_side(n: int = 16_384, block_rows: int = 100, k_tilde: float = 600.0) -> None:
    """The same extended-input problem solved by nfoursid and by nlid_nsi's subspace step."""
    try:
        import pandas as pd
        from nfoursid.nfoursid import NFourSID
    except ImportError:
        print("  nfoursid is not installed (pip install '.[bench]'): side-by-side skipped")
        return
    from nlid_nsi.basis import split_model
    from nlid_nsi.channels import perturbation_map, prepare_channels
    from nlid_nsi.common import velocity_estimate
    from nlid_nsi.continuous import coefficient_spectra, d2c_zoh, extended_frf, fit_uls
    from nlid_nsi.fit import fit_extended
    from nlid_nsi.gram import block_hankel_gram

    rec = record(n)
    model = Model.from_spec(TERMS)
    basis = split_model(model).basis
    vel = velocity_estimate(rec, None, None)
    # the raw extended-input problem (pass 1 of nsi-ip: trapezoid interval means, no reconstruction)
    ch = prepare_channels(rec.z, vel.v, rec.f, rec.dt, basis, 0.0, None, True, False)
    t = perturbation_map(ch, k_tilde)
    w = ch.base @ t.T
    names = [b.name for b in basis]

    def ours():
        return fit_extended(ch, t, block_hankel_gram(ch.base, 2 * block_rows), rec.dt, "halfpower", 2, 10, 0.5)

    t_ours, _ = median_time(ours, repeat=3, warmup=1)
    fit = ours()
    c_ours = dict(fit.coefficients, z=fit.uls.k - k_tilde, v=fit.uls.c)

    frame = pd.DataFrame(w, columns=["u0", *names, "y"])

    def theirs():
        sid = NFourSID(frame, output_columns=["y"], input_columns=["u0", *names], num_block_rows=block_rows)
        sid.subspace_identification()
        return sid.system_identification(rank=2)[0]

    t0 = time.perf_counter()
    ss = theirs()
    t_theirs = time.perf_counter() - t0
    # undo the channel scaling exactly as nlid_nsi does, then the same continuous-time steps (Eq. 18-20)
    su = np.concatenate([[ch.scales[0]], ch.scales[2:-1]])
    b = np.asarray(ss.b) / su[None, :]
    cm = np.asarray(ss.c) * ch.scales[-1]
    d = np.asarray(ss.d) * ch.scales[-1] / su[None, :]
    ac, bc, lc = d2c_zoh(np.asarray(ss.a), b, rec.dt)
    lo, hi = fit.band
    wb = np.linspace(lo, hi, 256)
    he = extended_frf(ac, bc, cm, wb) + d
    uls = fit_uls(wb, he[:, 0], lc)
    spectra = coefficient_spectra(he, np.ones(wb.size, dtype=bool), names)
    c_theirs = {s.name: s.estimate for s in spectra}
    c_theirs.update(z=uls.k - k_tilde, v=uls.c)
    print(f"  {n} samples, {block_rows} block rows, k~1 = {k_tilde:g} N/m, order 2, raw extended inputs:")
    print(f"    nlid_nsi subspace step (Gram, PO-MOESP, output-error B): {t_ours:.3f} s; errors {fmt(errors(c_ours))}")
    print(f"    nfoursid (N4SID, Hankel matrices): {t_theirs:.3f} s; errors {fmt(errors(c_theirs))}")
    print(f"    time ratio nfoursid / nlid_nsi: {t_theirs / t_ours:.0f}")
    full = NSIInputPerturbation().identify(rec, model)
    print(f"    nsi-ip, full method, same record: errors {fmt(errors(full.coefficients))}")


def profile(n: int, top: int = 25, by: str = "cumulative") -> None:
    """cProfile of one nsi-ip call (after a warm-up call), in CPU seconds; top entries by ``by`` (a pstats key)."""
    import cProfile
    import io
    import pstats

    import nlid_nsi

    rec = record(n)
    model = Model.from_spec(TERMS)
    ident = NSIInputPerturbation()
    ident.identify(rec, model)
    prof = cProfile.Profile(time.process_time)
    prof.enable()
    res = ident.identify(rec, model)
    prof.disable()
    out = io.StringIO()
    stats = pstats.Stats(prof, stream=out)
    stats.sort_stats(by).print_stats(top)
    print(f"nlid_nsi from {Path(nlid_nsi.__file__).parent}; N = {n:,}; load {os.getloadavg()[0]:.2f}")
    print(f"timings_s (wall, inside the call): {res.diagnostics['timings_s']}")
    print(out.getvalue())


def main() -> None:
    if "--profile" in sys.argv:
        by = sys.argv[sys.argv.index("--by") + 1] if "--by" in sys.argv else "cumulative"
        profile(int(sys.argv[sys.argv.index("--profile") + 1]), by=by)
        return
    if "--cli" in sys.argv:
        repeat = int(sys.argv[sys.argv.index("--repeat") + 1]) if "--repeat" in sys.argv else 5
        # --rfs: the same command with the README's other method (rfs, --mass 0.2), whose child needs no scipy.signal
        method, extra = ("rfs", ("--mass", "0.2")) if "--rfs" in sys.argv else ("nsi-ip", ())
        against = sys.argv[sys.argv.index("--against") + 1] if "--against" in sys.argv else None
        cli(int(sys.argv[sys.argv.index("--cli") + 1]), repeat=repeat, method=method, extra=extra, against=against)
        return
    if "--cli-phases" in sys.argv:
        cli_phases(int(sys.argv[sys.argv.index("--cli-phases") + 1]))
        return
    quick = "--quick" in sys.argv
    rec = record(122_880)
    model = Model.from_spec(TERMS)
    print(f"load average before: {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    for label, opts in (
        ("nsi-ip incl. k~1 search (defaults)", {}),
        ("nsi-ip, k~1 = 600 given", {"k_tilde": 600}),
        ("nsi-ip incl. search, BLAS threads not limited", {"blas_threads": None}),
    ):
        ident = NSIInputPerturbation(**opts)
        cpu: list[float] = []

        def call(ident=ident, cpu=cpu):
            fresh = rec.replace()  # a new record each call: nothing cached per record (e.g. its cut-off) carries over
            c0 = time.process_time()
            ident.identify(fresh, model)
            cpu.append(time.process_time() - c0)

        med, times = median_time(call, repeat=7)
        print(
            f"{label}: median {med:.3f} s over 7 runs (min {min(times):.3f}, max {max(times):.3f}; "
            f"CPU median {sorted(cpu[1:])[3]:.3f} s; load {os.getloadavg()[0]:.2f})"
        )
    from nlid_nsi import NSIZeroShift

    ident = NSIZeroShift()
    med, times = median_time(lambda: ident.identify(rec.replace(), model), repeat=3)
    print(f"nsi-shift (2 wells, fixed-point references): median {med:.3f} s over 3 runs (min {min(times):.3f})")
    print("peak memory, nsi-ip incl. search (fresh subprocess each):")
    memory(122_880)
    if not quick:
        memory(1_000_000)
        print("whole nlid identify process (fresh child process each):")
        cli(122_880)
        cli(1_000_000)
        cli_phases(1_000_000)
        print("side by side with nfoursid (both with one BLAS thread):")
        from nlid_nsi.common import blas_threads

        with blas_threads(1):
            nfoursid_side_by_side()


if __name__ == "__main__":
    main()
