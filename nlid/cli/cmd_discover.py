"""``nlid discover``: find the effect a declared model lacks, add it, report the error before and after."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from ..base.validate import ESTIMATE
from ..errors import InputError, NlidError
from ..runtime.progress import stderr_is_terminal
from .common import (
    add_data_arguments,
    add_mass_argument,
    load_data,
    mass_argument,
    parse_settings,
    print_json,
    untrusted,
)
from .isolated import DISCOVER_TIMEOUT, add_timeout_argument, parse_timeout, plugin_warnings

DESCRIPTION = """\
Identify the declared model, look at its residual (against z, v, the (z, v) plane and
frequency), test candidate effects against it on held-out data, add the one that passes
the acceptance rule, re-identify and repeat until nothing else is significant. Prints
epsilon (Eq. 26) and the force residual before and after each step, on estimation and
held-out data.
"""

EPILOG = """\
candidate effects (--candidates): coulomb, viscous, quadratic-damping, cubic-damping,
  position-dependent-friction, stribeck, offset, quadratic-stiffness, cubic-stiffness,
  quintic-stiffness; add your own with --candidate NAME=TERMS, or install a plugin.

acceptance: candidates are ranked by the fraction of the held-out residual variance
  they explain; the best is accepted if it explains at least --min-explained of it and
  the BIC computed with the effective sample size of the residual drops by at least
  10 (--max-delta-bic). See docs/discover.md.

examples:
  nlid discover dataset:emps --declared "v, 1"
  nlid discover dataset:silverbox:estimation --declared "1, z, v"
  nlid discover x.csv --declared "1, z, z^3, v" --mass 0.2 --out report/ --json
  nlid discover dataset:bouc-wen --declared "z, v" --validation dataset:bouc-wen:sinesweep

what remains: after the last step, probes ask how much of the held-out residual is still
  predictable from z, v, (z, v), the acceleration (a wrong mass), the force's rate (a time
  skew) or the motion's history (memory); the report says "clean" or what remains and what
  to try. See docs/discover.md.
"""


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "discover",
        help="find the effect a model lacks from its residual, add it, report the error before and after",
        description=DESCRIPTION,
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_data_arguments(p)
    p.add_argument(
        "--declared",
        required=True,
        metavar="TERMS",
        help="the complete declared model, taken literally (no default terms added), e.g. 'v, 1' or '1, z, v'",
    )
    p.add_argument(
        "--method", metavar="NAME", help="identifier (default: the preferred installed one; see nlid methods)"
    )
    add_mass_argument(
        p,
        "known mass in kg (default: estimated by the method); for a structure its matrix (default: the record's "
        ".meta.json sidecar)",
    )
    p.add_argument(
        "--holdout",
        default="0.25",
        metavar="FILE|FRACTION",
        help="held-out data: a fraction of DATA (its last part; default 0.25) or a second record "
        "(file or dataset:NAME, read like DATA)",
    )
    p.add_argument(
        "--validation",
        metavar="FILE",
        help="a record every model is also scored on (free-run error, epsilon) without taking part in any "
        "decision, e.g. a benchmark's validation set (file or dataset:NAME, read like DATA)",
    )
    p.add_argument(
        "--rule",
        metavar="RULE",
        help="transient rule of the free runs on the held-out and validation records: first-sample, window:N "
        "(N samples fit the initial state and are not scored), periodic or periodic:P (periodic steady state); "
        "default: each record's own (periodic when declared or when its force repeats, else first-sample)",
    )
    p.add_argument(
        "--candidates",
        metavar="NAMES",
        help="comma-separated candidate effects to test (default: all of the library and of installed plugins, "
        "plus 'mass' (re-estimate a given mass) and 'dictionary' (sparse regression on an automatic dictionary))",
    )
    p.add_argument(
        "--candidate",
        action="append",
        metavar="NAME=TERMS",
        help="a candidate of your own, e.g. 'drag=v*|v|' or 'ramp=sign(v)*exp(-|v|/0.01), sign(v)' (repeatable)",
    )
    p.add_argument("--max-steps", type=int, default=5, metavar="N", help="most effects to add (default 5)")
    p.add_argument(
        "--min-explained",
        type=float,
        metavar="F",
        help="fraction of the held-out residual variance a candidate must explain (default 0.02 when the "
        "prediction decides, 0.10 with --no-prediction)",
    )
    p.add_argument(
        "--folds",
        type=int,
        default=2,
        metavar="K",
        help="contiguous blocks of the cross-fitted prediction check: a candidate must improve the free run "
        "(k-step prediction when chaotic) of every block, predicted by the model fitted on the rest (default 2)",
    )
    p.add_argument(
        "--min-gain",
        type=float,
        default=0.01,
        metavar="F",
        help="smallest relative drop of the pooled cross-fitted prediction error that accepts a candidate "
        "(default 0.01)",
    )
    p.add_argument(
        "--no-prediction",
        action="store_true",
        help="judge candidates by the equation error alone (no cross-fitted prediction check)",
    )
    p.add_argument(
        "--max-delta-bic",
        type=float,
        default=-10.0,
        metavar="D",
        help="largest accepted change of the effective-sample-size BIC (default -10)",
    )
    p.add_argument(
        "--cutoff", type=float, metavar="HZ", help="equation band for estimated channels (default: from the data)"
    )
    p.add_argument(
        "--connections",
        metavar="LIST",
        help="structure records only: the connections to test, e.g. '4-5, 5-0' (5-0: DOF 5 to the ground); "
        "default every pair and every DOF to the ground",
    )
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="identifier option (repeatable)")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of the table")
    p.add_argument("--out", metavar="DIR", help="write a report (Markdown, HTML, figures, CSV, JSON) to DIR")
    p.add_argument(
        "--force",
        action="store_true",
        help="with --out, write into a folder that holds files nlid did not write; nlid never replaces them: if "
        "one has the name of an output (figures, report.md, report.html, result.json, models.csv), it stops "
        "before writing anything, naming it",
    )
    p.add_argument(
        "--quiet", action="store_true", help="no progress on stderr (it is shown only on a terminal, never with --json)"
    )
    add_timeout_argument(p, DISCOVER_TIMEOUT, "the search (every identification of it)")
    p.add_argument(
        "--refine",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="refine the final model with the output-error identifier oe (fits the free-run error, shape "
        "parameters included) and report the errors before and after; on a structure record, the chosen elements "
        "refitted by oe on the selection record, and that refit is the final structure model (the search's "
        "equation-error fits are biased when velocities are estimated from noisy displacements). Default: off for "
        "one DOF; on for a structure record whose velocities or accelerations are estimated (--no-refine: off)",
    )
    p.set_defaults(func=run)


def _holdout(args: argparse.Namespace):
    text = str(args.holdout).strip()
    try:
        fraction = float(text)
    except ValueError:
        return load_data(argparse.Namespace(data=text, columns=args.columns, fs=args.fs, units=args.units))
    if not 0.0 < fraction < 1.0:
        raise InputError(f"--holdout: a fraction must lie between 0 and 1, got {text}")
    return fraction


class _SearchProgress:
    """The search's stages on one terminal line, redrawn in place; each accepted effect kept as a line of its own."""

    def __init__(self, show: bool) -> None:
        from ..runtime.progress import ProgressLine

        self.line = ProgressLine("nlid discover", enabled=show)  # the parent looked at its terminal

    def __call__(self, message: str) -> None:
        if ": accepted " in message:
            self.line.keep(f"nlid discover: {message}")
        else:
            self.line.update(note=message)


def _discover_in_child(record, declared, method, settings, show: bool = False) -> tuple:
    """The child's side of ``nlid discover``: the result, or the error's class names and message.

    ``show``: the parent asked for progress (on a terminal, not ``--quiet`` nor ``--json``); the search's
    stages, and the progress of a long identifier (``oe`` with ``--refine``), are then drawn on stderr.
    """
    from ..discovery import discover
    from ..runtime.progress import showing

    with showing(show):
        progress = _SearchProgress(show)
        try:
            with progress.line:
                return ("ok", discover(record, declared, method, progress=progress, **settings))
        except NlidError as exc:
            return ("error", [c.__name__ for c in type(exc).__mro__], str(exc))


def _discover_isolated(timeout: float, record, declared, method, settings, show: bool = False):
    """:func:`nlid.discovery.discover` in a child process stopped after ``timeout`` seconds."""
    from ..runtime.isolation import run_in_child

    label = "the search" if method is None else f"the search with identifier {method!r}"
    outcome = run_in_child(_discover_in_child, (record, declared, method, settings, show), timeout=timeout)
    outcome.reissue_warnings(label)
    return outcome.answer(label, timeout, "raise --timeout")


def run(args: argparse.Namespace) -> int:
    from ..discovery import AcceptanceRule, write_report
    from ..discovery.crossfit import PredictionRule
    from ..runtime.isolation import start_fork_server

    if args.max_steps < 0:
        raise InputError(f"--max-steps must be >= 0, got {args.max_steps}")
    timeout = parse_timeout(args.timeout)
    start_fork_server(pin_threads=False)  # it loads the pipeline while this process reads the data
    record = load_data(args)
    prediction = PredictionRule(folds=args.folds, min_gain=args.min_gain, enabled=not args.no_prediction)
    default_share = prediction.screen if prediction.enabled else AcceptanceRule().min_explained
    share = default_share if args.min_explained is None else args.min_explained
    rule = AcceptanceRule(min_explained=share, max_delta_bic=args.max_delta_bic)
    if record.indexed:
        if args.min_explained is None:  # structures are judged by the equation error (issue 31 covers one DOF)
            rule = AcceptanceRule(max_delta_bic=args.max_delta_bic)
        return _run_structure(args, record, rule)
    if args.connections:
        raise InputError("--connections applies to a structure record (channels z1, z2, ...), not to one DOF")

    def status(message: str) -> None:
        if not args.quiet:
            print(f"nlid discover: {message}", file=sys.stderr, flush=True)

    mass = mass_argument(args.mass)
    settings = dict(
        mass=None if mass == ESTIMATE else mass,
        holdout=_holdout(args),
        validation=None
        if not args.validation
        else load_data(argparse.Namespace(data=args.validation, columns=args.columns, fs=args.fs, units=args.units)),
        candidates=args.candidates,
        extra_candidates=args.candidate or (),
        accept=rule,
        max_steps=args.max_steps,
        cutoff=args.cutoff,
        options=parse_settings(args.set),
        views=bool(args.out),
        refine=bool(args.refine),
        freerun_rule=args.rule,
        prediction=prediction,
    )
    with plugin_warnings("discover"):
        # progress only on a terminal (never when piped, under --quiet or with --json)
        show = not (args.quiet or args.json) and stderr_is_terminal()
        result = _discover_isolated(timeout, record, args.declared, args.method, settings, show)
    if args.out:
        paths = _written(write_report, result, args.out, force=args.force)
        status(f"report written to {paths[1]} (and {paths[0].name})")
    if args.json:
        print_json(result.to_dict())
    else:
        print(result.summary())
        if result.refined is not None:
            print(_refined_lines(result))
    from ..identified.plausibility import headline

    return untrusted("discover", headline(result.final.identified.flags))


def _refined_lines(result) -> str:
    """What the refinement (by a refining identifier, e.g. oe) changed: free-run errors before and after, terms."""
    from ..discovery.report import freerun_rules

    unit = result.info.get("units", {}).get("z", "")
    before, after = result.final, result.refined

    def fmt(x):
        return "n/a" if x is None else f"{x:.4g} {unit}"

    refiner = after.identified.method
    lines = ["", f"refined with {refiner} (output error on the free run, started from {result.method}):"]
    if result.info.get("refined_on"):
        lines.append(f"  fitted on {result.info['refined_on']}")
    lines += [f"  {line}" for line in freerun_rules(result)]
    lines.append(f"  free-run RMS error held-out: {fmt(before.sim_rms_holdout)} -> {fmt(after.sim_rms_holdout)}")
    if before.validation is not None:
        lines.append(
            f"  free-run RMS error validation: {fmt(before.sim_rms_validation)} -> {fmt(after.sim_rms_validation)}"
        )
    if after.holdout.freerun_note and after.holdout.freerun_note != "not computed":
        lines.append(f"  ({after.holdout.freerun_note})")
    fit = after.identified
    se = fit.standard_errors or {}
    for name in fit.terms:
        err = f"  +/- {se[name]:.3g}" if se.get(name) is not None else ""
        lines.append(f"  {name:<28} {fit.coefficients[name]:14.6g}{err}")
    if fit.mass_estimated:
        lines.append(f"  mass {fit.mass:.6g} kg")
    return "\n".join(lines)


def _written(write: Any, result: Any, out: str, **options: Any) -> list:
    """The files a report writer wrote into ``out``; a folder that cannot be written is one line (exit 2)."""
    try:
        return write(result, out, **options)
    except OSError as exc:
        raise InputError(f"cannot write the report to {out}: {exc.strerror or exc}") from None


def _run_structure(args: argparse.Namespace, record, rule) -> int:
    """``nlid discover`` on a structure record: which connection carries the missing element."""
    from ..discovery.structure import discover_structure
    from ..discovery.structure_result import write_structure_report

    unsupported = [
        flag
        for flag, value in (
            ("--method", args.method),
            ("--validation", args.validation),
            ("--rule", args.rule),
            ("--set", args.set),
        )
        if value
    ]
    if unsupported:
        raise InputError(
            f"{unsupported[0]} does not apply to a structure record (every DOF is fitted by one joint least "
            "squares, rfs's)"
        )
    holdout = _holdout(args)
    if not isinstance(holdout, float):
        raise InputError("--holdout for a structure record is a fraction")

    def say(message: str) -> None:
        if not (args.quiet or args.json):
            print(f"nlid discover: {message}", file=sys.stderr, flush=True)

    result = discover_structure(
        record,
        args.declared,
        mass=mass_argument(args.mass),
        holdout=holdout,
        connections=args.connections,
        candidates=args.candidates,
        extra_candidates=args.candidate or (),
        accept=rule,
        max_steps=args.max_steps,
        cutoff=args.cutoff,
        progress=say,
        refine=args.refine,
        prediction=not args.no_prediction,
    )
    if args.out:
        paths = _written(write_structure_report, result, args.out)
        say(f"report written to {paths[0]} (and {paths[1].name})")
    if args.json:
        print_json(result.to_dict())
    else:
        print(result.summary())
    return 0
