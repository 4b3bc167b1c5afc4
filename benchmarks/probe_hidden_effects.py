"""Probe of issue 31: records with one undeclared effect each, and what discover says about them.

Each case simulates a record whose truth holds one effect the declared model lacks (or a
corruption of the record a user would not declare: a wrong mass, millimetres, a delayed
force), 1 % noise, and runs ``nlid.discover`` (one DOF) or ``discover_structure``
(structures, ``max_steps=2``). Printed per run: what was named, its coefficients against
the truth, the restoring-force error of the final model against the truth on the clean
record, the free-run error on an independent test record (one DOF: ``validation=``; a
structure: its own test part) before and after, the run time, and the stop reason and
notes, so that a reader can judge whether the tool says what is wrong.

    python benchmarks/probe_hidden_effects.py --group 1dof --seeds 1,2 [--refine] [--only coulomb,gap]
    python benchmarks/probe_hidden_effects.py --group mdof --seeds 1,2 [--only coulomb12]

Load: one case is one to a few minutes of one core; run one group at a time on a shared machine.
"""

from __future__ import annotations

import argparse
import dataclasses
import time
import warnings

import numpy as np

from nlid.data.record import Record
from nlid.simulation.presets import PRESETS

_BASE = dataclasses.replace(PRESETS["paper-numerical"], duration=20.0)
_M = 0.2
_DECLARED = ["1", "z", "v", "z^3", "z^2"]  # the base model, linear part and offset included
#: what a user who writes only the nonlinear terms declares (the "complete-bare" case)
_BARE = ["z^3", "z^2"]

#: one-DOF cases: name -> (extra true terms, corruption, mass given)
ONE_DOF: dict[str, tuple[dict[str, float], str, float]] = {
    "complete": ({}, "", _M),
    "complete-bare": ({}, "", _M),
    "coulomb": ({"sign(v)": 2.0}, "", _M),
    "quadratic-damping": ({"v*|v|": 5.0}, "", _M),
    "gap": ({"gap(z, 0.012)": 3000.0}, "", _M),
    "bouc-wen": ({"bouc_wen(150, -50)": 300.0}, "", _M),
    "delay3": ({}, "delay3", _M),
    "mass-x2": ({}, "", 2 * _M),
    "mass-x0.5": ({}, "", 0.5 * _M),
    "mm": ({}, "mm", _M),
    "kN": ({}, "kN", _M),
    "f-negated": ({}, "f-negated", _M),
    "z-drift": ({}, "z-drift", _M),
    "z-only-no-meta": ({}, "z-only-no-meta", _M),
}


def one_dof_preset(extra: dict[str, float]):
    """The paper-numerical double well without its quadratic damping, plus ``extra``."""
    coefficients = dict(_BASE.coefficients)
    coefficients.pop("v*|v|")
    coefficients.update(extra)
    terms = ", ".join(t for t in coefficients if t not in ("1", "z", "v"))
    return dataclasses.replace(_BASE, terms=terms, coefficients=coefficients)


def corrupt(record: Record, how: str) -> Record:
    """The record as a user would hand it over: force 3 samples late, or z, v, a in mm."""
    if how == "delay3":  # the force that acts lags the recorded channel by 3 samples
        k = 3
        return Record(
            f=record.f[k:], z=record.z[:-k], v=record.v[:-k], a=record.a[:-k], fs=record.fs, meta=dict(record.meta)
        )
    if how == "kN":
        return dataclasses.replace(record, f=record.f / 1e3)
    if how == "f-negated":  # the load cell mounted the other way round
        return dataclasses.replace(record, f=-record.f)
    if how == "z-drift":  # a displacement sensor drifting 0.1 mm/s; z only (v and a estimated from it)
        t = np.arange(record.z.size) / record.fs
        return Record(f=record.f, z=record.z + 1e-4 * t, fs=record.fs, meta=dict(record.meta))
    if how == "z-only-no-meta":  # z only, as read from a file without a sidecar (the force hold unknown)
        return Record(f=record.f, z=record.z, fs=record.fs)
    if how == "mm":
        return Record(
            f=record.f, z=record.z * 1e3, v=record.v * 1e3, a=record.a * 1e3, fs=record.fs, meta=dict(record.meta)
        )
    return record


def restoring_error(stage, clean: Record, mass_true: float, how: str) -> float:
    """RMS of (identified R - true R) over RMS of true R along the clean record, percent."""
    r_true = clean.f - mass_true * clean.a
    rec = corrupt(clean, how)
    if how == "delay3":
        r_true = r_true[:-3]
    try:
        r_id = stage.identified.restoring_force(rec.z, clean.v if rec.v is None else rec.v)
    except Exception:  # noqa: BLE001  (memory terms need the history)
        return float("nan")
    a_true = clean.a[:-3] if how == "delay3" else clean.a
    # what the identified model predicts for f - m_true a: its R plus its own inertia minus the true one
    a_rec = a_true if rec.a is None else rec.a  # z-only records: the true acceleration (the drift has none)
    pred = r_id + stage.mass * a_rec - mass_true * a_true
    return float(100 * np.sqrt(np.mean((pred - r_true) ** 2)) / np.sqrt(np.mean(r_true**2)))


def run_one_dof(names: list[str], seeds: list[int], refine: bool) -> None:
    import nlid

    for name in names:
        extra, how, mass = ONE_DOF[name]
        preset = one_dof_preset(extra)
        for seed in seeds:
            rec = corrupt(preset.simulate(seed, noise=0.01), how)
            test = corrupt(preset.simulate(seed + 100, noise=0.01), how)
            clean = preset.simulate(seed, noise=0.0)
            start = time.perf_counter()
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                try:
                    declared = _BARE if name.endswith("-bare") else _DECLARED
                    res = nlid.discover(rec, declared, mass=mass, validation=test, refine=refine)
                except Exception as exc:  # noqa: BLE001
                    print(f"== {name} seed {seed}: CRASH {type(exc).__name__}: {exc}")
                    continue
            secs = time.perf_counter() - start
            print(
                f"== {name} seed {seed} ({secs:.1f} s) truth: {extra or '-'} corruption: {how or '-'} mass given {mass}"
            )
            for s in res.steps:
                coefs = {t: f"{s.after.coefficients[t]:.4g}" for t in s.terms if t in s.after.coefficients}
                print(f"   step {s.effect}: {coefs}; notes {s.notes}")
            stages = [res.initial, res.final] + ([res.refined] if res.refined is not None else [])
            for label, st in zip(("initial", "final", "refined"), stages, strict=False):
                c = st.coefficients
                truth = dict(preset.coefficients)
                cerr = {t: f"{100 * (c[t] - truth[t]) / truth[t]:+.1f}%" for t in ("z^3", "z^2", "z") if t in c}
                r_err = restoring_error(st, clean, _M, how)
                print(
                    f"   {label:8s} eps_ho {st.scores.eps_holdout:.3g}% free-run ho {_g(st.sim_rms_holdout)} "
                    f"test {_g(st.sim_rms_validation)} {st.sim_note[:80]} R err {r_err:.3g}%  "
                    f"m {st.mass:.4g} coef err {cerr} terms {list(c)}"
                )
            print(f"   stop: {res.stop_reason}")
            for w in caught:
                print(f"   WARNING {w.category.__name__}: {str(w.message)[:300]}")


def _g(x: float | None) -> str:
    return "None" if x is None else f"{x:.3g}"


#: structure cases: name -> (extra elements with coefficients, mass factor given)
MDOF: dict[str, tuple[dict[str, float], float]] = {
    "complete": ({}, 1.0),
    "coulomb12": ({"sign(v1-v2)": 2.0}, 1.0),
    "quaddamp23": ({"(v2-v3)*|v2-v3|": 2000.0}, 1.0),
    "gap12": ({"gap(z1-z2, 0.001)": 2e5}, 1.0),
    "cubic1g": ({"z1^3": 3e9}, 1.0),
    "boucwen23": ({"bouc_wen(z2-z3, 3000, -1000)": 3e4}, 1.0),
    "mass-x1.5": ({}, 1.5),
    "mass-x0.5": ({}, 0.5),
    "delay3": ({}, 1.0),  # the force that acts lags the recorded channel by 3 samples (3 ms)
}


def run_mdof(names: list[str], seeds: list[int], refine: bool) -> None:
    from nlid.discovery.structure import discover_structure
    from nlid.simulation.structure_presets import STRUCTURE_PRESETS

    base = STRUCTURE_PRESETS["3dof-cubic"]
    for name in names:
        extra, factor = MDOF[name]
        elements = ", ".join(["z3^3", *extra])
        p = dataclasses.replace(base, elements=elements, coefficients={"z3^3": 5e9, **extra}, duration=20.0)
        for seed in seeds:
            rec = p.simulate(seed, noise=0.01)
            if name == "delay3":
                k = 3
                rec = dataclasses.replace(rec, f=rec.f[k:], z=rec.z[:-k], v=rec.v[:-k], a=rec.a[:-k])
            mass = factor * np.asarray(base.M)
            start = time.perf_counter()
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                try:
                    res = discover_structure(rec, "z3^3", mass=mass, max_steps=2, refine=refine)
                except Exception as exc:  # noqa: BLE001
                    print(f"== {name} seed {seed}: CRASH {type(exc).__name__}: {exc}")
                    continue
            secs = time.perf_counter() - start
            print(f"== {name} seed {seed} ({secs:.1f} s) truth: {extra or '-'} mass x{factor}")
            for s in res.steps:
                ev = s.evidence
                print(f"   step {ev.where}: {ev.elements} {ev.coefficients}")
            for st in res.stages:
                coefs = _model_coefs(st.model)
                print(
                    f"   {st.label[:40]:40s} test free run % {np.round(st.freerun_percent, 2)} "
                    f"eps % {np.round(st.eps_percent, 2)} coefs {coefs} {st.freerun_note[:120]}"
                )
            print(f"   stop: {res.stop_reason[:600]}")
            for w in caught:
                print(f"   WARNING {w.category.__name__}: {str(w.message)[:300]}")


def _model_coefs(model) -> dict[str, str]:
    for attr in ("element_coefficients", "coefficients"):
        c = getattr(model, attr, None)
        if isinstance(c, dict):
            return {k: f"{v:.4g}" for k, v in c.items()}
    return {}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--group", choices=("1dof", "mdof"), default="1dof")
    parser.add_argument("--seeds", default="1,2")
    parser.add_argument("--only", default="")
    parser.add_argument("--refine", action="store_true")
    args = parser.parse_args()
    seeds = [int(s) for s in args.seeds.split(",")]
    table = ONE_DOF if args.group == "1dof" else MDOF
    names = [n for n in args.only.split(",") if n] or list(table)
    (run_one_dof if args.group == "1dof" else run_mdof)(names, seeds, args.refine)


if __name__ == "__main__":
    main()
