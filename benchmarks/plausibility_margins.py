"""The figures the plausibility checks judge, on every preset and measured benchmark: how far healthy is from flagged.

Prints, per record and method: the damping ratios, the force residual, the most negative dissipative
coefficient in standard errors, the mass the record's force balance implies against the given one (and
its relative standard error), and the flags :func:`nlid.identified.plausibility.check` raises (a healthy
record must raise none). The limits in :mod:`nlid.identified.plausibility` were chosen from this output.

Usage::

    python benchmarks/plausibility_margins.py [--seeds 3] [--methods rfs,nsi-ip] [--no-measured]

Needs ``$NLID_DATA_DIR`` for the measured benchmarks (EMPS, Silverbox, Bouc-Wen).
"""

from __future__ import annotations

import argparse
import time

import nlid
import nlid.errors
from nlid.identified.plausibility import check, implied_mass

#: (preset, terms, noise, channels, duration) as the built-in studies simulate them.
PRESETS = (
    ("paper-numerical", "z^3, z^2, v*|v|", {"z": 0.02}, "z", None),
    (
        "paper-experimental",
        "z^3, z^2, sign(v)*|px(z)|, v*|px(z)|, v*|v|*|px(z)|, v^3*|px(z)|",
        {"z": 0.02, "a": 0.02},
        "z,a",
        None,
    ),
    ("paper-numerical-stepped", "z^3, z^2, v*|v|", {"z": 0.02}, "z", 134.0),
    ("paper-numerical-swept", "z^3, z^2, v*|v|", {"z": 0.02}, "z", 160.0),
)

#: (label, dataset, terms, without, mass) for the measured benchmarks (README and study models).
MEASURED = (
    ("emps (README)", "dataset:emps", "sign(v)", "z", None),
    ("emps (mass given 95.1)", "dataset:emps", "sign(v)", "z", 95.1),
    ("silverbox z^2,z^3", "dataset:silverbox", "z^2, z^3", None, None),
    ("silverbox z^3", "dataset:silverbox", "z^3", None, None),
    ("bouc-wen linear (mass 2)", "dataset:bouc-wen", "", "1", 2.0),
    ("bouc-wen z^3,v*|v| (mass 2)", "dataset:bouc-wen", "z^3, v*|v|", "1", 2.0),
    ("bouc-wen bouc_wen(800,-1100)", "dataset:bouc-wen", "bouc_wen(800, -1100)", "1", 2.0),
)


def describe(label: str, fit: nlid.IdentifiedModel, record: nlid.Record, true_mass: float | None) -> None:
    zetas = [100 * m.zeta for m in fit.modal]
    se = dict(fit.standard_errors or {})
    worst = []
    for name, term in zip(fit.terms, fit.model.terms, strict=True):
        if term.dissipative and fit.coefficients[name] < 0:
            e = se.get(name)
            ratio = f" ({fit.coefficients[name] / e:.1f} se)" if e else ""
            worst.append(f"{name}={fit.coefficients[name]:.3g}{ratio}")
    implied = implied_mass(record, fit.model)
    mass = fit.mass if true_mass is None else true_mass
    ratio = rel = float("nan")
    if implied is not None and mass:
        ratio, rel = mass / implied.value, implied.standard_error / abs(implied.value)
    flags = check(fit, record)
    res = fit.force_residual_percent
    shown = [f"{z:.3g}" for z in zetas]
    print(
        f"{label:44s} zeta % {shown!s:28s} force res. {res if res is None else round(res, 3)!s:8s}"
        f" mass/implied {ratio:7.4f} (implied rel. se {rel:.3g})  negative dissipative: {worst or '-'}"
        f"  flags: {[f.code for f in flags] or '-'}",
        flush=True,
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--methods", default="rfs,nsi-ip")
    parser.add_argument("--no-measured", action="store_true")
    args = parser.parse_args()
    methods = args.methods.split(",")
    start = time.perf_counter()
    for preset, terms, noise, channels, duration in PRESETS:
        for seed in range(args.seeds):
            kw = {} if duration is None else {"duration": duration}
            record = nlid.simulate(preset, seed=seed, noise=noise, channels=channels, **kw)
            for method in methods:
                try:
                    fit = nlid.identify(record, terms, method, mass=record.mass)
                except nlid.errors.NlidError as exc:  # a method that cannot identify the record has no figures
                    print(f"{preset} seed {seed} {method}: failed: {exc}", flush=True)
                    continue
                describe(f"{preset} seed {seed} {method}", fit, record, None)
            fit = nlid.identify(record, terms, "rfs")  # the mass estimated: its implied mass vs the true one
            describe(f"{preset} seed {seed} rfs (mass estimated)", fit, record, record.mass)
    if not args.no_measured:
        for label, source, terms, without, mass in MEASURED:
            record = nlid.load(source)
            fit = nlid.identify(record, terms, "rfs", mass=mass, without=without)
            describe(label, fit, record, None)
    print(f"wall time {time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()
