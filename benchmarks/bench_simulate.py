"""Simulator speed: one paper-numerical record (122 880 samples, RK4, numba).

Target (issue 2): <= 50 ms per record after warm-up, on the 2-core machine.

    python benchmarks/bench_simulate.py
"""

from __future__ import annotations

import sys
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

        med, times = median_time(integrate, repeat=9)
        print(
            f"{name:20s} {force.size:7d} samples  integrator median {1e3 * med:6.1f} ms "
            f"(min {1e3 * min(times):.1f}, max {1e3 * max(times):.1f}, 9 runs)"
        )
        med, _ = median_time(lambda preset=preset: preset.simulate(0, noise=0.02), repeat=5)
        print(f"{'':20s} {'':7s}          full preset.simulate (force, noise, Record) {1e3 * med:6.1f} ms")


if __name__ == "__main__":
    main()
