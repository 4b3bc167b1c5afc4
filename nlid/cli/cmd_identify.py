"""``nlid identify``: identify a model's coefficients from a record."""

from __future__ import annotations

import argparse

from ..interface import IdentificationResult
from ..pipeline import identify
from ..terms import parse_term
from .common import add_data_arguments, add_model_arguments, load_data, parse_px_roots, parse_settings, print_json


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "identify",
        help="identify the coefficients of a model from a record",
        description="Identify the coefficient of every term of R(z, v) = f - m z'' from a record. The terms "
        "1 (static load), z and v (underlying-linear system) are always included unless removed with "
        "--without; list the others with --terms. See 'nlid terms' for the language and 'nlid methods' for "
        "the methods and their options.",
        epilog="example: nlid identify x.csv --method rfs --terms 'z^3,z^2,v*|v|' --mass 0.2",
    )
    add_data_arguments(p)
    add_model_arguments(p, "identifier to use (default rfs; see nlid methods)")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of a table")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    record = load_data(args)
    result = identify(
        record,
        args.terms,
        args.method,
        mass=args.mass,
        options=parse_settings(args.set),
        without=args.without,
        px_roots=parse_px_roots(args.px_roots),
    )
    if args.json:
        print_json(result.to_dict())
    else:
        print(format_result(result))
    return 0


def format_result(result: IdentificationResult) -> str:
    """A human-readable table of a result."""
    lines = [f"method: {result.method}"]
    if result.mass is not None:
        how = "estimated" if result.mass_estimated else "given"
        lines.append(f"mass: {result.mass:.6g} kg ({how})")
    lines.append("")
    se = result.standard_errors or {}
    width = max(len(t) for t in result.coefficients)
    lines.append(f"{'term':<{width}}  {'coefficient':>14}  {'std. error':>11}  unit")
    for name, value in result.coefficients.items():
        err = f"{se[name]:11.3g}" if se.get(name) is not None else " " * 11
        lines.append(f"{name:<{width}}  {value:14.6g}  {err}  {parse_term(name).coefficient_unit}")
    if result.px_roots:
        lines.append(f"px(z) roots: z- = {result.px_roots[0]:.6g} m, z+ = {result.px_roots[1]:.6g} m")
    if result.equilibria:
        st = ", ".join(f"{z:.6g}" for z in result.equilibria["stable"]) or "none"
        un = ", ".join(f"{z:.6g}" for z in result.equilibria["unstable"]) or "none"
        lines.append("")
        lines.append(f"equilibria (m): stable {st}; unstable {un}")
    for m in result.modal or []:
        lines.append(f"  at z* = {m['equilibrium']:.6g} m: fn = {m['fn_hz']:.4g} Hz, zeta = {100 * m['zeta']:.3g} %")
    lines.append("")
    if result.eps_percent is not None:
        lines.append(
            f"epsilon (Eq. 26): {result.eps_percent:.3g} %   force residual: {result.force_residual_percent:.3g} %"
        )
    if result.seconds is not None:
        lines.append(f"time: {result.seconds:.3g} s")
    for w in result.warnings:
        lines.append(f"warning: {w}")
    return "\n".join(lines)
