"""Accuracy of nsi-ip and nsi-shift on paper-numerical (the issue-3 acceptance table).

For each seed: 2 % noise on z only (velocity estimated by the tool), terms
``z^3, z^2, v*|v|`` (+ ``1``, ``z``, ``v``), relative errors (%) of every
coefficient, the mass, the natural frequencies, damping ratios and equilibria
at the two stable wells; then the median of the absolute errors.

    python benchmarks/accuracy_nsi.py                      # both methods, noise 0.02, seeds 0-4
    python benchmarks/accuracy_nsi.py --noise 0 --seeds 0 1 --methods nsi-ip
    python benchmarks/accuracy_nsi.py --set velocity_cutoff=60 --set denoise_cutoff=60
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from nlid import identify
from nlid.model import physics
from nlid.simulation.presets import get_preset

TERMS = "z^3, z^2, v*|v|"
COEFS = ["z^3", "z^2", "z", "v*|v|", "v", "1"]


def truth_modal(preset):
    model = preset.model()
    coefs = preset.truth()["coefficients"]
    eq = physics.equilibria(model, coefs)
    return {("-" if m.equilibrium < 0 else "+"): m for m in physics.modal(model, coefs, preset.mass, eq.stable)}


def errors(result, preset, modal_true):
    truth = preset.truth()["coefficients"]
    e = {k: 100 * (result.coefficients[k] / truth[k] - 1) for k in COEFS}
    e["m"] = 100 * (result.mass / preset.mass - 1)
    found = {("-" if m.equilibrium < 0 else "+"): m for m in result.modal}
    eq = result.equilibria.stable if result.equilibria else []
    for side in "-+":
        t = modal_true[side]
        m = found.get(side)
        e[f"fn{side}"] = np.nan if m is None else 100 * (m.fn_hz / t.fn_hz - 1)
        e[f"ze{side}"] = np.nan if m is None else 100 * (m.zeta / t.zeta - 1)
        zs = [z for z in eq if (z < 0) == (side == "-")]
        e[f"eq{side}"] = np.nan if not zs else 100 * (zs[0] / t.equilibrium - 1)
    return e


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=list(range(5)))
    ap.add_argument("--noise", type=float, default=0.02)
    ap.add_argument("--methods", nargs="+", default=["nsi-ip", "nsi-shift"])
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument("--v-exact", action="store_true", help="give the exact velocity (measured channel)")
    args = ap.parse_args()
    options = dict(s.split("=", 1) for s in args.set)
    preset = get_preset("paper-numerical")
    modal_true = truth_modal(preset)
    channels = ("z", "v") if args.v_exact else ("z",)
    records = {s: preset.simulate(s, noise={"z": args.noise}, channels=channels) for s in args.seeds}
    cols = COEFS + ["m", "fn-", "fn+", "ze-", "ze+", "eq-", "eq+"]
    for method in args.methods:
        print(
            f"\n### {method}, noise {args.noise:g} on z, v {'exact' if args.v_exact else 'estimated'} {options or ''}"
        )
        print("| seed | " + " | ".join(cols) + " | order | k~1 | s |")
        print("|---" * (len(cols) + 4) + "|")
        rows = []
        for s, rec in records.items():
            t0 = time.perf_counter()
            res = identify(rec, TERMS, method, options=options)
            el = time.perf_counter() - t0
            e = errors(res, preset, modal_true)
            rows.append(e)
            d = res.diagnostics
            order = d.get("order")
            k = d.get("k_tilde", "")
            print(f"| {s} | " + " | ".join(f"{e[c]:+.3f}" for c in cols) + f" | {order} | {k} | {el:.2f} |")
        med = {c: float(np.nanmedian([abs(r[c]) for r in rows])) for c in cols}
        print("| **median abs** | " + " | ".join(f"{med[c]:.3f}" for c in cols) + " | | | |")


if __name__ == "__main__":
    main()
