"""Measure how far every pinned number moves on another machine, and write the pin tolerances (issue 35).

The pin tests (``tests/test_pins_spine.py``: suite ``issue22``; ``tests/test_pins.py``: suite ``issue12``)
compare each pinned leaf with the tolerance of its group, read from ``tests/data/pin_tolerances.json``
(``tests/pinning.py``). This script measures those tolerances. It recomputes every pinned leaf in a child
process under each *configuration* this machine can run:

* ``auto``: nothing forced (the OpenBLAS kernel this CPU selects, every core);
* ``kernel=<name>``: ``OPENBLAS_CORETYPE=<name>``, one per distinct kernel OpenBLAS accepts here (numpy's
  and scipy's OpenBLAS both read it; the kernel actually used is read back with threadpoolctl);
* ``threads=1``: ``OPENBLAS_NUM_THREADS=1`` (another split of the BLAS work);
* ``numpy=baseline``: ``NPY_DISABLE_CPU_FEATURES`` switches off every instruction set numpy dispatches to
  at run time (its SIMD loops for the elementwise functions);
* ``numba=generic``: ``NUMBA_CPU_NAME=generic``, the compiled integrators built for a generic x86-64 (in a
  cache folder of their own);
* ``perturb=<eps>#<k>``: every simulated record's ``f``, ``z``, ``v``, ``a`` multiplied by
  ``1 + eps * N(0, 1)`` (seeded), with ``eps`` = 1e-15, 1e-14, 1e-13: the order of the last bits a
  different kernel changes in a sum of a few thousand products, applied to the input instead.

For each leaf the *spread* is the range of its values over the configurations and the pinned value
itself, relative to the pinned value: the pins were written by the same code on another machine (issue22;
on this one the issue12 pins are reproduced to the last bit with the auto kernel), so their distance is a
measurement of one more machine.

A group's tolerance (a group is a leaf path with list positions dropped) is then

* ``rel = max(floor, SAFETY * worst relative spread)``, rounded up to one significant digit, for
  deterministic numbers (``SAFETY`` = 100, ``floor`` = 1e-9);
* ``abs = MC_SAFETY * worst absolute deviation from the pin`` for the quantities declared Monte Carlo below
  (an MCMC chain: one flipped accept/reject from a last-bit change gives another chain, so they move by
  their Monte Carlo error, not by the last bits);
* a text compared with a declared pattern masked (a number inside it that comes from a Monte Carlo chain).

Text, flags and counts must not move at all; one that does (a tie-break, a near-equal argmax) is reported
and ``--write`` refuses until it has a declared rule with its reason.

Usage::

    python benchmarks/pin_spreads.py --list            # the configurations this machine can run
    python benchmarks/pin_spreads.py                   # measure (cached per configuration) and print
    python benchmarks/pin_spreads.py --write           # ... and rewrite tests/data/pin_tolerances.json
    python benchmarks/pin_spreads.py --suite issue22 --configs auto,kernel=Haswell   # a subset
    python benchmarks/pin_spreads.py --check           # do the pins hold under every cached configuration?
    python benchmarks/pin_spreads.py --check floors    # ... with the floors alone (before issue 35)
    python benchmarks/pin_spreads.py --check leave-one-out   # ... each with tolerances measured without it
    python benchmarks/pin_spreads.py --other-kernel    # a kernel name for CI's second pin run (or nothing)

Each configuration recomputes every pin (about a minute per suite on an idle core); the results are cached
in ``--cache`` (default ``/tmp/nlid-pin-spreads``) so ``--write`` after a measurement costs nothing; pass
``--fresh`` to measure again.
"""

from __future__ import annotations

import argparse
import fnmatch
import json
import math
import os
import platform
import re
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
TESTS = ROOT / "tests"
sys.path.insert(0, str(TESTS))

from pinning import TOLERANCE_PATH, group_of, is_number  # noqa: E402

SAFETY = 100.0
MC_SAFETY = 3.0
EPSILONS = (1e-15, 1e-14, 1e-13)
PERTURB_SEEDS = 2
#: OPENBLAS_CORETYPE names tried; the distinct kernels OpenBLAS actually selects for them are kept.
KERNEL_NAMES = ("Prescott", "Nehalem", "Sandybridge", "Haswell", "SkylakeX", "Cooperlake", "SapphireRapids", "Zen")


@dataclass(frozen=True)
class Suite:
    """One pin file: its test module, how to collect its leaves and how its tolerances are set."""

    name: str
    module: str
    floor: float
    absolute: float
    pins_count: bool
    monte_carlo: dict[str, str] = field(default_factory=dict)
    masks: dict[str, tuple[str, str]] = field(default_factory=dict)


_CHAIN = "from an MCMC chain (emcee): a last-bit change flips one accept/reject and gives another chain"
_DIVERGED = r"diverged at sample \d+ \(t = [0-9.]+ s\)"

SUITES = {
    "issue22": Suite(
        "issue22",
        "test_pins_spine",
        floor=1e-9,
        absolute=0.0,
        pins_count=True,
        monte_carlo={
            "study.*.ci_lo:*": _CHAIN,
            "study.*.ci_hi:*": _CHAIN,
            "study.*.ci_width:*": _CHAIN,
            "study.*.posterior:tau": _CHAIN,
        },
        masks={
            "study.*.warnings": (
                _DIVERGED,
                "an identified model that escapes its wells under the recorded force (the posterior's bias"
                " check) does so at a sample that moves with the last bits (measured 1682 to 6906 for one run);"
                " the rest of the text is compared exactly",
            ),
        },
    ),
    "issue12": Suite("issue12", "test_pins", floor=1e-9, absolute=0.0, pins_count=True),
}


@dataclass(frozen=True)
class Config:
    """One way of running the pins: environment variables and an optional input perturbation."""

    name: str
    env: dict[str, str] = field(default_factory=dict)


# --------------------------------------------------------------------------- the configurations


#: Kernels tried, in order, for the second pin run of CI (``--other-kernel``): x86-64 first, then ARM and POWER.
CI_KERNELS = ("Haswell", "Sandybridge", "Prescott", "Nehalem", "ARMV8", "NEOVERSEN1", "CORTEXA57", "POWER8")


def _probe(env: dict[str, str]) -> dict[str, Any]:
    """What a fresh interpreter with ``env`` runs on: the BLAS kernels, their threads, numpy's CPU features."""
    code = (
        "import json, numpy, scipy.linalg, threadpoolctl\n"
        "try:\n"
        "    from numpy._core._multiarray_umath import __cpu_features__ as f\n"
        "except ImportError:\n"
        "    f = {}\n"
        "info = threadpoolctl.threadpool_info()\n"
        "print(json.dumps({'blas': sorted({i.get('architecture', '?') for i in info if i['user_api'] == 'blas'}),"
        " 'threads': sorted({i['num_threads'] for i in info}), 'numpy': sorted(k for k, v in f.items() if v)}))"
    )
    out = subprocess.run([sys.executable, "-c", code], env={**os.environ, **env}, capture_output=True, text=True)
    if out.returncode:
        return {"error": out.stderr.strip().splitlines()[-1] if out.stderr.strip() else "failed"}
    return json.loads(out.stdout)


def other_kernel() -> str:
    """The first of :data:`CI_KERNELS` that this machine's OpenBLAS accepts and that differs from its own.

    An empty string when none does (OPENBLAS_CORETYPE not honoured: an OpenBLAS built for one CPU, another
    BLAS, or a CPU none of the names fits).
    """
    auto = tuple(_probe({}).get("blas", ()))
    for name in CI_KERNELS:
        got = tuple(_probe({"OPENBLAS_CORETYPE": name}).get("blas", ()))
        if got and got != auto:
            return name
    return ""


def configurations() -> list[Config]:
    """Every configuration this machine can run (kernels that map to the same one are tried once)."""
    auto = _probe({})
    configs = [Config("auto")]
    seen = {tuple(auto.get("blas", ()))}
    for name in KERNEL_NAMES:
        got = tuple(_probe({"OPENBLAS_CORETYPE": name}).get("blas", ()))
        if got and got not in seen:
            seen.add(got)
            configs.append(Config(f"kernel={name}", {"OPENBLAS_CORETYPE": name}))
    configs.append(Config("threads=1", {"OPENBLAS_NUM_THREADS": "1"}))
    try:
        from numpy._core._multiarray_umath import __cpu_dispatch__
    except ImportError:  # pragma: no cover - older numpy
        __cpu_dispatch__ = []
    if __cpu_dispatch__:
        configs.append(Config("numpy=baseline", {"NPY_DISABLE_CPU_FEATURES": " ".join(__cpu_dispatch__)}))
    configs.append(Config("numba=generic", {"NUMBA_CPU_NAME": "generic", "NUMBA_CACHE_DIR": "<cache>/numba-generic"}))
    for eps in EPSILONS:
        for k in range(PERTURB_SEEDS):
            configs.append(Config(f"perturb={eps:g}#{k}", {"NLID_PIN_PERTURB": f"{eps!r},{k}"}))
    return configs


# The perturbation reaches every process of a run (the study's fork server and its children) through
# a sitecustomize module on PYTHONPATH, read when each interpreter starts.
SITECUSTOMIZE = '''"""Written by benchmarks/pin_spreads.py: perturb every simulated record (NLID_PIN_PERTURB)."""
import os

if os.environ.get("NLID_PIN_PERTURB"):
    import numpy as np

    from nlid import presets

    _eps, _seed = os.environ["NLID_PIN_PERTURB"].split(",")
    _original = presets.Preset.simulate

    def _simulate(self, *args, **kwargs):
        record = _original(self, *args, **kwargs)
        rng = np.random.default_rng([int(_seed), int(record.meta["seed"]), record.n])
        changes = {}
        for c in ("f", "z", "v", "a"):
            x = getattr(record, c)
            if x is not None:
                changes[c] = x * (1.0 + float(_eps) * rng.standard_normal(x.size))
        return record.replace(**changes)

    presets.Preset.simulate = _simulate
'''


def _env(config: Config, cache: Path) -> dict[str, str]:
    env = dict(os.environ)
    for key in ("OPENBLAS_CORETYPE", "OPENBLAS_NUM_THREADS", "NPY_DISABLE_CPU_FEATURES", "NUMBA_CPU_NAME"):
        env.pop(key, None)
    env.update({k: v.replace("<cache>", str(cache)) for k, v in config.env.items()})
    if "NLID_PIN_PERTURB" in config.env:
        site = cache / "site"
        site.mkdir(parents=True, exist_ok=True)
        (site / "sitecustomize.py").write_text(SITECUSTOMIZE)
        env["PYTHONPATH"] = os.pathsep.join([str(site), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    return env


# --------------------------------------------------------------------------- collecting


def collect_child(suite: str, out: Path) -> None:
    """In the child: every leaf of ``suite`` computed now, and what the process ran on, as JSON."""
    import tempfile

    module = __import__(SUITES[suite].module)
    info: dict[str, Any] = {}
    if suite == "issue22":
        values = {**module.new_leaves("identify"), **module.new_leaves("compare"), **module.new_leaves("study")}
    else:
        with tempfile.TemporaryDirectory() as tmp:
            values = module.collect_leaves(Path(tmp))
        # test_posterior_unchanged's own measure: shifts in posterior sd (its limit 0.1) and the sd ratio
        info["posterior_shifts"] = module.posterior_shifts(module.pinned_record())
    clean = {k: (None if isinstance(v, float) and math.isnan(v) else v) for k, v in values.items()}
    out.write_text(json.dumps({"ran_on": _probe({}), "leaves": clean, "info": info}, default=str))


def measure(suite: str, config: Config, cache: Path, fresh: bool) -> dict[str, Any]:
    """The leaves of ``suite`` under ``config`` (from the cache unless ``fresh``)."""
    path = cache / suite / f"{re.sub(r'[^A-Za-z0-9=.#+-]', '_', config.name)}.json"
    if path.is_file() and not fresh:
        return json.loads(path.read_text())
    path.parent.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    cmd = [sys.executable, str(Path(__file__).resolve()), "--child", suite, str(path)]
    done = subprocess.run(cmd, env=_env(config, cache), capture_output=True, text=True)
    if done.returncode:
        raise SystemExit(f"{suite} under {config.name} failed:\n{done.stderr[-3000:]}")
    data = json.loads(path.read_text())
    data["seconds"] = round(time.perf_counter() - start, 1)
    path.write_text(json.dumps(data, default=str))
    print(f"  {suite} {config.name}: {data['seconds']} s on {data['ran_on'].get('blas')}", file=sys.stderr)
    return data


def pinned(suite: str) -> dict[str, Any]:
    """The pinned leaves of ``suite``."""
    module = __import__(SUITES[suite].module)
    if suite == "issue22":
        pins = json.loads(module.PINS_PATH.read_text())
        return {
            **module.pinned_leaves(pins, "identify"),
            **module.pinned_leaves(pins, "compare"),
            **module.pinned_leaves(pins, "study"),
        }
    return module.pinned_leaves_all()


# --------------------------------------------------------------------------- spreads and tolerances


def _round_up(x: float) -> float:
    """``x`` rounded up to one significant digit (3.2e-7 -> 4e-7)."""
    if x <= 0:
        return 0.0
    exponent = math.floor(math.log10(x))
    mantissa = math.ceil(round(x / 10**exponent, 9))
    return float(f"{mantissa}e{exponent}")


def _rule(patterns: dict[str, Any], group: str) -> Any:
    for pattern, value in patterns.items():
        if fnmatch.fnmatchcase(group, pattern):
            return value
    return None


def prepared(suite: Suite, pins: dict[str, Any], runs: dict[str, dict[str, Any]]):
    """Per configuration: the leaves to compare (after the test's own rule, if any) and what broke the rule."""
    rule = getattr(__import__(suite.module), "posterior_outcome", None)
    out = {}
    for name, run in runs.items():
        new, old, problems = rule(run["leaves"], pins) if rule else (run["leaves"], pins, [])
        out[name] = (new, old, problems)
    return out


def spreads(suite: Suite, pins: dict[str, Any], runs: dict[str, dict[str, Any]]) -> dict[str, Any]:
    """Per group: the measured spread, the rule it gets, and the discrete leaves that moved."""
    views = prepared(suite, pins, runs)
    groups: dict[str, dict[str, Any]] = {}
    unstable: dict[str, list[str]] = {}
    skipped: dict[str, list[str]] = {}
    for name, (_, _, problems) in views.items():
        for problem in problems:
            unstable.setdefault("rule", []).append(f"{name}: {problem}")
    for path, old in pins.items():
        group = group_of(path)
        values = {name: new.get(path, "<missing>") for name, (new, kept, _) in views.items() if path in kept}
        left_out = [name for name, (_, kept, _) in views.items() if path not in kept]
        if left_out:
            skipped[path] = left_out
        if suite.pins_count:
            values = {"pin": old, **values}
        entry = groups.setdefault(group, {"leaves": 0, "spread": 0.0, "by": "", "numeric": False, "worst": ""})
        entry["leaves"] += 1
        mask = _rule(suite.masks, group)
        if isinstance(old, str) and mask:
            masked = {re.sub(mask[0], "#", v) if isinstance(v, str) else v for v in values.values()}
            if len(masked) > 1:
                unstable.setdefault(group, []).append(f"{path}: differs outside the mask {sorted(masked)[:3]}")
            continue
        numbers = [v for v in values.values() if is_number(v)]
        if is_number(old) and not (isinstance(old, int) and all(isinstance(v, int) for v in numbers)):
            if len(numbers) != len(values):
                unstable.setdefault(group, []).append(f"{path}: not a number in {_which(values, is_number)}")
                continue
            entry["numeric"] = True
            entry["samples"] = min(entry.get("samples", len(numbers)), len(numbers))
            low, high = min(numbers), max(numbers)
            spread_abs = max(abs(v - old) for v in numbers)
            if _rule(suite.monte_carlo, group):
                if spread_abs >= entry["spread"]:
                    entry.update(spread=spread_abs, worst=path, by=_argmax(values, old))
                continue
            spread = (high - low) / abs(old) if old != 0 else (math.inf if high != low else 0.0)
            if spread >= entry["spread"] and spread > 0:
                entry.update(spread=spread, worst=path, by=_argmax(values, old))
        else:
            same = {json.dumps(v, sort_keys=True, default=str) for v in values.values()}
            if len(same) > 1:
                unstable.setdefault(group, []).append(f"{path}: {sorted(same)[:4]}")
    return {"groups": groups, "unstable": unstable, "skipped": skipped}


def _which(values: dict[str, Any], good) -> str:
    return ", ".join(name for name, v in values.items() if not good(v))


def _argmax(values: dict[str, Any], old: float) -> str:
    """The configuration farthest from the pin (or from the first value when the pin is not counted)."""
    ref = old
    return max(values, key=lambda name: abs(values[name] - ref))


def tolerances(suite: Suite, measured: dict[str, Any]) -> dict[str, Any]:
    """The entry of ``suite`` in the tolerance file."""
    groups = {}
    pooled: dict[str, dict[str, Any]] = {}  # Monte Carlo columns: pooled over the study's runs
    for group, entry in measured["groups"].items():
        if entry["numeric"] and _rule(suite.monte_carlo, group):
            pool = pooled.setdefault(_run_pattern(group), {"spread": 0.0, "samples": 0, "by": ""})
            pool["samples"] += entry.get("samples", 0)
            if entry["spread"] >= pool["spread"]:
                pool.update(spread=entry["spread"], by=f"{entry['worst']} ({entry['by']})")
    for group, entry in sorted(measured["groups"].items()):
        if not entry["numeric"]:
            continue
        reason = _rule(suite.monte_carlo, group)
        if reason:
            pool = pooled[_run_pattern(group)]
            groups[group] = {
                "abs": _round_up(MC_SAFETY * pool["spread"]) or suite.absolute,
                "measured_abs": float(f"{pool['spread']:.3g}"),
                "samples": pool["samples"],
                "by": pool["by"],
                "monte_carlo": f"{reason}; pooled over every run of {_run_pattern(group)}",
            }
            continue
        rel = max(suite.floor, _round_up(SAFETY * entry["spread"]))
        item: dict[str, Any] = {"rel": rel, "measured": float(f"{entry['spread']:.3g}")}
        if entry["spread"] > 0:
            item["by"] = entry["by"]
        if entry["leaves"] > 1 and entry["spread"] > 0:
            item["worst"] = entry["worst"]
        groups[group] = item
    masks = {pattern: {"mask": mask, "reason": reason} for pattern, (mask, reason) in suite.masks.items()}
    left_out: dict[str, set[str]] = {}
    for path, names in measured["skipped"].items():
        left_out.setdefault(".".join(path.split(".")[:2]), set()).update(names)
    entry = {
        "test": f"tests/{suite.module}.py",
        "floor": suite.floor,
        "abs": suite.absolute,
        "pins_counted": suite.pins_count,
    }
    if left_out:
        entry["left_out_by_rule"] = {
            "why": "the configurations where the test's posterior_outcome rule applied (the chains did not"
            " converge): the posterior columns of that run are left out there, so fewer samples",
            **{run: sorted(names) for run, names in sorted(left_out.items())},
        }
    return {**entry, "groups": groups, "masked": masks}


def posterior_summary(shifts: dict[str, dict[str, list[float]]]) -> dict[str, Any]:
    """The limits of ``test_posterior_unchanged`` from what it saw in every configuration.

    A configuration that changes the last bits gives another chain, so the shifts are Monte Carlo
    deviations: the limits are ``MC_SAFETY`` times the largest measured.
    """
    worst = max(((v[0], c, t) for c, per in shifts.items() for t, v in per.items()), default=(0.0, "", ""))
    ratios = [v[1] for per in shifts.values() for v in per.values()]
    sd_dev = max(abs(r - 1.0) for r in ratios)
    return {
        "shift_sd": _round_up(MC_SAFETY * worst[0]),
        "sd_rel": _round_up(MC_SAFETY * sd_dev),
        "measured_shift_sd": round(worst[0], 4),
        "by": f"{worst[2]} ({worst[1]})",
        "measured_sd_ratio_range": [round(min(ratios), 4), round(max(ratios), 4)],
        "monte_carlo": "test_posterior_unchanged: the largest shift of a term's mean and 5/50/95 % quantiles from"
        " the pins, in pinned posterior sd, and the sd's relative change; a last-bit change gives another chain"
        f" (emcee), so both are Monte Carlo deviations; limits = {MC_SAFETY:g} x the largest measured",
    }


def _run_pattern(group: str) -> str:
    """A study column's group with its run id replaced by ``*`` (``study.*.ci_lo:v``)."""
    return re.sub(r"^(study|builtin_paper_numerical)\.[^.]+\.", r"\1.*.", group)


def _machine(configs: list[Config], runs: dict[str, dict[str, Any]]) -> dict[str, Any]:
    import numba
    import numpy
    import scipy

    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:  # pragma: no cover - not Linux
        pass
    return {
        "cpu": cpu,
        "python": platform.python_version(),
        "numpy": numpy.__version__,
        "scipy": scipy.__version__,
        "numba": numba.__version__,
        "date": time.strftime("%Y-%m-%d"),
        "configurations": {
            c.name: {"env": c.env, "blas": runs.get(c.name, {}).get("ran_on", {}).get("blas")} for c in configs
        },
    }


def write_file(entries: dict[str, Any], machine: dict[str, Any]) -> str:
    """The tolerance file's text: one group per line, so a diff shows which tolerance moved."""
    head = {
        "about": (
            "Tolerances of the pinned numbers (tests/pinning.py reads them), written by"
            " `python benchmarks/pin_spreads.py --write`: per group (a leaf path with list positions dropped),"
            " 'measured' is the largest range of a leaf over the configurations below (and the pin itself where"
            " 'pins_counted'), relative to the pinned value, 'by' the configuration farthest from the pin;"
            f" rel = max(floor, {SAFETY:g} x measured) rounded up to one digit. Monte Carlo groups get"
            f" abs = {MC_SAFETY:g} x the largest deviation from the pin ('measured_abs'). Groups not listed"
            " (text, flags, counts) are compared exactly."
        ),
        "safety": SAFETY,
        "monte_carlo_safety": MC_SAFETY,
        "measured_on": machine,
    }
    lines = ["{"]
    for key, value in head.items():
        lines.append(f"  {json.dumps(key)}: {json.dumps(value)},")
    lines.append('  "suites": {')
    for i, (name, entry) in enumerate(entries.items()):
        lines.append(f"    {json.dumps(name)}: {{")
        scalars = [k for k in entry if k not in ("groups", "masked")]  # left_out_by_rule: one line
        for key in scalars:
            lines.append(f"      {json.dumps(key)}: {json.dumps(entry[key])},")
        for key in ("masked", "groups"):
            lines.append(f"      {json.dumps(key)}: {{")
            items = list(entry[key].items())
            for j, (group, value) in enumerate(items):
                comma = "," if j < len(items) - 1 else ""
                lines.append(f"        {json.dumps(group)}: {json.dumps(value)}{comma}")
            lines.append("      }" + ("," if key == "masked" else ""))
        lines.append("    }" + ("," if i < len(entries) - 1 else ""))
    lines.append("  }")
    lines.append("}")
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------- checking


def check(suite: str, runs: dict[str, dict[str, Any]], pins: dict[str, Any], data: dict[str, Any]) -> int:
    """Apply the tests' comparison (tolerance file ``data``) to every cached configuration."""
    from pinning import Tolerances, assert_pinned

    tol = Tolerances(suite, data)
    bad = 0
    for name, (new, old, problems) in prepared(SUITES[suite], pins, runs).items():
        try:
            assert not problems, "\n".join(problems)
            assert_pinned(new, old, tol, f"{suite} under {name}")
            print(f"  {suite:8s} {name:22s} pass")
        except AssertionError as exc:
            bad += 1
            first = str(exc).splitlines()
            print(f"  {suite:8s} {name:22s} FAIL {first[0]}\n      " + "\n      ".join(first[1:4]))
    return bad


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--child", nargs=2, metavar=("SUITE", "OUT"), help=argparse.SUPPRESS)
    parser.add_argument("--suite", default="issue22,issue12", help="issue22, issue12 or both (default)")
    parser.add_argument("--configs", default="", help="comma-separated configuration names (default: all)")
    parser.add_argument("--cache", type=Path, default=Path("/tmp/nlid-pin-spreads"))
    parser.add_argument("--fresh", action="store_true", help="measure again instead of reading the cache")
    parser.add_argument("--list", action="store_true", help="print the configurations and exit")
    parser.add_argument(
        "--other-kernel",
        action="store_true",
        help="print an OPENBLAS_CORETYPE that changes the kernel here, or nothing",
    )
    parser.add_argument("--write", action="store_true", help=f"rewrite {TOLERANCE_PATH.relative_to(ROOT)}")
    parser.add_argument(
        "--check",
        nargs="?",
        const="file",
        choices=("file", "floors", "leave-one-out"),
        help="apply the tolerances to every cached configuration: the file's (default), the floors alone (the"
        " tests before issue 35), or for each configuration those measured without it (leave-one-out)",
    )
    args = parser.parse_args(argv)
    if args.child:
        collect_child(args.child[0], Path(args.child[1]))
        return 0
    if args.other_kernel:
        print(other_kernel())
        return 0
    configs = configurations()
    if args.configs:
        wanted = args.configs.split(",")
        unknown = [w for w in wanted if w not in {c.name for c in configs}]
        if unknown:
            parser.error(f"unknown configuration(s) {unknown}; this machine has {[c.name for c in configs]}")
        configs = [c for c in configs if c.name in wanted]
    if args.list:
        for c in configs:
            print(f"{c.name:22s} {c.env}")
        return 0
    entries, all_runs, status = {}, {}, 0
    for name in args.suite.split(","):
        suite = SUITES[name]
        runs = {c.name: measure(name, c, args.cache, args.fresh) for c in configs}
        all_runs.update(runs)
        pins = pinned(name)
        if args.check == "file":
            status |= check(name, runs, pins, json.loads(TOLERANCE_PATH.read_text())) > 0
            continue
        if args.check == "floors":
            floors = {"suites": {name: {"floor": suite.floor, "abs": suite.absolute, "groups": {}}}}
            status |= check(name, runs, pins, floors) > 0
            continue
        if args.check == "leave-one-out":
            for held in runs:
                others = {k: v for k, v in runs.items() if k != held}
                data = {"suites": {name: tolerances(suite, spreads(suite, pins, others))}}
                status |= check(name, {held: runs[held]}, pins, data) > 0
            continue
        measured = spreads(suite, pins, runs)
        entries[name] = tolerances(suite, measured)
        shifts = {c: run.get("info", {}).get("posterior_shifts") for c, run in runs.items()}
        if all(shifts.values()):
            entries[name]["posterior"] = posterior_summary(shifts)
            print(f"{name}: test_posterior_unchanged {entries[name]['posterior']}")
        report(name, entries[name], measured)
        if measured["unstable"]:
            status = 1
    if args.write and not args.check:
        if status:
            print("not written: discrete leaves moved (above); give them a rule first", file=sys.stderr)
            return status
        old = json.loads(TOLERANCE_PATH.read_text()) if TOLERANCE_PATH.is_file() else {"suites": {}}
        merged = {**old.get("suites", {}), **entries}
        TOLERANCE_PATH.write_text(write_file(merged, _machine(configs, all_runs)))
        print(f"wrote {TOLERANCE_PATH.relative_to(ROOT)}")
    return status


def report(name: str, entry: dict[str, Any], measured: dict[str, Any]) -> None:
    """The groups above the floor, the Monte Carlo ones and the discrete leaves that moved."""
    groups = entry["groups"]
    at_floor = [g for g, v in groups.items() if v.get("rel") == entry["floor"]]
    print(f"\n{name}: {len(groups)} numeric groups, {len(at_floor)} at the floor {entry['floor']:g}")
    worst_floor = max((groups[g]["measured"] for g in at_floor), default=0.0)
    print(f"  largest spread among those at the floor: {worst_floor:.2g}")
    for group, v in sorted(groups.items(), key=lambda kv: -kv[1].get("rel", 0)):
        if "abs" in v:
            print(f"  MC  abs {v['abs']:<8.2g} measured {v['measured_abs']:<9.3g} {group}  ({v['by']})")
        elif v["rel"] > entry["floor"]:
            print(f"  rel {v['rel']:<8.2g} measured {v['measured']:<9.3g} {group}  ({v.get('by', '')})")
    for group, items in measured["unstable"].items():
        print(f"  UNSTABLE {group}:\n    " + "\n    ".join(items[:3]))


if __name__ == "__main__":
    sys.exit(main())
