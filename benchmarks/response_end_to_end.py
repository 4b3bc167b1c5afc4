"""End to end on the command line (issue 33): a model identified from a broadband record predicts a stepped sine.

1. ``paper-numerical`` with its 60 s random force, 2 % noise on z and a (``nlid simulate``);
2. the declared model ``1, z, z^3, v`` identified on it (``nlid identify --json``), and the model
   ``nlid discover`` finds from that declaration (its ``result.json``: ``z^2`` and ``v*|v|`` added);
3. a stepped-sine test of the same oscillator, 2 N from 4 to 20 Hz and back (``paper-numerical-stepped``);
4. ``nlid response MODEL --measured stepped.csv --json`` for each model (and the truth): the prediction error
   on the stepped-sine points must fall as the model gets better.

    python benchmarks/response_end_to_end.py [--seeds 0,1,2]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

TRUTH = {
    "schema": "nlid.IdentifiedModel/1",
    "method": "truth",
    "terms": ["1", "z", "z^2", "z^3", "v", "v*|v|"],
    "coefficients": {"1": 0.2 * 9.81, "z": -500.0, "z^2": 5e3, "z^3": 1e6, "v": 1.0, "v*|v|": 5.0},
    "mass": 0.2,
}


def nlid(*args: str, out: Path | None = None) -> str:
    """Run ``nlid ARGS``; its stdout (also written to ``out``)."""
    done = subprocess.run([sys.executable, "-m", "nlid.cli.main", *args], capture_output=True, text=True, check=True)
    if out is not None:
        out.write_text(done.stdout)
    return done.stdout


def error(model: Path, stepped: Path) -> tuple[float, str]:
    data = json.loads(nlid("response", str(model), "--measured", str(stepped), "--no-verify", "--json"))
    return data["measured"]["error_percent"], ", ".join(c["labels"][0] for c in data["curves"])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", default="0,1,2")
    args = parser.parse_args()
    print("load {:.1f} {:.1f} {:.1f}".format(*os.getloadavg()))
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        stepped = folder / "stepped.csv"
        nlid("simulate", "--preset", "paper-numerical-stepped", "--out", str(stepped))
        truth = folder / "truth.json"
        truth.write_text(json.dumps(TRUTH))
        print("\n| seed | model | terms | prediction error on the stepped sine |")
        print("|---|---|---|---|")
        t_err, _ = error(truth, stepped)
        print(f"| - | truth | {', '.join(TRUTH['terms'])} | {t_err:.3g} % |")
        for seed in (int(s) for s in args.seeds.split(",")):
            broadband = folder / f"x{seed}.csv"
            nlid(
                "simulate",
                "--preset",
                "paper-numerical",
                "--seed",
                str(seed),
                "--noise",
                "0.02",
                "--channels",
                "a",
                "--out",
                str(broadband),
            )
            declared = folder / f"declared{seed}.json"
            nlid("identify", str(broadband), "--terms", "z^3", "--mass", "0.2", "--json", out=declared)
            found = folder / f"discover{seed}"
            nlid("discover", str(broadband), "--declared", "1, z, z^3, v", "--mass", "0.2", "--out", str(found))
            result = found / "result.json"
            terms = json.loads(result.read_text())["final_model"]["terms"]
            d_err, _ = error(declared, stepped)
            f_err, _ = error(result, stepped)
            print(f"| {seed} | declared | {', '.join(json.loads(declared.read_text())['terms'])} | {d_err:.3g} % |")
            print(f"| {seed} | discovered | {', '.join(terms)} | {f_err:.3g} % |", flush=True)
    print("\nload {:.1f} {:.1f} {:.1f}".format(*os.getloadavg()))


if __name__ == "__main__":
    main()
