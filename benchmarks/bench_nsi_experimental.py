"""Seconds per paper-experimental record for nsi-ip: z/a fusion and the k~1 ensemble on and off.

One record (2 % noise on z and a, 61 440 samples at 512 Hz), terms of Eq. 24
(``z^3, z^2, sign(v)*|px(z)|, v*|px(z)|, v*|v|*|px(z)|, v^3*|px(z)|``), the
whole ``nlid.identify`` call (px(z) fixed point included: 2 identifications
on this preset) and one nsi-ip call with the true px roots. Median of
``--repeat`` runs after one warm-up, per configuration:

* ``default``: ``acceleration=fuse``, ``k_tilde_ensemble=5``;
* ``ignore, 1 k~1``: the behaviour before the fusion and the ensemble;
* ``fuse, 1 k~1`` and ``ignore, 5 k~1``: each addition alone.

Also prints nsi-ip's own cumulative timings (``diagnostics["timings_s"]``)
for the default.

    python benchmarks/bench_nsi_experimental.py [--repeat 3] [--seed 0]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

from _common import median_time  # noqa: E402

from nlid import identify  # noqa: E402
from nlid.simulation.presets import get_preset  # noqa: E402

TERMS = "z^3, z^2, sign(v)*|px(z)|, v*|px(z)|, v*|v|*|px(z)|, v^3*|px(z)|"
CONFIGS = {
    "default": {},
    "ignore, 1 k~1": {"acceleration": "ignore", "k_tilde_ensemble": 1},
    "fuse, 1 k~1": {"k_tilde_ensemble": 1},
    "ignore, 5 k~1": {"acceleration": "ignore"},
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    preset = get_preset("paper-experimental")
    rec = preset.simulate(args.seed, noise={"z": 0.02, "a": 0.02}, channels=("z", "a"))
    roots = preset.model().px_roots
    print(f"### nsi-ip on one paper-experimental record ({rec.n} samples), median of {args.repeat} runs")
    print("| configuration | identify (px fixed point), s | one nsi-ip call, s |")
    print("|---|---|---|")
    for label, options in CONFIGS.items():
        full, _ = median_time(lambda o=options: identify(rec, TERMS, "nsi-ip", options=o), repeat=args.repeat)
        one, _ = median_time(
            lambda o=options: identify(rec, TERMS, "nsi-ip", options=o, px_roots=roots), repeat=args.repeat
        )
        print(f"| {label} | {full:.2f} | {one:.2f} |", flush=True)
    res = identify(rec, TERMS, "nsi-ip", px_roots=roots)
    steps = ", ".join(f"{k} {v:.2f}" for k, v in res.diagnostics["timings_s"].items())
    print(f"default, cumulative nsi-ip timings (s): {steps}")


if __name__ == "__main__":
    main()
