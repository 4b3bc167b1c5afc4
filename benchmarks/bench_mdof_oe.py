"""Wall time of ``oe`` on a 3-DOF chain (issue 31, item 4: a 30-s record in well under a minute on 2 cores).

The record has the shape of the reviewer's hidden case: the ``3dof-cubic`` chain (three 1 kg masses,
springs of 1e5 N/m, dampers of 20 N s/m, 1 kHz) with a cubic spring ``(z2-z3)^3`` (5e9 N/m^3) and a
Coulomb friction of 2 N on connection 1-2 (``sign(v1-v2)``), the force on mass 1; ``--noise`` (fraction of
each displacement's std) on the displacements, the velocities and accelerations estimated, the mass
matrix given. ``oe`` fits both elements from its ``rfs`` start. Printed: each run's wall time (the whole
``nlid.identify`` call, rfs start included), the median of ``--repeat`` runs, the Jacobian used, oe's
iterations and segments, and the coefficients' errors; the CPU time of every thread of the process beside the
wall time (on a loaded machine the wall time measures the load). State the machine's load (``uptime``)
beside the figures: the runs use the 2 cores.

    python benchmarks/bench_mdof_oe.py [--duration 30] [--repeat 3] [--seed 1] [--noise 0.01]
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import nlid
from nlid.simulation.presets import get_preset

ELEMENTS = "(z2-z3)^3, sign(v1-v2)"
TRUTH = {"(z2-z3)^3": 5e9, "sign(v1-v2)": 2.0}


def chain(duration: float):
    """The hidden case's chain (module docstring)."""
    return get_preset("3dof-cubic").with_overrides(duration=duration, elements=ELEMENTS, coefficients=TRUTH)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=30.0)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--noise", type=float, default=0.01)
    args = parser.parse_args()
    record = chain(args.duration).simulate(args.seed, noise={"z": args.noise}, channels=("z",))
    print(f"load before: {os.getloadavg()}")
    times = []
    for k in range(args.repeat):
        clock, cpu = time.perf_counter(), time.process_time()
        fit = nlid.identify(record, ELEMENTS, "oe", mass=record.mass)
        times.append(time.perf_counter() - clock)
        cpu = time.process_time() - cpu  # every thread of this process: the wall time an idle machine approaches
        d = fit.diagnostics
        errors = ", ".join(
            f"{name} {100 * (fit.structure.coefficient(name) / v - 1):+.3g} %" for name, v in TRUTH.items()
        )
        print(
            f"run {k + 1}: {times[-1]:.1f} s, CPU {cpu:.1f} s (fit {d.get('seconds_fit', float('nan')):.1f} s; "
            "jacobian "
            f"{d.get('jacobian', 'finite differences')}; {d.get('segments')} segments; nfev {d.get('nfev')}, "
            f"njev {d.get('njev')}); {errors}",
            flush=True,
        )
    print(f"median of {len(times)}: {statistics.median(times):.1f} s; load after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
