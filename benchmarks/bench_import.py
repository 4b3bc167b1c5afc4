"""Start-up time of ``import nlid`` and ``nlid --help`` (issue 14: <= 0.4 s / <= 0.3 s).

Each case runs in a fresh interpreter (``sys.executable``, not a pyenv shim:
the shim alone costs ~0.13 s) ``--repeat`` times; the median wall time of the
whole process is printed with the 1-minute load average, next to the bare
interpreter (``python -c pass``) and ``import numpy`` measured in the same
interleaved rounds, and the heavy modules each case imported.

    python benchmarks/bench_import.py [--repeat 9] [--subcommands]
    python -X importtime -m nlid.cli.main --help 2> importtime.txt   # where the time goes
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time

#: Modules ``nlid --help`` must not import (checked by tests/cli/test_startup.py too).
HEAVY = ("scipy", "scipy.signal", "pandas", "matplotlib", "numba", "emcee", "pysindy", "sklearn", "dask", "numpy")

_PROBE = (
    "import sys\n"
    "{code}\n"
    "heavy = {heavy!r}\n"
    "sys.stderr.write('HEAVY ' + ','.join(m for m in heavy if m in sys.modules) + '\\n')\n"
)

_CLI = "import sys\nfrom nlid.cli.main import main\ntry:\n    main({argv!r})\nexcept SystemExit:\n    pass\n"


def _time(code: str) -> float:
    start = time.perf_counter()
    subprocess.run([sys.executable, "-c", code], check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - start


def _heavy(code: str) -> str:
    out = subprocess.run(
        [sys.executable, "-c", _PROBE.format(code=code, heavy=HEAVY)], capture_output=True, text=True, check=True
    )
    line = [x for x in out.stderr.splitlines() if x.startswith("HEAVY ")]
    return line[-1][6:] if line else "?"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeat", type=int, default=9, help="runs of each case (default 9)")
    parser.add_argument("--subcommands", action="store_true", help="also time 'nlid COMMAND --help' for every command")
    args = parser.parse_args()
    cases = {
        "python -c pass": "pass",
        "import numpy": "import numpy",
        "import nlid": "import nlid",
        "nlid --help": _CLI.format(argv=["--help"]),
    }
    if args.subcommands:
        for command in ("study", "identify", "discover", "posterior", "simulate", "methods", "terms", "data"):
            cases[f"nlid {command} --help"] = _CLI.format(argv=[command, "--help"])
    times: dict[str, list[float]] = {name: [] for name in cases}
    loads = []
    for _ in range(args.repeat):  # interleaved rounds: load changes hit every case alike
        loads.append(os.getloadavg()[0])
        for name, code in cases.items():
            times[name].append(_time(code))
    print(f"{sys.executable}, {args.repeat} runs each, 1-min load {min(loads):.1f}-{max(loads):.1f}")
    for name, code in cases.items():
        t = times[name]
        heavy = _heavy(code) if name.startswith(("import nlid", "nlid")) else ""
        print(
            f"  {name:28s} median {statistics.median(t):.3f} s (min {min(t):.3f}, max {max(t):.3f})"
            + (f"  heavy: {heavy or 'none'}" if name.startswith(("import nlid", "nlid")) else "")
        )


if __name__ == "__main__":
    main()
