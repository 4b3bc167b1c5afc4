"""Speed of the nonlinear frequency response (issue 33, "Speed").

1. One DOF: the hardening Duffing oscillator (1 kg, 1e4 N/m, 2 % damping, 5e9 N/m^3) at 1 N from 10 to 30 Hz,
   7 harmonics, continuation step 0.02 (205 points, two folds), Hill's stability at every point, no backbone.
   Target: under 0.5 s.
2. Three DOFs: ``3dof-cubic`` at 20 N on DOF 1 from 15 to 35 Hz, 7 harmonics, step tuned to about 200 points.
   Target: under 5 s.
3. A 100-draw posterior band for one DOF: ``paper-experimental`` (2 % noise on z and a, seed 1) identified by
   the preferred method, its posterior of every coefficient, the response at 1.5 N from 6 to 16 Hz (a curve per
   well), 100 draws continued on 2 processes. Target: under 30 s on 2 cores.

Each figure is the median of ``--repeat`` runs (after one warm-up), wall time and the process's CPU time (the
computation is single-threaded: BLAS is held to one thread), with the machine's load average before and after:
the machine is shared, and a loaded core stretches the wall time, not the CPU time. The band's CPU time is
that of its two worker processes (``os.times`` of the children).

    python benchmarks/response_speed.py [--repeat 5] [--skip-band]
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))


import nlid  # noqa: E402
from nlid.identified.model import IdentifiedModel  # noqa: E402
from nlid.model.terms import Model  # noqa: E402
from nlid.response import Settings, frequency_response  # noqa: E402
from nlid.simulation.presets import get_preset  # noqa: E402


def _load() -> str:
    return "load {:.1f} {:.1f} {:.1f}".format(*os.getloadavg())


def timed(fn, repeat: int) -> tuple[float, float, list[float]]:
    """Median wall and CPU time (s) of ``fn()`` over ``repeat`` runs after a warm-up, and the wall times."""
    fn()
    wall, cpu = [], []
    for _ in range(repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        fn()
        wall.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    return statistics.median(wall), statistics.median(cpu), wall


def one_dof(repeat: int) -> None:
    fit = IdentifiedModel(
        model=Model.from_spec("z^3"), coefficients={"z^3": 5e9, "z": 1e4, "v": 4.0, "1": 0.0}, mass=1.0, method="-"
    )
    settings = Settings(harmonics=7, step=0.02)
    points = len(frequency_response(fit, 1.0, (10, 30), settings=settings, backbone=False).curves[0])
    print(f"[{_load()}]")
    med, cpu, runs = timed(lambda: frequency_response(fit, 1.0, (10, 30), settings=settings, backbone=False), repeat)
    print(
        f"one DOF, {points} points, 7 harmonics: median wall {med:.3f} s, CPU {cpu:.3f} s "
        f"(wall runs {', '.join(f'{x:.3f}' for x in runs)})"
    )
    print(f"[{_load()}]")


def three_dof(repeat: int) -> None:
    chain = get_preset("3dof-cubic").model()
    settings = Settings(harmonics=7, step=0.034)
    points = len(frequency_response(chain, 20.0, (15, 35), settings=settings, backbone=False).curves[0])
    print(f"[{_load()}]")
    med, cpu, runs = timed(lambda: frequency_response(chain, 20.0, (15, 35), settings=settings, backbone=False), repeat)
    print(
        f"three DOFs, {points} points, 7 harmonics: median wall {med:.3f} s, CPU {cpu:.3f} s "
        f"(wall runs {', '.join(f'{x:.3f}' for x in runs)})"
    )
    print(f"[{_load()}]")


def band(repeat: int) -> None:
    record = nlid.simulate("paper-experimental", seed=1, noise=0.02, channels="z,a")
    terms = "z^3,z^2,sign(v)*|px(z)|,v*|px(z)|,v*|v|*|px(z)|,v^3*|px(z)|"
    fit = nlid.identify(record, terms, mass=0.265)
    post = nlid.posterior(record, fit, params="all", seed=0)
    resp = fit.frequency_response(1.5, (6, 16), settings=Settings(step=0.1), backbone=False)
    print(f"[{_load()}]")
    times, cpus = [], []
    for k in range(repeat + 1):
        t0, c0 = time.perf_counter(), os.times()
        out = resp.with_posterior(post, draws=100, jobs=2, seed=k)
        c1 = os.times()
        if k:
            times.append(time.perf_counter() - t0)
            cpus.append((c1.children_user + c1.children_system) - (c0.children_user + c0.children_system))
    failed = out.uncertainty.failed
    print(
        f"100-draw band, one DOF, 2 curves, 2 processes: median wall {statistics.median(times):.1f} s, "
        f"CPU of the workers {statistics.median(cpus):.1f} s (wall runs {', '.join(f'{x:.1f}' for x in times)}; "
        f"{failed} draw(s) failed in the last)"
    )
    print(f"[{_load()}]")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--skip-band", action="store_true")
    args = parser.parse_args()
    one_dof(args.repeat)
    three_dof(args.repeat)
    if not args.skip_band:
        band(args.repeat)


if __name__ == "__main__":
    main()
