"""Simulator speed: one paper-numerical record (122 880 samples, RK4, numba).

Target (issue 14): <= 15 ms per record after warm-up, on the 2-core machine
(issue 2: <= 50 ms). The CPU time is printed too: on a shared machine it is
the steadier figure.

    python benchmarks/bench_simulate.py
    python benchmarks/bench_simulate.py --profile   # where the kernel's time goes

A profiler cannot see inside the compiled kernel; ``--profile`` times it
directly (without ``simulate``'s Python around it) for models of 1 to 8 terms
against a hand-written RK4 of ``m z'' + k z = f`` (the floor: the same
arithmetic and memory traffic without the generic term evaluation). Put
another version's tree first on ``PYTHONPATH`` to profile it.
"""

from __future__ import annotations

import os
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

from _common import median_time  # noqa: E402

from nlid.simulation import simulate  # noqa: E402
from nlid.simulation.presets import get_preset  # noqa: E402


def profile(repeat: int = 21) -> None:
    """CPU time of the compiled kernel alone for several models, and of the hand-written linear floor."""
    import numba
    import numpy as np

    import nlid.simulation as sim
    from nlid.model.terms import Model
    from nlid.simulation import kernels

    @numba.njit(cache=False)
    def linear_rk4(force, dt, mass, k, out_z, out_v, out_a):  # pragma: no cover - compiled
        z = v = 0.0
        inv_m, h2 = 1.0 / mass, 0.5 * dt
        for i in range(force.size):
            fk = force[i]
            a1 = (fk - k * z) * inv_m
            out_z[i], out_v[i], out_a[i] = z, v, a1
            z2, v2 = z + h2 * v, v + h2 * a1
            a2 = (fk - k * z2) * inv_m
            z3, v3 = z + h2 * v2, v + h2 * a2
            a3 = (fk - k * z3) * inv_m
            z4, v4 = z + dt * v3, v + dt * a3
            a4 = (fk - k * z4) * inv_m
            z = z + dt / 6.0 * (v + 2.0 * v2 + 2.0 * v3 + v4)
            v = v + dt / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
        return -1

    force = get_preset("paper-numerical").force(0)
    n, dt = force.size, 1 / 2048
    out = [np.empty(n) for _ in range(3)]

    def cpu_ms(fn) -> float:
        fn()
        times = []
        for _ in range(repeat):
            c0 = time.process_time()
            fn()
            times.append(time.process_time() - c0)
        return 1e3 * statistics.median(times)

    print(f"nlid.simulation from {Path(sim.__file__).parent}; {n} samples; load {os.getloadavg()[0]:.2f}")
    print(
        f"  {'hand-written linear RK4 (floor)':58s} {cpu_ms(lambda: linear_rk4(force, dt, 0.2, 2000.0, *out)):6.2f} ms"
    )
    experimental = get_preset("paper-experimental")
    cases = [
        ("z", {"z": 2000.0}, None),
        ("z, v", {"z": 2000.0, "v": 1.0}, None),
        ("1, z, v, z^2, z^3, v*|v| (paper-numerical)", None, "paper-numerical"),
        ("paper-experimental (8 terms, px(z))", None, "paper-experimental"),
        ("z, v, v*exp(-|v|/0.1) (a special factor)", {"z": 2000.0, "v": 1.0, "v*exp(-|v|/0.1)": 0.5}, None),
    ]
    for label, coefs, preset_name in cases:
        if preset_name is None:
            model = Model.from_spec(label.split(" (")[0], defaults=False)
        else:
            preset = get_preset(preset_name)
            model, coefs = preset.model(), preset.truth()["coefficients"]
        theta = model.vector(coefs)
        parts, special, pxc = sim.encode_model(model)
        mass = experimental.mass if preset_name == "paper-experimental" else 0.2
        ms = cpu_ms(lambda args=(mass, theta, parts, special, pxc): kernels._rk4(force, dt, *args, 0.0, 0.0, *out))
        print(f"  kernel, {label:50s} {ms:6.2f} ms")
    model = get_preset("paper-numerical").model()
    coefs = get_preset("paper-numerical").truth()["coefficients"]
    ms = cpu_ms(lambda: sim.simulate(model, coefs, 0.2, force, 2048.0))
    print(f"  {'simulate(), paper-numerical (kernel + Python)':58s} {ms:6.2f} ms")


def main() -> None:
    if "--profile" in sys.argv:
        profile()
        return
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
