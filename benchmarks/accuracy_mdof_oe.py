"""oe on structures against its rfs start, seed by seed, on the same noisy record (issue 24, item 5).

For each case and seed: one record of ``--duration`` s with ``--noise`` (fraction of each channel's std)
on every displacement (velocities and accelerations estimated), the mass matrix known; ``rfs`` on it, then
``oe`` started from ``rfs`` on the same record. Printed per seed: the |relative error| in % of every
element coefficient, the largest error of the underlying linear natural frequencies and damping ratios, the
wall time of each method (oe's includes its rfs start), and whether oe's element errors are at most rfs's.

Cases: ``3dof-cubic`` (``z3^3``) and ``2dof-double-well`` (the element's three coefficients).

    python benchmarks/accuracy_mdof_oe.py [--seeds 3] [--duration 10] [--noise 0.02] [--cases 3dof-cubic]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import nlid
from nlid.simulation.presets import get_preset

CASES = {
    "3dof-cubic": "z3^3",
    "2dof-double-well": "(z1-z2)^3, (z1-z2)^2, (v1-v2)*|v1-v2|",
}


def _linear_errors(fit, truth) -> tuple[float, float]:
    """Largest |relative error| in % of the underlying linear natural frequencies and damping ratios."""
    ref = truth["linear_modes"]
    fn = 100 * np.max(np.abs(np.asarray(fit.linear_modes.fn_hz) / np.asarray(ref["fn_hz"]) - 1))
    zeta = 100 * np.max(np.abs(np.asarray(fit.linear_modes.zeta) / np.asarray(ref["zeta"]) - 1))
    return float(fn), float(zeta)


def run_case(case: str, seed: int, duration: float, noise: float) -> list[dict]:
    """rfs and oe (from rfs) on one record: one row per method."""
    terms = CASES[case]
    record = get_preset(case).with_overrides(duration=duration).simulate(seed, noise={"z": noise}, channels=("z",))
    truth = record.meta["reference"]
    rows = []
    for method, options in (("rfs", {}), ("oe", {"init": "rfs"})):
        clock = time.perf_counter()
        fit = nlid.identify(record, terms, method, mass=record.mass, options=options)
        seconds = time.perf_counter() - clock
        errors = {k: 100 * abs(fit.coefficient(k) / v - 1) for k, v in truth["coefficients"].items()}
        fn, zeta = _linear_errors(fit, truth)
        rows.append({"case": case, "seed": seed, "method": method, "errors": errors, "fn": fn, "zeta": zeta,
                     "seconds": seconds, "diagnostics": fit.diagnostics})  # fmt: skip
    return rows


def table(rows: list[dict]) -> str:
    """Markdown: one line per case and seed, rfs | oe for each element, the linear modes and the times."""
    lines = []
    for case in dict.fromkeys(r["case"] for r in rows):
        sub = [r for r in rows if r["case"] == case]
        names = list(sub[0]["errors"])
        shown = [n.replace("|", "\\|") + " rfs / oe" for n in names]  # a | would split the cell
        head = ["seed", *shown, "fn max rfs / oe", "zeta max rfs / oe", "s rfs / oe"]
        lines += [f"### {case}: |relative error| in %", "", "| " + " | ".join(head) + " | oe <= rfs |"]
        lines.append("|---" * (len(head) + 1) + "|")
        for seed in dict.fromkeys(r["seed"] for r in sub):
            rfs, oe = (next(r for r in sub if r["seed"] == seed and r["method"] == m) for m in ("rfs", "oe"))
            cells = [f"{rfs['errors'][n]:.3g} / {oe['errors'][n]:.3g}" for n in names]
            cells += [f"{rfs[k]:.3g} / {oe[k]:.3g}" for k in ("fn", "zeta")]
            cells.append(f"{rfs['seconds']:.2g} / {oe['seconds']:.2g}")
            ok = all(oe["errors"][n] <= rfs["errors"][n] for n in names)
            lines.append(f"| {seed} | " + " | ".join(cells) + f" | {'yes' if ok else 'NO'} |")
        lines.append("")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--duration", type=float, default=10.0)
    parser.add_argument("--noise", type=float, default=0.02)
    parser.add_argument("--cases", default=",".join(CASES))
    args = parser.parse_args()
    rows = []
    for case in args.cases.split(","):
        for seed in range(args.seeds):
            rows += run_case(case, seed, args.duration, args.noise)
            oe = rows[-1]
            d = oe["diagnostics"]
            print(f"{case} seed {seed}: rfs {rows[-2]['errors']} oe {oe['errors']} ({oe['seconds']:.1f} s, "
                  f"{d.get('segments')} segments, nfev {d.get('nfev')})", flush=True)  # fmt: skip
    print(table(rows))


if __name__ == "__main__":
    main()
