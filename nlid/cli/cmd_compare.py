"""``nlid compare``: several methods on one record, one tidy table (the twin of :func:`nlid.compare`)."""

from __future__ import annotations

import argparse
import json
import math
from typing import Any

from ..errors import DataError, InputError, brief
from ..runtime.progress import showing
from .common import (
    add_data_arguments,
    add_term_arguments,
    load_data,
    mass_argument,
    parse_px_roots,
    parse_settings,
    print_json,
    untrusted,
)

DESCRIPTION = """\
Identify one model with several methods on one record and print one table:
per method its coefficients (with standard errors), mass, stable equilibria,
natural frequencies and damping ratios against the reference, and with
--holdout epsilon, the force residual and the free-run error on held-out
data. The reference is the record's own (a simulated record carries its
truth, a measured benchmark its published values) unless --reference names
one. A method that fails gets one row saying why (--errors raise: stop).
By default every installed method runs except the refining ones (oe): add
them with --methods.
"""

EPILOG = """\
examples:
  nlid simulate --preset paper-numerical --seed 0 --channels v,a --out x.csv
  nlid compare x.csv --terms "z^3,z^2,v*|v|" --mass 0.2 --methods rfs,sindy
  nlid compare x.csv --terms "z^3,z^2,v*|v|" --mass 0.2 --holdout 0.25 --rule window:50 --json
  nlid compare x.csv --terms "z^3,z^2,v*|v|" --methods rfs,oe --set oe.max_nfev=50 --out table.csv
"""


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "compare",
        help="identify one model with several methods and compare them against the reference",
        description=DESCRIPTION,
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_data_arguments(p)
    p.add_argument(
        "--methods",
        metavar="NAMES",
        help="comma-separated identifiers (default: every installed one except those that refine another's fit, "
        "such as oe, 10-100x slower and left out of the built-in studies too: name it to run it; nlid methods)",
    )
    add_term_arguments(p, "known mass in kg (default: estimated by each method)")
    p.add_argument(
        "--set",
        action="append",
        metavar="METHOD.KEY=VALUE",
        help="an option of one method, e.g. 'oe.max_nfev=50' (repeatable; KEY=VALUE alone when one method is "
        "compared); see nlid methods NAME",
    )
    p.add_argument(
        "--holdout",
        metavar="FILE|FRACTION",
        help="held-out data scored by every method (epsilon, force residual, free-run error): a second record "
        "(file or dataset:NAME, read like DATA) or a fraction of DATA (its last part, whole periods of a periodic "
        "record; the methods are then identified on the rest)",
    )
    p.add_argument(
        "--rule",
        metavar="RULE",
        help="transient rule of the free run on the held-out record: first-sample, window:N, periodic or "
        "periodic:P (default: the record's own)",
    )
    p.add_argument(
        "--reference",
        metavar="FILE.json",
        help="reference values instead of the record's own: the JSON of 'nlid identify --json', "
        '{"coefficients": {...}, "mass": ...} or {"TERM": value, ...}',
    )
    p.add_argument(
        "--errors",
        choices=("record", "raise"),
        default="record",
        help="a failing method: one row saying why (record, default) or stop with its error (raise)",
    )
    p.add_argument("--json", action="store_true", help="print the table as JSON records instead of text")
    p.add_argument(
        "--quiet", action="store_true", help="no progress on stderr (it is shown only on a terminal, never with --json)"
    )
    p.add_argument("--out", metavar="FILE.csv", help="also write the table to a CSV file (not replaced unless --force)")
    p.add_argument("--force", action="store_true", help="replace the --out file if it exists")
    p.set_defaults(func=run)


def parse_method_options(items: list[str] | None, methods: list[str] | None) -> dict[str, dict[str, str]]:
    """``--set METHOD.KEY=VALUE`` (or ``KEY=VALUE`` with one method) as ``{method: {key: value}}``."""
    out: dict[str, dict[str, str]] = {}
    for key, value in parse_settings(items).items():
        method, dot, option = key.partition(".")
        if not dot:
            if methods is None or len(methods) != 1:
                raise InputError(
                    f"--set {brief(key)}: name the method whose option it is, e.g. --set rfs.{key}=VALUE "
                    "(KEY=VALUE alone only when --methods names one method)"
                )
            method, option = methods[0], key
        if not method.strip() or not option.strip():
            raise InputError(f"--set expects METHOD.KEY=VALUE, got {brief(key)}")
        if methods is not None and method.strip() not in methods:
            raise InputError(
                f"--set {brief(key)}: {brief(method.strip())} is not among the methods compared ({', '.join(methods)})"
            )
        out.setdefault(method.strip(), {})[option.strip()] = value
    return out


def _methods(text: str | None) -> list[str] | None:
    if text is None:
        return None
    names = [m.strip() for m in text.split(",") if m.strip()]
    if not names:
        raise InputError("--methods names no method")
    return names


def _holdout(args: argparse.Namespace) -> Any:
    if args.holdout is None:
        return None
    text = str(args.holdout).strip()
    try:
        return float(text)  # checked by nlid.compare (HOLDOUT_FRACTION)
    except ValueError:
        pass
    return load_data(argparse.Namespace(data=text, columns=args.columns, fs=args.fs, units=args.units))


def _reference(path: str | None) -> Any:
    """The ``--reference`` file: a model JSON (rebuilt as the model) or a mapping of reference values."""
    if path is None:
        return None
    from ..data.io import read_text_file
    from ..identified.model import IdentifiedModel
    from ..identified.structure import SCHEMA as STRUCTURE_SCHEMA

    text = read_text_file(path, "reference JSON")
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise DataError(f"--reference {path}: not a JSON file ({exc})") from None
    except RecursionError:
        raise DataError(f"--reference {path}: nested too deeply to be a reference") from None
    if not isinstance(data, dict):
        raise DataError(f"--reference {path}: expected a JSON object, got {type(data).__name__}")
    if data.get("schema") == STRUCTURE_SCHEMA:  # nlid identify --json of a structure
        from ..identified.structure import IdentifiedStructure

        return IdentifiedStructure.from_dict(data)
    if {"terms", "coefficients", "method"} <= set(data):  # nlid identify --json
        return IdentifiedModel.from_dict(data)
    return data


def frame_records(frame: Any) -> list[dict[str, Any]]:
    """The rows of :func:`nlid.compare`'s frame as JSON-ready records (NaN as ``None``)."""
    from ..base.jsonable import to_jsonable

    return to_jsonable(frame.to_dict(orient="records"))


def run(args: argparse.Namespace) -> int:
    from ..api import compare
    from ..runtime.outputs import check_new_file

    methods = _methods(args.methods)
    options = parse_method_options(args.set, methods)
    if args.out:
        if not args.out.lower().endswith(".csv"):
            raise InputError(f"--out must end in .csv, got {args.out!r}")
        check_new_file(args.out, force=args.force)
    reference = _reference(args.reference)
    record = load_data(args)
    with showing(not (args.quiet or args.json)):  # a long identifier (oe) shows its progress on a terminal
        frame = compare(
            record,
            args.terms,
            methods,
            mass=mass_argument(args.mass),
            reference=reference,
            holdout=_holdout(args),
            options=options or None,
            without=args.without,
            px_roots=parse_px_roots(args.px_roots),
            errors=args.errors,
            rule=args.rule,
        )
    if args.out:
        frame.to_csv(args.out, index=False)
    from ..data.forcehold import describe_force_hold

    hold = frame.attrs.get("force_hold") or {"hold": record.force_hold, "source": "default"}
    if args.json:  # every row says the force-hold assumption its models were identified under
        print_json(frame_records(frame))
    else:
        print(format_frame(frame))
        print(f"force between samples: {describe_force_hold(hold['hold'], hold['source'])}")
    from ..identified.plausibility import headline

    flagged = [(name, fit) for name, fit in (frame.attrs.get("models") or {}).items() if getattr(fit, "flags", ())]
    return untrusted("compare", f"{flagged[0][0]}: {headline(flagged[0][1].flags)}" if flagged else "")


def format_frame(frame: Any) -> str:
    """The frame as a text table: one line per row, numbers to 6 significant digits, notes last."""

    def number(x: Any, fmt: str = ".6g") -> str:
        return "" if x is None or (isinstance(x, float) and math.isnan(x)) else format(float(x), fmt)

    header = ["method", "quantity", "name", "value", "+/-", "unit", "reference", "error %"]
    rows = []
    for r in frame.to_dict(orient="records"):
        rows.append(
            [
                str(r["method"]),
                str(r["quantity"]),
                str(r["name"]),
                number(r["value"]),
                number(r["std_error"], ".3g"),
                str(r["unit"] or "") if isinstance(r["unit"], str) else "",
                number(r["reference"]),
                number(r["error_pct"], "+.3g"),
                str(r["note"] or "") if isinstance(r["note"], str) else "",
            ]
        )
    widths = [max([len(h)] + [len(row[i]) for row in rows]) for i, h in enumerate(header)]
    numeric = {3, 4, 6, 7}

    def line(cells: list[str]) -> str:
        text = "  ".join(
            c.rjust(w) if i in numeric else c.ljust(w) for i, (c, w) in enumerate(zip(cells, widths, strict=True))
        )
        return text.rstrip()

    out = [line(header)]
    for row in rows:
        out.append(line(row[:8]) + (f"  ({row[8]})" if row[8] else ""))
    return "\n".join(out)
