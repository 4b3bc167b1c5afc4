"""``nlid identify``: identify a model's coefficients from a record."""

from __future__ import annotations

import argparse

from ..runtime.progress import showing
from .common import (
    add_data_arguments,
    add_model_arguments,
    identify_options,
    load_data,
    print_json,
    untrusted,
    with_wall_time,
)
from .isolated import IDENTIFY_TIMEOUT, add_timeout_argument, parse_timeout, plugin_warnings


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "identify",
        help="identify the coefficients of a model from a record",
        description="Identify the coefficient of every term of R(z, v) = f - m z'' from a record. The terms "
        "1 (static load), z and v (underlying-linear system) are always included unless removed with "
        "--without; list the others with --terms. See 'nlid terms' for the language and 'nlid methods' for "
        "the methods and their options.",
        epilog="examples: nlid identify x.csv --method rfs --terms 'z^3,z^2,v*|v|' --mass 0.2; "
        "nlid identify chain.csv --method rfs --terms '(z2-z3)^3' --mass 'diag(1,1,2)'",
    )
    add_data_arguments(p)
    add_model_arguments(p, "identifier to use (default: the installed one with the best preference; see nlid methods)")
    add_timeout_argument(p, IDENTIFY_TIMEOUT, "the identifier")
    p.add_argument(
        "--input-path",
        metavar="SPEC",
        help="what happens to the force before it acts, e.g. 'delay=3ms', 'lag=2 samples', 'hold=zoh' "
        "(comma-separated; units s, ms, us or samples): the model keeps it and every score applies it",
    )
    p.add_argument("--json", action="store_true", help="print one JSON object instead of a table")
    p.add_argument(
        "--quiet", action="store_true", help="no progress on stderr (it is shown only on a terminal, never with --json)"
    )
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..runtime.isolation import start_fork_server

    timeout = parse_timeout(args.timeout)

    start_fork_server(pin_threads=False)  # it loads the pipeline while this process reads the data
    from ..identification.pipeline import identify

    record = load_data(args)
    path = None
    if args.input_path is not None:
        from ..estimation.inputpath import InputPath

        path = InputPath.from_spec(args.input_path, getattr(record, "fs", None))
    # a long identifier (oe) shows its progress on a terminal, never under --quiet or --json
    with plugin_warnings("identify"), showing(not (args.quiet or args.json)):
        result = identify(record, args.terms, args.method, **identify_options(args), timeout=timeout, input_path=path)
    from ..identified.plausibility import headline

    if args.json:
        print_json(result.to_dict())
    else:
        print(with_wall_time(str(result.summary()), "identification"))
    return untrusted("identify", headline(result.flags))
