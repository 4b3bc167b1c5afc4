"""The reviewer's hidden 3-DOF case, simulated: the joint least squares' bias and what ``discover`` finds, seed by seed.

The chain is ``3dof-cubic``'s (three 1 kg masses, springs of 1e5 N/m, dampers of 20 N s/m, the force on
mass 1, 1 kHz) with a cubic spring ``(z2-z3)^3`` of 5e9 N/m^3 and a Coulomb friction of 2 N on connection
1-2, ``sign(v1-v2)``. Each record is ``--duration`` s long; only the displacements are recorded, with
``--noise`` (fractions of each displacement's std) on them; velocities and accelerations are estimated;
the mass matrix is known (the record's ``meta['mass']``).

1. **Joint least squares, true model** (both elements declared): the cubic's and the friction's error of
   :func:`nlid.estimation.joint.fit_linear_elements` (the estimator behind ``discover``) and of ``rfs``.
2. **discover** with ``(z2-z3)^3`` declared (every candidate of the library on every connection, up to
   ``--steps`` steps): the connection and law it names, the fitted friction (truth 2 N), the cubic's error
   in the final model, and the time.

``--cutoff-factors 1 2`` repeats part 1 at multiples of the default cut-off (the record's noise floor:
:meth:`nlid.Record.suggest_cutoff`): a higher cut-off lowers the equation error's bias on the cubic but not its
scatter from seed to seed.

The script runs against any checkout (``PYTHONPATH``), so the figures before and after a change come from
the same code path:

    python benchmarks/accuracy_mdof_friction.py [--seeds 1 2 3 4 5] [--noise 0.005 0.01] [--duration 30]
        [--skip-discover] [--skip-joint] [--refine] [--without-friction]

The cubic is read from the model ``discover`` reports (``result.model``): with ``--refine`` the output-error
refit of the final elements (``discover_structure(refine=True)``; the default since the velocities are
estimated), which the noise on the displacements does not bias; without it, from the search's equation-error
fit (``refine=False``, ``nlid discover --no-refine``). The column "search's cubic %" is always the search's.
"""

from __future__ import annotations

import argparse
import os
import time

import nlid
from nlid.discovery.structure import discover_structure
from nlid.estimation.joint import fit_linear_elements
from nlid.simulation.presets import get_preset

CUBIC, FRICTION = "(z2-z3)^3", "sign(v1-v2)"
TRUTH = {CUBIC: 5e9, FRICTION: 2.0}


def chain(duration: float):
    """The hidden case's chain (module docstring)."""
    elements = f"{CUBIC}, {FRICTION}"
    return get_preset("3dof-cubic").with_overrides(duration=duration, elements=elements, coefficients=TRUTH)


def record(duration: float, seed: int, noise: float):
    """One record: displacements only, noise on them."""
    return chain(duration).simulate(seed, noise={"z": noise}, channels=("z",))


def pct(value: float, truth: float) -> str:
    return f"{100 * (value / truth - 1):+.3g}"


def joint(seeds, noises, duration, factors=(1.0,)) -> None:
    print("| noise | seed | cut-off Hz | joint LS: cubic % | friction % | rfs: cubic % | friction % |")
    print("|---|---|---|---|---|---|---|")
    for noise in noises:
        for seed in seeds:
            rec = record(duration, seed, noise)
            for factor in factors:  # the default cut-off (the record's noise floor) times each factor
                fc = min(factor * rec.suggest_cutoff(), 0.45 * rec.fs)
                model = fit_linear_elements(rec, f"{CUBIC}, {FRICTION}", cutoff=fc)
                cells = [pct(model.coefficient(k), TRUTH[k]) for k in (CUBIC, FRICTION)]
                if factor == 1.0:
                    fit = nlid.identify(rec, f"{CUBIC}, {FRICTION}", "rfs", mass=rec.mass).structure
                    cells += [pct(fit.coefficient(k), TRUTH[k]) for k in (CUBIC, FRICTION)]
                else:
                    cells += ["-", "-"]
                print(f"| {noise:g} | {seed} | {fc:.0f} | " + " | ".join(cells) + " |", flush=True)


def discovery(seeds, noises, duration, steps, refine=False) -> None:
    print("| noise | seed | named | law | coefficient | explained % | refused above it | search's cubic % | cubic % "
          "| friction % | right | s | CPU s |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    right = 0
    for noise in noises:
        for seed in seeds:
            rec = record(duration, seed, noise)
            clock, cpu = time.perf_counter(), time.process_time()
            res = discover_structure(rec, CUBIC, max_steps=steps, refine=refine)
            assert res.model is (res.refined if refine else res.final).model
            seconds, cpu = time.perf_counter() - clock, time.process_time() - cpu
            final = res.refined if refine else res.final
            search = pct(res.final.model.coefficient(CUBIC), TRUTH[CUBIC])
            cubic = pct(final.model.coefficient(CUBIC), TRUTH[CUBIC])
            coefficients = final.model.coefficients
            friction = pct(coefficients[FRICTION], TRUTH[FRICTION]) if FRICTION in coefficients else "-"
            if res.steps:
                e = res.steps[0].evidence
                law, coef = e.effect, ", ".join(f"{k} = {v:.4g}" for k, v in e.coefficients.items())
                refused = [x for x in res.steps[0].ranking if x.status == "rejected" and x.explained > e.explained]
                above = "; ".join(f"{x.effect} {next(iter(x.coefficients.values())):.3g}" for x in refused) or "-"
                named, explained = e.where, f"{100 * e.explained:.3g}"
                positive = all(v > 0 for v in e.coefficients.values())
                ok = e.connection == (1, 2) and positive and abs(float(cubic)) < 1.0
            else:
                named, law, coef, explained, above, ok = "none", "", "", "", "-", False
            right += ok
            print(
                f"| {noise:g} | {seed} | {named} | {law} | {coef} | {explained} | {above} | {search} | {cubic} | "
                f"{friction} | {'yes' if ok else 'NO'} | {seconds:.0f} | {cpu:.0f} |",
                flush=True,
            )
    print(f"\nconnection 1-2, a positive dissipative law and the cubic within 1 %: {right} of "
          f"{len(seeds) * len(noises)}")  # fmt: skip


def false_positives(seeds, noises, duration) -> None:
    """The chain with its declared cubic only (no friction): what discover names (it should name nothing)."""
    print("| noise | seed | named |")
    print("|---|---|---|")
    quiet = 0
    for noise in noises:
        for seed in seeds:
            rec = (
                get_preset("3dof-cubic")
                .with_overrides(duration=duration, elements=CUBIC, coefficients={CUBIC: TRUTH[CUBIC]})
                .simulate(seed, noise={"z": noise}, channels=("z",))
            )
            res = discover_structure(rec, CUBIC, simulate=False, refine=False)  # only what is named
            named = "; ".join(f"{s.evidence.effect} on {s.evidence.where}" for s in res.steps) or "nothing"
            quiet += not res.steps
            print(f"| {noise:g} | {seed} | {named} |", flush=True)
    print(f"\nnothing named: {quiet} of {len(seeds) * len(noises)}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5])
    parser.add_argument("--noise", type=float, nargs="+", default=[0.005, 0.01])
    parser.add_argument("--duration", type=float, default=30.0)
    parser.add_argument("--steps", type=int, default=2)
    parser.add_argument("--skip-joint", action="store_true")
    parser.add_argument(
        "--cutoff-factors", type=float, nargs="+", default=[1.0], help="joint LS at these multiples of the cut-off"
    )
    parser.add_argument("--skip-discover", action="store_true")
    parser.add_argument("--refine", action="store_true", help="read the cubic from the output-error refit")
    parser.add_argument("--without-friction", action="store_true", help="also the chain without its friction")
    args = parser.parse_args()
    print(f"load: {os.getloadavg()}\n")
    if not args.skip_joint:
        print(f"## Joint least squares with the true model ({args.duration:g} s, z only)\n")
        joint(args.seeds, args.noise, args.duration, args.cutoff_factors)
    if not args.skip_discover:
        how = ", refined by oe" if args.refine else ""
        print(f"\n## discover, (z2-z3)^3 declared ({args.duration:g} s, z only{how})\n")
        discovery(args.seeds, args.noise, args.duration, args.steps, args.refine)
    if args.without_friction:
        print(f"\n## discover on the chain without its friction ({args.duration:g} s, z only)\n")
        false_positives(args.seeds, args.noise, args.duration)
    print(f"\nload: {os.getloadavg()}")


if __name__ == "__main__":
    main()
