"""``nlid data``: the measured benchmarks, where they come from, and which files are here and intact."""

from __future__ import annotations

import argparse
import os
import textwrap
from pathlib import Path

from ..base.formatting import TERMINAL_WIDTH, wrap
from ..data.names import PARTS, describe
from .common import print_json

DESCRIPTION = textwrap.fill(
    f"List the measured benchmarks nlid knows ({', '.join(PARTS)}), where each comes from, the folder layout "
    "$NLID_DATA_DIR must have, and check the files that are there against their SHA-256 checksums: each file is "
    "'ok', 'missing' or 'MISMATCH' (a different file, or a corrupt download). Exit status 1 when a checksum does "
    "not match, 0 otherwise (missing files are only reported: use the benchmarks you have). Records are read as "
    f"{describe()}.",
    width=79,
    break_on_hyphens=False,
    break_long_words=False,
)

EPILOG = """\
examples:
  nlid data
  nlid data --dir ~/benchmarks
  nlid data emps --json
"""


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "data",
        help="list the measured benchmarks and check the files in $NLID_DATA_DIR (SHA-256)",
        description=DESCRIPTION,
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("names", nargs="*", metavar="NAME", help="benchmarks to check (default: all)")
    p.add_argument("--dir", metavar="DIR", help="data folder to check (default: $NLID_DATA_DIR)")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..data.datasets import BENCHMARKS, DATA_ENV, check

    folder = Path(args.dir).expanduser() if args.dir else None
    where = str(folder) if folder is not None else os.environ.get(DATA_ENV)
    statuses = check(folder, args.names or None)
    mismatch = sum(s.status == "mismatch" for s in statuses)
    if args.json:
        print_json(
            {
                "folder": where,
                "benchmarks": {
                    name: {
                        "title": b.title,
                        "source": b.source,
                        "citation": b.citation,
                        "loader": f"dataset:{name}" if b.loader else None,
                        "files": [
                            {
                                "path": s.file.path,
                                "status": s.status,
                                "sha256": s.file.sha256,
                                "found_sha256": s.found_sha256,
                            }
                            for s in statuses
                            if s.benchmark == name
                        ],
                    }
                    for name, b in BENCHMARKS.items()
                    if any(s.benchmark == name for s in statuses)
                },
            }
        )
        return 1 if mismatch else 0
    if where is None:
        print(f"{DATA_ENV} is not set: every file is missing. Put the files below in one folder and set {DATA_ENV}.")
    elif not Path(where).expanduser().is_dir():
        print(f"data folder {where} is not a folder: every file is missing.")
    else:
        print(f"data folder: {where}" + ("" if folder is not None else f" (${DATA_ENV})"))
    width = max(len(s.file.path) for s in statuses)
    for name, bench in BENCHMARKS.items():
        mine = [s for s in statuses if s.benchmark == name]
        if not mine:
            continue
        loader = f"read by nlid.load('dataset:{name}')" if bench.loader else "no loader yet"
        print()
        print(wrap(f"{name}: {bench.title}", TERMINAL_WIDTH, subsequent="  "))
        print(wrap(f"source: {bench.source}; {loader}", TERMINAL_WIDTH, indent="  ", subsequent="    "))
        print(wrap(f"cite: {bench.citation}", TERMINAL_WIDTH, indent="  ", subsequent="    "))
        for s in mine:
            status = {"ok": "ok", "missing": "missing", "mismatch": "MISMATCH"}[s.status]
            print(f"  {status:<9} {s.file.path:<{width}}  SHA-256 {s.file.sha256[:12]}...")
            print(wrap(s.file.content, TERMINAL_WIDTH, indent=" " * 12, subsequent=" " * 12))
            if s.status == "mismatch":
                print(f"            expected SHA-256 {s.file.sha256}")
                print(f"            found    SHA-256 {s.found_sha256}")
    counts = {k: sum(s.status == k for s in statuses) for k in ("ok", "missing", "mismatch")}
    print(
        f"\n{len(statuses)} files: {counts['ok']} ok, {counts['missing']} missing, "
        f"{counts['mismatch']} checksum mismatch(es)"
    )
    return 1 if mismatch else 0
