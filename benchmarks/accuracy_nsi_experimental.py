"""nsi-ip on the paper-experimental preset (paper Sec. 4, Eq. 24): what issue 8 will need.

2 % noise on z and a, terms ``z^3, z^2, sign(v)*|px(z)|, v*|px(z)|, v*|v|*|px(z)|,
v^3*|px(z)|`` (+ 1, z, v), px(z) roots iterated by nlid.identify. Prints the
relative errors (%) of every coefficient, the natural frequencies and the
equilibria per seed.

    python benchmarks/accuracy_nsi_experimental.py [--seeds 0 1 2] [--set key=value ...]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from nlid import identify, physics
from nlid.presets import get_preset

TERMS = "z^3, z^2, sign(v)*|px(z)|, v*|px(z)|, v*|v|*|px(z)|, v^3*|px(z)|"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument("--method", default="nsi-ip")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = ap.parse_args()
    options = dict(s.split("=", 1) for s in args.set)
    preset = get_preset("paper-experimental")
    model = preset.model()
    truth = preset.truth()["coefficients"]
    eq = physics.equilibria(model, truth)
    modal = physics.modal(model, truth, preset.mass, eq.stable)
    names = list(model.names)
    cols = names + ["m", "fn-", "fn+", "eq-", "eq+"]
    print(f"### {args.method} on paper-experimental, 2 % noise on z and a {options or ''}")
    print("| seed | " + " | ".join(cols) + " | px iterations | s |")
    print("|---" * (len(cols) + 3) + "|")
    for seed in args.seeds:
        rec = preset.simulate(seed, noise={"z": 0.02, "a": 0.02}, channels=("z", "a"))
        t0 = time.perf_counter()
        res = identify(rec, TERMS, args.method, options=options)
        el = time.perf_counter() - t0
        e = {k: 100 * (res.coefficients[k] / truth[k] - 1) for k in names}
        e["m"] = 100 * (res.mass / preset.mass - 1)
        found = {("-" if m["equilibrium"] < 0 else "+"): m for m in res.modal}
        st = res.equilibria["stable"]
        for side, t in zip("-+", modal, strict=True):
            e[f"fn{side}"] = 100 * (found[side]["fn_hz"] / t.fn_hz - 1) if side in found else np.nan
            zs = [z for z in st if (z < 0) == (side == "-")]
            e[f"eq{side}"] = 100 * (zs[0] / t.equilibrium - 1) if zs else np.nan
        it = res.diagnostics.get("px_iteration", {}).get("iterations")
        print(f"| {seed} | " + " | ".join(f"{e[c]:+.2f}" for c in cols) + f" | {it} | {el:.1f} |", flush=True)


if __name__ == "__main__":
    main()
