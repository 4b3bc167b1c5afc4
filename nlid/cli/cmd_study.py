"""``nlid study``: run benchmark studies and list the built-in ones."""

from __future__ import annotations

import argparse
import io
import signal
import sys
from pathlib import Path

from .common import print_json
from .isolated import parse_timeout

DESCRIPTION = """\
Run a benchmark study: every identifier of the study on the same data
(datasets x models x identifiers x repetitions), in parallel, with each
finished run saved at once. Running the same study again skips finished runs
(--rerun to redo them), so an interrupted study resumes where it stopped.
Outputs in the study folder: results.csv (one row per run), summary.md
(the verdict, then method x metric tables), summary.txt (the same for a
terminal, printed at the end), figures/ (PNG and SVG) and a self-contained
report.html.
"""

EPILOG = """\
examples:
  nlid study list
  nlid study run paper-numerical
  nlid study run my-study.toml --out results/my-study --jobs 4
  nlid study run noise-sweep --executor dask                  # a Dask LocalCluster
  nlid study run noise-sweep --executor dask --scheduler tcp://host:8786
"""


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "study",
        help="run benchmark studies that score every identifier on the same data",
        description=DESCRIPTION,
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    actions = p.add_subparsers(dest="study_command", metavar="ACTION", parser_class=type(p))
    run = actions.add_parser(
        "run",
        help="run a study (built-in name or .toml file) and print its summary",
        description=DESCRIPTION,
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    run.add_argument("study", metavar="NAME|PATH", help="a built-in study (see 'nlid study list') or a .toml file")
    run.add_argument("--out", metavar="DIR", help="output folder (default: nlid-studies/NAME in the current folder)")
    run.add_argument(
        "--executor",
        choices=("local", "dask"),
        default="local",
        help="local: processes on this machine (default); dask: a Dask cluster (needs nlid[dask])",
    )
    run.add_argument(
        "--scheduler",
        metavar="ADDR",
        help="Dask scheduler address; without it --executor dask starts a LocalCluster. Dask sends work as pickles: "
        "a scheduler you do not trust gets code execution on this machine, so name only your own",
    )
    run.add_argument(
        "--jobs",
        type=int,
        metavar="N",
        help="identifications at the same time; with fewer than the cores, a run's scores overlap the next "
        "identification on an idle core (default: every core)",
    )
    run.add_argument("--rerun", action="store_true", help="run everything again, even runs already saved")
    run.add_argument(
        "--force",
        action="store_true",
        help="write into a folder that holds files nlid did not write; nlid never replaces them: if one has the "
        "name of an output (study.toml, runs, arrays, results.csv, summary.md, summary.txt, summary.csv, "
        "report.html, figures), it stops before writing anything, naming it",
    )
    run.add_argument(
        "--timeout",
        metavar="SECONDS",
        help="time limit of each run, which runs in a separate process and is recorded as timed out past it "
        "(default: the study's 'timeout', 600 s unless it sets one; 0 or 'none': no limit)",
    )
    run.add_argument("--no-progress", action="store_true", help="no progress line (it only shows on a terminal)")
    run.add_argument("--quiet", action="store_true", help="no progress line and no status lines on stderr")
    run.add_argument(
        "--json",
        action="store_true",
        help="print the study, its folder and one row per run (results.csv) as JSON instead of the summary",
    )
    run.set_defaults(func=run_command)
    lst = actions.add_parser("list", help="list the built-in studies", description="List the built-in studies.")
    lst.add_argument("--json", action="store_true", help="machine-readable output")
    lst.set_defaults(func=list_command)
    p.set_defaults(func=lambda args: _usage(p))


def _usage(parser: argparse.ArgumentParser) -> int:
    parser.print_help()
    return 0


def _terminate(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


def run_command(args: argparse.Namespace) -> int:
    from ..study import load_study, make_executor, run_study
    from ..study.report import TEXT_SUMMARY

    if args.executor == "local":
        from ..runtime.isolation import start_fork_server

        start_fork_server(pin_threads=True)  # it loads the plugins while this process reads the study
    config = load_study(args.study)
    executor = make_executor(args.executor, jobs=args.jobs, scheduler=args.scheduler)
    out = Path(args.out) if args.out else Path("nlid-studies") / config.name
    quiet = args.quiet or args.json
    previous = signal.signal(signal.SIGTERM, _terminate)  # stop children and keep what is saved
    try:
        outcome = run_study(
            config,
            out,
            executor=executor,
            rerun=args.rerun,
            progress=False if args.no_progress or quiet else None,
            log=_Quiet() if args.quiet else None,
            force=args.force,
            timeout=parse_timeout(args.timeout),
        )
    finally:
        signal.signal(signal.SIGTERM, previous)
    if args.json:
        print_json(outcome.to_dict())
    else:
        # the terminal summary (verdict first, no line over 100 characters); summary.md holds the Markdown
        text = outcome.folder / TEXT_SUMMARY
        print(text.read_text().rstrip("\n") if text.is_file() else outcome.summary)
    if not args.quiet:
        print(
            f"nlid study: {outcome.executed} runs executed, {outcome.skipped} reused; report: {outcome.report}",
            file=sys.stderr,
        )
    return 0


class _Quiet(io.StringIO):
    """The status lines of ``--quiet``: kept, not shown."""

    def isatty(self) -> bool:
        return False


def list_command(args: argparse.Namespace) -> int:
    from ..study import builtin_studies
    from ..study.config import tomllib

    studies = builtin_studies()
    descriptions = {}
    for name, path in studies.items():
        try:
            descriptions[name] = tomllib.loads(path.read_text()).get("study", {}).get("description", "")
        except (OSError, UnicodeDecodeError, RecursionError, tomllib.TOMLDecodeError):
            descriptions[name] = None
    if args.json:
        print_json({"studies": {n: {"description": descriptions[n], "path": str(p)} for n, p in studies.items()}})
        return 0
    if not studies:
        print("no built-in studies found", file=sys.stderr)
        return 0
    width = max(len(n) for n in studies)
    for name in studies:
        description = descriptions[name]
        print(f"{name:<{width}}  {'(unreadable)' if description is None else description}")
    return 0
