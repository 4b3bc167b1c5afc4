"""nsi-ip on paper-experimental with the acceleration fused or ignored, record by record.

For each seed (2 % noise on z and a, terms of Eq. 24, px(z) roots iterated
by ``nlid.identify``, mass estimated) nsi-ip runs with ``acceleration=ignore``
and ``acceleration=fuse`` (other options at their defaults, or ``--set``).
Per record: the relative errors (%) of the coefficients, of the damping
ratios and natural frequencies at both wells, and ``D``, the relative RMS
error (%) of the identified damping force D(z, v) over the noise-free
motion of the same seed. Results are appended to ``--out`` (JSON lines) as
they come and the run resumes from it; the summary gives, per quantity, mean /
sd / max |error| for each setting and on how many records fusion is closer.

    python benchmarks/accuracy_nsi_acceleration.py --seeds $(seq 0 23)
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from nlid import identify
from nlid.model import physics
from nlid.simulation.presets import get_preset

TERMS = "z^3, z^2, sign(v)*|px(z)|, v*|px(z)|, v*|v|*|px(z)|, v^3*|px(z)|"
SETTINGS = ("ignore", "fuse")


def one_record(preset, seed: int, options: dict[str, str]) -> dict:
    """Errors of both settings on one record."""
    model, truth = preset.model(), preset.truth()["coefficients"]
    eq = physics.equilibria(model, truth)
    true_modal = {("-" if m.equilibrium < 0 else "+"): m for m in physics.modal(model, truth, preset.mass, eq.stable)}
    rec = preset.simulate(seed, noise={"z": 0.02, "a": 0.02}, channels=("z", "a"))
    clean = preset.simulate(seed, channels=("z", "v", "a"))
    d_true = physics.damping(model, truth, clean.z, clean.v)
    row: dict = {"seed": seed}
    for acc in SETTINGS:
        t0 = time.perf_counter()
        res = identify(rec, TERMS, "nsi-ip", options={**options, "acceleration": acc})
        seconds = time.perf_counter() - t0
        d_id = physics.damping(model.with_px_roots(res.px_roots), res.coefficients, clean.z, clean.v)
        err = {k: 100 * (res.coefficients[k] / truth[k] - 1) for k in res.coefficients}
        found = {("-" if m.equilibrium < 0 else "+"): m for m in res.modal}
        for side, t in true_modal.items():
            err[f"zeta{side}"] = 100 * (found[side].zeta / t.zeta - 1) if side in found else np.nan
            err[f"fn{side}"] = 100 * (found[side].fn_hz / t.fn_hz - 1) if side in found else np.nan
        err["D"] = 100 * float(np.sqrt(np.mean((d_id - d_true) ** 2) / np.mean(d_true**2)))
        row[acc] = {"errors": err, "seconds": seconds}
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=list(range(8)))
    ap.add_argument("--out", type=Path, default=Path("out/nsi_acceleration.jsonl"))
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = ap.parse_args()
    options = dict(s.split("=", 1) for s in args.set)
    preset = get_preset("paper-experimental")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    done = {}
    if args.out.exists():
        for line in args.out.read_text().splitlines():
            row = json.loads(line)
            done[row["seed"]] = row
    for seed in args.seeds:
        if seed in done:
            continue
        row = one_record(preset, seed, options)
        with args.out.open("a") as fh:
            fh.write(json.dumps(row) + "\n")
        done[seed] = row
        print(f"seed {seed}: D {row['ignore']['errors']['D']:.2f} % ignored, {row['fuse']['errors']['D']:.2f} % fused")
    rows = [done[s] for s in args.seeds]
    print(f"\n### {len(rows)} records, mass estimated {options or ''}")
    print("| quantity | ignore: mean / sd / max abs | fuse: mean / sd / max abs | records where fuse is closer |")
    print("| --- | --- | --- | --- |")
    for key in rows[0]["fuse"]["errors"]:
        x = {acc: np.array([r[acc]["errors"][key] for r in rows]) for acc in SETTINGS}
        sd = {a: x[a].std(ddof=1) if len(rows) > 1 else np.nan for a in SETTINGS}
        cells = [f"{x[a].mean():+.2f} / {sd[a]:.2f} / {np.abs(x[a]).max():.2f}" for a in SETTINGS]
        closer = int(np.sum(np.abs(x["fuse"]) < np.abs(x["ignore"])))
        name = key.replace("|", "\\|")
        print(f"| {name} | {cells[0]} | {cells[1]} | {closer}/{len(rows)} |")
    med = {acc: float(np.median([r[acc]["seconds"] for r in rows])) for acc in SETTINGS}
    print(f"median seconds per record: ignore {med['ignore']:.1f}, fuse {med['fuse']:.1f}")


if __name__ == "__main__":
    main()
