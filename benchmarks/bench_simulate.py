"""Simulator speed: one paper-numerical record (122 880 samples, RK4, numba).

Target (issue 14): <= 15 ms per record after warm-up, on the 2-core machine
(issue 2: <= 50 ms). The CPU time is printed too: on a shared machine it is
the steadier figure.

    python benchmarks/bench_simulate.py
"""

from __future__ import annotations

import os
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

from _common import median_time  # noqa: E402

from nlid.presets import get_preset  # noqa: E402
from nlid.simulation import simulate  # noqa: E402


def main() -> None:
    for name in ("paper-numerical", "paper-experimental"):
        preset = get_preset(name)
        model, coeffs = preset.model(), preset.truth()["coefficients"]
        force = preset.force(0)

        def integrate(model=model, coeffs=coeffs, preset=preset, force=force):
            return simulate(model, coeffs, preset.mass, force, preset.fs)

        cpu: list[float] = []

        def timed(integrate=integrate, cpu=cpu):
            c0 = time.process_time()
            integrate()
            cpu.append(time.process_time() - c0)

        med, times = median_time(timed, repeat=21)
        print(
            f"{name:20s} {force.size:7d} samples  integrator median {1e3 * med:6.1f} ms "
            f"(min {1e3 * min(times):.1f}, max {1e3 * max(times):.1f}, 21 runs; "
            f"CPU median {1e3 * statistics.median(cpu[1:]):.1f} ms; load {os.getloadavg()[0]:.2f})"
        )
        med, _ = median_time(lambda preset=preset: preset.simulate(0, noise=0.02), repeat=5)
        print(f"{'':20s} {'':7s}          full preset.simulate (force, noise, Record) {1e3 * med:6.1f} ms")


if __name__ == "__main__":
    main()
