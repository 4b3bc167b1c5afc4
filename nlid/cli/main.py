"""``nlid``: the command-line entry point.

Every subcommand lives in its own module with ``add_parser(subparsers)`` and
``run(args) -> int``. Errors nlid raises on purpose become one line on stderr:
exit status 2 for bad input (file, term, option, unknown method, broken
plugin) and for a file or folder that cannot be read or written, 1 when an
identification ran but cannot be trusted. numpy's runtime warnings become one
warning line. Every such line is one line whatever the message holds: line breaks
are escaped and a runaway message is cut (:func:`nlid.errors.one_line`) - the last
resort behind the capped values of the messages themselves. An error nlid did not
foresee (a bug) is one line too, ``internal error: ...``, with exit status 1 (as
Python's own). ``--debug`` shows the traceback and the raw warnings instead.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from .. import __version__
from ..errors import IdentificationError, NlidError, describe_exception, one_line
from . import (
    cmd_bench,
    cmd_compare,
    cmd_data,
    cmd_discover,
    cmd_identify,
    cmd_methods,
    cmd_posterior,
    cmd_response,
    cmd_simulate,
    cmd_study,
    cmd_terms,
)
from .common import Parser, describe_os_error, to_cli

__all__ = ["main", "build_parser", "COMMANDS"]

#: Subcommand modules, in the order ``nlid --help`` lists them.
COMMANDS = (
    cmd_study,
    cmd_bench,
    cmd_identify,
    cmd_compare,
    cmd_discover,
    cmd_posterior,
    cmd_response,
    cmd_simulate,
    cmd_methods,
    cmd_terms,
    cmd_data,
)

DESCRIPTION = """\
Identify the nonlinear stiffness and friction of a vibrating structure from
measured force and motion.

Models are lists of terms of the restoring force R(z, v) = f - m z''
(see 'nlid terms'); identification methods are plugins (see 'nlid methods').

examples:
  nlid study run paper-numerical
  nlid simulate --preset paper-numerical --seed 0 --channels v,a --out x.csv
  nlid identify x.csv --method rfs --terms "z^3,z^2,v*|v|" --mass 0.2
  nlid identify dataset:emps --method rfs --terms "sign(v)" --without z
  nlid compare x.csv --methods rfs,sindy --terms "z^3,z^2,v*|v|" --mass 0.2
  nlid discover dataset:emps --declared "v, 1"
  nlid posterior x.csv --terms "z^3,z^2,v*|v|" --mass 0.2 --params damping
  nlid response model.json --force 0.5,1,2 --band 4:20   # a model's nonlinear frequency response
  nlid data                       # the measured benchmarks: where to get them, which files are here
"""


def build_parser() -> Parser:
    """The full argument parser."""
    parser = Parser(prog="nlid", description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action="version", version=f"nlid {__version__}")
    parser.add_argument("--debug", action="store_true", help="show tracebacks instead of one-line errors")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)
    for module in COMMANDS:
        module.add_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 0
    _say_compiling(args)
    if args.debug:
        return int(args.func(args) or 0)
    from ..base.numerics import collect_warnings, describe_warnings  # numpy: not for --help

    try:
        with collect_warnings() as numerical:
            status = int(args.func(args) or 0)
    except NlidError as exc:
        status = 1 if isinstance(exc, IdentificationError) else 2
        print(f"nlid {args.command}: error: {one_line(to_cli(str(exc)))}", file=sys.stderr)
        return status
    except OSError as exc:  # a file or folder the command reads or writes, whatever path it took
        print(f"nlid {args.command}: error: {one_line(describe_os_error(exc))}", file=sys.stderr)
        return 2
    except MemoryError:
        print(f"nlid {args.command}: error: not enough memory (try a shorter record or fewer samples)", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("nlid: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # noqa: BLE001 - the last resort: an error nlid did not foresee is a bug, still one line
        what = one_line(describe_exception(exc))
        print(
            f"nlid {args.command}: internal error: {what} (a bug: rerun with --debug for the traceback, and report it)",
            file=sys.stderr,
        )
        return 1
    if numerical:
        print(
            f"nlid {args.command}: warning: {one_line(f'numerical warnings: {describe_warnings(numerical)}')}",
            file=sys.stderr,
        )
    return status


#: The commands that simulate (and so run numba's compiled kernels).
SIMULATING = frozenset({"identify", "compare", "discover", "posterior", "simulate", "response", "study", "bench"})


def _say_compiling(args: argparse.Namespace) -> None:
    """On a terminal, before a command that simulates: say that the first run compiles the kernels."""
    if args.command not in SIMULATING or getattr(args, "quiet", False) or getattr(args, "json", False):
        return
    from ..runtime.compilation import COMPILING_NOTE, cold_kernels
    from ..runtime.progress import stderr_is_terminal

    if stderr_is_terminal() and cold_kernels():
        print(f"nlid {args.command}: {COMPILING_NOTE}", file=sys.stderr, flush=True)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
