"""Accuracy of rfs and sindy on the paper's numerical example (the tables of docs/results.md).

Cases (paper-numerical, terms z^3, z^2, v*|v| plus 1, z, v):

* ``exact``: noise 0, exact v and a channels, seed 0;
* ``noisy``: 2 % noise on z and a (velocity estimated), seeds 0-4;
* ``band``: rfs on the noisy records, and on the same records without noise
  filtered in the same band, with the regressor band factor of
  :func:`nlid.estimation.balance.regression_data` changed: this separates the two
  biases of the damping coefficients (docs/rfs.md).

Each case is run with the mass known and estimated; methods ``nsi-ip`` (for
comparison), ``rfs``, ``sindy``
and ``sindy`` with the automatic library. Every identification is appended to
a CSV as soon as it is done (one row per coefficient, mass, natural frequency
and damping ratio), and a rerun skips what the CSV already holds, so an
interrupted run resumes. The script then prints the median absolute errors as
Markdown tables.

    python benchmarks/accuracy_rfs_sindy.py [--out out/rfs_sindy_accuracy.csv] [--seeds 5]
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np
import pandas as pd

from nlid import identify
from nlid.estimation import balance
from nlid.model import physics
from nlid.simulation.presets import get_preset

TERMS = "z^3, z^2, v*|v|"
METHODS = {
    "nsi-ip": ("nsi-ip", {}),
    "rfs": ("rfs", {}),
    "sindy": ("sindy", {}),
    "sindy-automatic": ("sindy", {"library": "automatic"}),
}
FIELDS = ["case", "mass", "method", "band_factor", "seed", "quantity", "estimate", "truth", "error_percent"]
BAND_FACTORS = (2.0, 4.0, 6.0, 8.0)


def truth_table(preset) -> dict[str, float]:
    """True coefficients, mass and modal parameters at the two stable equilibria."""
    truth = preset.truth()
    model = preset.model()
    out = dict(truth["coefficients"])
    out["mass"] = truth["mass"]
    for mode in physics.modal(model, truth["coefficients"], truth["mass"]):
        side = "z-" if mode.equilibrium < 0 else "z+"
        out[f"fn {side} (Hz)"] = mode.fn_hz
        out[f"zeta {side}"] = mode.zeta
    return out


def rows_of(result, truth: dict[str, float]) -> dict[str, float]:
    """The quantities of a result comparable with the truth."""
    out = dict(result.coefficients)
    out["mass"] = result.mass
    for mode in result.modal or []:
        side = "z-" if mode.equilibrium < 0 else "z+"
        out[f"fn {side} (Hz)"] = mode.fn_hz
        out[f"zeta {side}"] = mode.zeta
    return {k: v for k, v in out.items() if k in truth and v is not None}


def run(out: Path, seeds: int) -> pd.DataFrame:
    preset = get_preset("paper-numerical")
    truth = truth_table(preset)
    out.parent.mkdir(parents=True, exist_ok=True)
    done = set()
    if out.is_file():
        old = pd.read_csv(out)
        done = set(zip(old["case"], old["mass"], old["method"], old["band_factor"], old["seed"], strict=True))
    new_file = not out.is_file()
    jobs = []
    for mass in ("known", "estimated"):
        jobs.append(("exact", mass, 0, {"channels": ("z", "v", "a")}))
        for seed in range(seeds):
            jobs.append(("noisy", mass, seed, {"channels": ("z", "a"), "noise": {"z": 0.02, "a": 0.02}}))
    with out.open("a", newline="") as handle:
        writer = csv.DictWriter(handle, FIELDS)
        if new_file:
            writer.writeheader()
        for case, mass, seed, sim in jobs:
            record = None
            for label, (method, options) in METHODS.items():
                if (case, mass, label, 4.0, seed) in done:
                    continue
                record = record or preset.simulate(seed, **sim)
                res = identify(record, TERMS, method, mass=0.2 if mass == "known" else None, options=options)
                write(writer, handle, case, mass, label, 4.0, seed, rows_of(res, truth), truth)
        default = balance.REGRESSOR_BAND_FACTOR
        try:
            for factor in BAND_FACTORS:
                balance.REGRESSOR_BAND_FACTOR = factor
                for seed in range(seeds):
                    if ("band-noisy", "known", "rfs", factor, seed) in done:
                        continue
                    noisy = preset.simulate(seed, channels=("z", "a"), noise={"z": 0.02, "a": 0.02})
                    res = identify(noisy, TERMS, "rfs", mass=0.2)
                    write(writer, handle, "band-noisy", "known", "rfs", factor, seed, rows_of(res, truth), truth)
                    # the same band without noise: what is left is the band-limited velocity's own bias
                    band = {"cutoff": res.diagnostics["filtered_at_hz"]}
                    clean = identify(preset.simulate(seed, channels=("z", "a")), TERMS, "rfs", mass=0.2, options=band)
                    write(writer, handle, "band-noise-free", "known", "rfs", factor, seed, rows_of(clean, truth), truth)
        finally:
            balance.REGRESSOR_BAND_FACTOR = default
    return pd.read_csv(out)


def write(writer, handle, case, mass, method, factor, seed, values, truth) -> None:
    for name, value in values.items():
        writer.writerow(
            {
                "case": case,
                "mass": mass,
                "method": method,
                "band_factor": factor,
                "seed": seed,
                "quantity": name,
                "estimate": value,
                "truth": truth[name],
                "error_percent": 100.0 * (value / truth[name] - 1.0),
            }
        )
    handle.flush()


def tables(frame: pd.DataFrame) -> str:
    """Median absolute errors (%) as Markdown."""
    lines = []
    order = ["z^3", "z^2", "z", "1", "v", "v*|v|", "mass", "fn z- (Hz)", "fn z+ (Hz)", "zeta z-", "zeta z+"]
    for case, mass in (("exact", "known"), ("exact", "estimated"), ("noisy", "known"), ("noisy", "estimated")):
        sub = frame[(frame.case == case) & (frame.mass == mass)]
        if sub.empty:
            continue
        med = sub.assign(abs_error=sub.error_percent.abs()).pivot_table(
            index="quantity", columns="method", values="abs_error", aggfunc="median"
        )
        methods = [m for m in METHODS if m in med.columns]
        lines.append(f"\n{case}, mass {mass}: median |error| in % over {sub.seed.nunique()} seed(s)\n")
        lines.append("| quantity | " + " | ".join(methods) + " |")
        lines.append("| --- |" + " --- |" * len(methods))
        for q in order:
            if q in med.index and not (q == "mass" and mass == "known"):
                label = q.replace("|", "\\|")
                lines.append(f"| {label} | " + " | ".join(f"{med.loc[q, m]:.3g}" for m in methods) + " |")
    band = frame[frame.case.str.startswith("band")]
    if not band.empty:
        lines.append("\nrfs damping errors against the regressor band factor (signed median %, seeds pooled)\n")
        lines.append("| case | factor | v | v*\\|v\\| | z^2 |")
        lines.append("| --- | --- | --- | --- | --- |")
        for (case, factor), sub in band.groupby(["case", "band_factor"]):
            med = sub.groupby("quantity").error_percent.median()
            lines.append(f"| {case} | {factor:g} | {med['v']:+.3g} | {med['v*|v|']:+.3g} | {med['z^2']:+.3g} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/rfs_sindy_accuracy.csv"), help="CSV to append to")
    parser.add_argument("--seeds", type=int, default=5, help="noisy records per case (seeds 0..N-1, default 5)")
    args = parser.parse_args(argv)
    frame = run(args.out, args.seeds)
    print(tables(frame))
    print(
        f"\n{len(frame)} rows in {args.out}; largest |error| of the exact case: "
        f"{np.abs(frame[frame.case == 'exact'].error_percent).max():.2g} %"
    )


if __name__ == "__main__":
    main()
