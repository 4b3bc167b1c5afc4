"""The response's "Done when" checks against time integration (issue 33), as Markdown tables for docs/response.md.

For each model below, the continuation's stable points (8 per curve, evenly along it, the folds excepted) are
integrated in time from their own state until the first-harmonic amplitude and the offset settle; unstable
points (3 per curve, those an amplitude can tell from a stable point at the same frequency) are integrated from
1 % away, both ways. Slow sweeps up and down at ``RATE`` Hz/s locate the jumps in time, beside the folds the
continuation says a sweep in that direction jumps at. Backbones are integrated freely from sampled points.

* Duffing (hardening): 1 kg, 1e4 N/m, 2 % damping, 5e9 N/m^3; 1 N, 12-28 Hz, 7 harmonics.
* The paper's double well (``paper-numerical``'s truth): 0.8 N, 4-12 Hz, 15 harmonics (in-well in each well,
  the right well's softening resonance folds); and 8 N, 8-30 Hz, 15 harmonics (a curve per well, the right
  well's becoming cross-well, with period doublings: no sweep, a sweep there does not stay periodic).
* Coulomb-damped Duffing: 5e9 N/m^3, Coulomb 0.2 N, 1 % viscous damping; 1 N, 12-35 Hz, 21 harmonics.
* Bouc-Wen: ``bouc_wen(20, 200)`` 5e3 N/m beside 5e3 N/m, 1 N s/m; 3 N, 10-20 Hz, 7 harmonics.
* ``3dof-cubic``: 20 N on DOF 1, 18-34 Hz, 7 harmonics (every DOF checked).

    python benchmarks/response_checks.py [--rate 0.05] [--only NAME]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

import numpy as np  # noqa: E402

from nlid.identified.model import IdentifiedModel  # noqa: E402
from nlid.model import physics  # noqa: E402
from nlid.model.terms import Model  # noqa: E402
from nlid.response import frequency_response  # noqa: E402
from nlid.simulation.presets import get_preset  # noqa: E402


def oscillator(spec: str, coefficients: dict, mass: float = 1.0, model: Model | None = None) -> IdentifiedModel:
    model = model or Model.from_spec(spec)
    eq = None if model.uses_memory else physics.equilibria(model, model.vector(coefficients), (-0.05, 0.05))
    return IdentifiedModel(model=model, coefficients=coefficients, mass=mass, method="truth", equilibria=eq)


#: Cases whose sweeps are not compared (period doublings and chaos: a jump is not a fold there).
NO_SWEEP = ("double-well-8N",)


def cases() -> dict:
    p = get_preset("paper-numerical")
    well = oscillator("", p.truth()["coefficients"], p.mass, model=p.model())
    return {
        "duffing": (oscillator("z^3", {"z^3": 5e9, "z": 1e4, "v": 4.0, "1": 0.0}), 1.0, (12, 28), 7),
        "double-well-0.8N": (well, 0.8, (4, 12), 15),
        "double-well-8N": (well, 8.0, (8, 30), 15),
        "coulomb-duffing": (
            oscillator("z^3, sign(v)", {"z^3": 5e9, "sign(v)": 0.2, "z": 1e4, "v": 2.0, "1": 0.0}),
            1.0,
            (12, 35),
            21,
        ),
        "bouc-wen": (
            oscillator("bouc_wen(20, 200)", {"bouc_wen(20, 200)": 5e3, "z": 5e3, "v": 1.0, "1": 0.0}),
            3.0,
            (10, 20),
            7,
        ),
        "3dof-cubic": (get_preset("3dof-cubic").model(), 20.0, (18, 34), 7),
    }


def run(name: str, model, force: float, band, harmonics: int, rate: float) -> list[str]:
    t0 = time.perf_counter()
    resp = frequency_response(model, force, band, harmonics=harmonics)
    checked = resp.verify(points=8, unstable=3, sweep_rate=None if name in NO_SWEEP else rate)
    stable = [c for c in checked.checks if c.stable]
    tried = [c for c in checked.checks if not c.stable]
    motions = sorted({m.split(" ")[0] for c in resp.curves for m, s in zip(c.labels, c.stable, strict=True) if m and s})
    sweeps = (
        "not compared"
        if name in NO_SWEEP
        else "; ".join(
            f"{s.direction} {s.jump_hz:.4g} / {s.fold_hz:.4g} Hz ({s.difference_percent:+.2f} %)"
            for s in checked.sweeps
            if np.isfinite(s.jump_hz) or np.isfinite(s.fold_hz)
        )
    )
    bb = max((c.error_percent for c in checked.backbone_checks), default=float("nan"))
    finite = [c.truncation[np.isfinite(c.truncation)] for c in resp.curves if c.truncation is not None]
    trunc = max((float(t.max()) for t in finite if t.size), default=np.nan)
    return [
        name,
        f"{force:g} N, {band[0]:g}-{band[1]:g} Hz, H={harmonics}",
        f"{len(resp.curves)} / {sum(len(c) for c in resp.curves)}",
        ", ".join(motions) or "-",
        f"{len(stable)}: {checked.max_error_percent:.3g} %",
        f"{len(tried)}: {checked.unstable_reached} reached",
        sweeps or "no fold, no jump",
        "-" if not np.isfinite(bb) else f"{len(checked.backbone_checks)}: {bb:.2g} %",
        "-" if not np.isfinite(trunc) else f"{trunc:.1e}",
        f"{time.perf_counter() - t0:.0f} s",
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--rate", type=float, default=0.05, help="sweep rate (Hz/s)")
    parser.add_argument("--only", default="", help="comma-separated case names")
    args = parser.parse_args()
    print("load {:.1f} {:.1f} {:.1f}".format(*os.getloadavg()))
    header = [
        "model",
        "force, band, harmonics",
        "curves / points",
        "stable motion",
        "stable points: largest difference",
        "unstable points",
        f"sweeps at {args.rate:g} Hz/s: jump / fold",
        "backbone points: largest difference",
        "truncation",
        "time",
    ]
    print("| " + " | ".join(header) + " |")
    print("|" + "---|" * len(header))
    wanted = {x for x in args.only.split(",") if x}
    for name, (model, force, band, h) in cases().items():
        if wanted and name not in wanted:
            continue
        print("| " + " | ".join(run(name, model, force, band, h, args.rate)) + " |", flush=True)
    print("load {:.1f} {:.1f} {:.1f}".format(*os.getloadavg()))


if __name__ == "__main__":
    main()
