"""``nlid bench``: pipelines on the measured benchmarks under their protocols, and the leaderboard."""

from __future__ import annotations

import argparse
import io
import signal
import sys

from ..errors import InputError, brief
from .common import print_json, to_cli

DESCRIPTION = """\
Run nlid's pipelines on the measured benchmarks under each benchmark's declared
protocol (nlid/benchmarking/protocols/*.toml, or your own benchmark file): every
pipeline sees only the estimation part (discover takes its hold-out from its end;
the final model is refitted on all of it), then every test set is scored under its
transient rule (initialisation window, periodic steady state, from the first
sample). Jobs run in their own processes (local or Dask), are saved as they finish,
and a second run resumes. Writes leaderboard.csv, leaderboard.md, a sortable
self-contained leaderboard.html, a figure per test set (figures/) and bench.json:
nlid's rows beside the peers' (pysindy, sysidentpy, a linear state space), the
verified published figures and the true model where it is known, each row saying
what it knew (mass, terms, shape given; discovered; a library; a black box).
"""

EPILOG = """\
pipelines (--pipeline, comma-separated): any installed identifier (rfs, sindy, oe...),
  linear (the default identifier on the declared model's linear terms), discover, discover-refine
  (discover, then refined by oe: "discover --refine" works too), the peers pysindy, sysidentpy
  (polynomial NARX; pip install sysidentpy) and linear-ss (a linear state space, output error),
  and truth (the benchmark's own model, where its file declares it).

benchmarks (--benchmark, comma-separated): emps, emps-internal, silverbox, bouc-wen, or a
  .toml benchmark file; 'nlid bench --list' shows their test sets and rules.

examples:
  nlid bench                                        # emps-internal, silverbox, bouc-wen; every pipeline
  nlid bench --benchmark silverbox --pipeline "rfs, discover-refine" --jobs 2 --out out/sb
  nlid bench --benchmark bouc-wen --test-file bouc-wen:multisine=uval_multisine.mat
  nlid bench --benchmark emps --test-file emps:pulses=DATA_EMPS_PULSES.mat
  nlid bench --render-docs --from out/bench         # docs/_data <- out/bench, regenerate the docs pages
"""


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "bench",
        help="run pipelines on the measured benchmarks under their protocols and write a leaderboard",
        description=DESCRIPTION,
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "--benchmark",
        action="append",
        metavar="NAMES",
        help="benchmarks (comma-separated or repeated; default emps-internal, silverbox, bouc-wen)",
    )
    p.add_argument(
        "--pipeline",
        action="append",
        metavar="NAMES",
        help="pipelines (comma-separated or repeated; default: the default identifier of nlid methods, "
        "rfs with the built-in plugins, then linear, discover, discover-refine, pysindy, sysidentpy, linear-ss, truth)",
    )
    p.add_argument("--out", metavar="DIR", default="nlid-bench", help="output folder (default: nlid-bench)")
    p.add_argument("--jobs", type=int, metavar="N", help="jobs at the same time (default: every core)")
    p.add_argument("--executor", choices=("local", "dask"), default="local", help="local processes (default) or Dask")
    p.add_argument(
        "--scheduler",
        metavar="ADDR",
        help="Dask scheduler address (default: a LocalCluster). Dask sends work as pickles: a scheduler you do not "
        "trust gets code execution on this machine, so name only your own",
    )
    p.add_argument(
        "--source",
        choices=("auto", "local", "package"),
        default="auto",
        help="data from $NLID_DATA_DIR (checksummed) else the nonlinear-benchmarks package (auto, the default), "
        "or only one of them",
    )
    p.add_argument(
        "--test-file",
        action="append",
        metavar="BENCHMARK:TEST=PATH",
        help="a user-supplied test set, e.g. bouc-wen:multisine=uval_multisine.mat (repeatable)",
    )
    p.add_argument("--timeout", type=float, default=1800.0, metavar="S", help="seconds before a job is stopped")
    p.add_argument("--rerun", action="store_true", help="run every job again, even those already saved")
    p.add_argument(
        "--force",
        action="store_true",
        help="write into a folder that holds files nlid did not write (never replacing them)",
    )
    p.add_argument("--json", action="store_true", help="print the leaderboard rows as JSON")
    p.add_argument("--no-progress", action="store_true", help="no progress line (it only shows on a terminal)")
    p.add_argument("--quiet", action="store_true", help="no progress line and no status lines on stderr")
    p.add_argument(
        "--list", action="store_true", help="list the built-in benchmarks, their test sets and rules (with --json too)"
    )
    p.add_argument(
        "--render-docs",
        action="store_true",
        help="regenerate the benchmark sections of the docs from DOCS/_data (with --from DIR: copy DIR's "
        "leaderboard.csv and bench.json there first)",
    )
    p.add_argument("--from", dest="source_dir", metavar="DIR", help="with --render-docs: an nlid bench output folder")
    p.add_argument("--docs", metavar="DIR", default="docs", help="with --render-docs: the docs folder (default docs)")
    p.set_defaults(func=run)


def _split(values: list[str] | None, flag: str) -> list[str] | None:
    """The names of a repeatable comma-separated flag; ``None`` when it is not given, refused when it names none."""
    if values is None:
        return None
    names = [item.strip() for value in values for item in value.split(",") if item.strip()]
    if not names:
        raise InputError(f"{flag} names nothing (got {brief(','.join(values), 40)}); leave it out for the default")
    return names


def _files(items: list[str] | None) -> dict[str, str]:
    out: dict[str, str] = {}
    for item in items or ():
        key, sep, path = item.partition("=")
        if not sep or ":" not in key or not path.strip():
            raise InputError(f"--test-file expects BENCHMARK:TEST=PATH, got {item!r}")
        out[key.strip()] = path.strip()
    return out


def benchmark_list() -> dict[str, dict]:
    """The built-in benchmarks, their estimation parts, test sets and rules (``nlid bench --list [--json]``)."""
    from ..benchmarking import builtin_benchmarks, load_protocol

    out = {}
    for name in builtin_benchmarks():
        p = load_protocol(name)
        out[name] = {
            "title": p.title,
            "official": bool(p.official),
            "unit": p.unit,
            "estimation": p.estimation.description,
            "tests": [
                {"name": t.name, "rule": t.rule, "user_file": t.file is not None, "source": t.source.description}
                for t in p.tests
            ],
        }
    return out


def _list(as_json: bool) -> int:
    benchmarks = benchmark_list()
    if as_json:
        print_json({"benchmarks": benchmarks})
        return 0
    for name, b in benchmarks.items():
        kind = "official split" if b["official"] else "nlid's protocol"
        print(f"{name}: {b['title']} ({kind}; RMSE in {b['unit']})")
        print(f"  estimation: {b['estimation']}")
        for t in b["tests"]:
            where = "user file" if t["user_file"] else "local"
            print(f"  test {t['name']}: rule {t['rule']}; {where}; {t['source']}")
    return 0


def _render(args: argparse.Namespace) -> int:
    from .bench_docs import copy_data, render_docs

    # every page is rendered from DIR's files first: nothing of docs/ is replaced unless all of it can be
    pages = render_docs(args.docs, write=False, data=args.source_dir)
    if args.source_dir:
        copied = copy_data(args.source_dir, args.docs)
        print(f"nlid bench: copied {', '.join(str(p) for p in copied)}", file=sys.stderr)
    for path, text in pages.items():
        path.write_text(text, encoding="utf-8")
        print(f"nlid bench: wrote {path}", file=sys.stderr)
    return 0


def _terminate(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


def run(args: argparse.Namespace) -> int:
    if args.list:
        return _list(args.json)
    if args.render_docs:
        return _render(args)
    if args.source_dir:
        raise InputError("--from applies to --render-docs")
    from ..benchmarking import DEFAULT_BENCHMARKS, bench, load_protocol
    from ..benchmarking.leaderboard import markdown_tables

    benchmarks = _split(args.benchmark, "--benchmark") or list(DEFAULT_BENCHMARKS)
    pipelines = _split(args.pipeline, "--pipeline")
    # the protocols by the names the rows carry: a benchmark file of one's own is named by its path, not its name
    protocols = {p.name: p for p in map(load_protocol, benchmarks)}
    if args.executor == "local":
        from ..runtime.isolation import start_fork_server

        start_fork_server()  # it loads the plugins while this process reads the benchmarks
    previous = signal.signal(signal.SIGTERM, _terminate)  # stop children and keep what is saved
    try:
        outcome = bench(
            benchmarks,
            pipelines,
            out=args.out,
            jobs=args.jobs,
            executor=args.executor,
            scheduler=args.scheduler,
            source=args.source,
            files=_files(args.test_file),
            timeout=args.timeout,
            rerun=args.rerun,
            progress=False if args.no_progress or args.quiet or args.json else None,
            log=io.StringIO() if args.quiet else None,
            force=args.force,
        )
    finally:
        signal.signal(signal.SIGTERM, previous)
    if args.json:
        print_json(outcome.rows)
    else:
        shown = {name: protocols[name] for name in dict.fromkeys(r["benchmark"] for r in outcome.rows)}
        print(to_cli("\n".join(markdown_tables(shown, outcome.rows, level=2)).rstrip()))
    if not args.quiet:
        print(
            f"nlid bench: {outcome.executed} job(s) run, {outcome.skipped} reused, {outcome.seconds:.0f} s; "
            f"leaderboard: {outcome.folder / 'leaderboard.md'} (.csv, .html)",
            file=sys.stderr,
        )
    return 0
