"""nsi-ip on the paper-experimental preset (paper Sec. 4, Eq. 24): issue 8's accuracy targets.

2 % noise on z and a, terms ``z^3, z^2, sign(v)*|px(z)|, v*|px(z)|, v*|v|*|px(z)|,
v^3*|px(z)|`` (+ 1, z, v), px(z) roots iterated by nlid.identify. Prints the
relative errors (%) of every coefficient, the mass (when estimated), the
natural frequencies and the equilibria per seed, then the largest and the
median absolute error over the seeds and whether issue 8's targets hold
(z^3, z^2, z, fn, equilibria within 1 %, c0 within 10 %).

    python benchmarks/accuracy_nsi_experimental.py                      # seeds 0-7, mass estimated
    python benchmarks/accuracy_nsi_experimental.py --mass known --study  # + the built-in study's 3 records
    python benchmarks/accuracy_nsi_experimental.py --seeds 0 3 --set acceleration=ignore
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from nlid import identify
from nlid.model import physics
from nlid.simulation.presets import get_preset

TERMS = "z^3, z^2, sign(v)*|px(z)|, v*|px(z)|, v*|v|*|px(z)|, v^3*|px(z)|"
#: Record seeds of the built-in study ``studies/paper-experimental.toml`` (seed 2026, 3 repetitions).
STUDY_SEEDS = (2647203444, 2424290875, 3764063815)
#: Issue 8's targets (%): the largest absolute error allowed.
TARGETS = {"z^3": 1.0, "z^2": 1.0, "z": 1.0, "fn-": 1.0, "fn+": 1.0, "eq-": 1.0, "eq+": 1.0, "sign(v)*|px(z)|": 10.0}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=list(range(8)))
    ap.add_argument("--study", action="store_true", help="also the built-in study's three records")
    ap.add_argument("--mass", choices=("estimated", "known"), default="estimated")
    ap.add_argument("--noise", type=float, default=0.02, help="noise on z and a (fraction of each std)")
    ap.add_argument("--method", default="nsi-ip")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = ap.parse_args()
    options = dict(s.split("=", 1) for s in args.set)
    preset = get_preset("paper-experimental")
    model = preset.model()
    truth = preset.truth()["coefficients"]
    eq = physics.equilibria(model, truth)
    modal = physics.modal(model, truth, preset.mass, eq.stable)
    known = args.mass == "known"
    names = list(model.names)
    cols = names + ([] if known else ["m"]) + ["fn-", "fn+", "eq-", "eq+"]
    seeds = list(args.seeds) + (list(STUDY_SEEDS) if args.study else [])
    print(
        f"### {args.method} on paper-experimental, {100 * args.noise:g} % noise on z and a, mass {args.mass} "
        f"{options or ''}"
    )
    print("| seed | " + " | ".join(c.replace("|", "\\|") for c in cols) + " | px iterations | s |")
    print("|---" * (len(cols) + 3) + "|")
    rows = []
    for seed in seeds:
        rec = preset.simulate(seed, noise={"z": args.noise, "a": args.noise}, channels=("z", "a"))
        t0 = time.perf_counter()
        res = identify(rec, TERMS, args.method, options=options, mass=preset.mass if known else None)
        el = time.perf_counter() - t0
        e = {k: 100 * (res.coefficients[k] / truth[k] - 1) for k in names}
        if not known:
            e["m"] = 100 * (res.mass / preset.mass - 1)
        found = {("-" if m.equilibrium < 0 else "+"): m for m in res.modal}
        st = res.equilibria.stable
        for side, t in zip("-+", modal, strict=True):
            e[f"fn{side}"] = 100 * (found[side].fn_hz / t.fn_hz - 1) if side in found else np.nan
            zs = [z for z in st if (z < 0) == (side == "-")]
            e[f"eq{side}"] = 100 * (zs[0] / t.equilibrium - 1) if zs else np.nan
        rows.append(e)
        it = res.diagnostics.get("px_iteration", {}).get("iterations")
        print(f"| {seed} | " + " | ".join(f"{e[c]:+.2f}" for c in cols) + f" | {it} | {el:.1f} |", flush=True)
    worst = {c: float(np.nanmax([abs(r[c]) for r in rows])) for c in cols}
    median = {c: float(np.nanmedian([abs(r[c]) for r in rows])) for c in cols}
    print("| max abs | " + " | ".join(f"{worst[c]:.2f}" for c in cols) + " | | |")
    print("| median abs | " + " | ".join(f"{median[c]:.2f}" for c in cols) + " | | |")
    failed = [f"{c} {worst[c]:.2f} % > {t:g} %" for c, t in TARGETS.items() if not worst[c] <= t]
    print()
    print("targets met on every record" if not failed else "targets missed: " + "; ".join(failed))


if __name__ == "__main__":
    main()
