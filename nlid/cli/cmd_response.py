"""``nlid response``: what an identified model predicts, its nonlinear frequency response by harmonic balance."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from ..errors import InputError
from .common import add_model_arguments, identify_options, print_json

DESCRIPTION = """\
The periodic response of a model to F cos(2 pi f t), continued in frequency over a band for each force
amplitude F (harmonic balance with H harmonics and a constant term, pseudo-arclength continuation,
stability by Hill's method). Prints the curves, their turning points (where a slow sweep jumps) and the
backbones of the conservative part; by default also checks sampled points against long time integration.

The model is an 'nlid identify --json' (or structure) file, the result.json of 'nlid discover --out' (its
final model), or a data file identified first with --terms, --mass and --method as 'nlid identify' does.

--posterior DIR adds the 90 % band over posterior draws (the folder 'nlid posterior --out DIR' wrote, on the
same model); --measured FILE reads a stepped- or swept-sine record, extracts its first-harmonic amplitude per
frequency, and reports the prediction error there (--force and --band then default to the record's).
"""

EPILOG = """\
examples:
  nlid simulate --preset paper-numerical --seed 0 --channels v,a --out x.csv
  nlid identify x.csv --terms "z^3,z^2,v*|v|" --mass 0.2 --json > model.json
  nlid response model.json --force 0.5,1,2 --band 4:20
  nlid simulate --preset paper-numerical-stepped --out stepped.csv
  nlid response model.json --measured stepped.csv --out resp/
"""


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "response",
        help="the nonlinear frequency response a model predicts (harmonic balance, continuation, jumps)",
        description=DESCRIPTION,
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("source", metavar="MODEL.json|DATA", help="an identified model (JSON) or a data file to identify")
    p.add_argument("--force", metavar="N,...", help="force amplitudes in N, e.g. 0.5,1,2 (default: the measured one)")
    p.add_argument("--band", metavar="LOW:HIGH", help="frequency band in Hz, e.g. 5:30 (default: the measured one)")
    p.add_argument("--harmonics", type=int, default=7, metavar="H", help="number of harmonics (default 7)")
    p.add_argument("--dof", type=int, metavar="K", help="the DOF the force acts on, for a structure (default 1)")
    p.add_argument("--no-verify", action="store_true", help="do not check points against time integration")
    p.add_argument("--sweep-rate", type=float, metavar="HZ/S", help="also simulate sweeps up and down at this rate")
    p.add_argument("--no-backbone", action="store_true", help="do not compute the backbones")
    p.add_argument("--posterior", metavar="DIR", help="the folder (or posterior.json) of 'nlid posterior --out'")
    p.add_argument("--draws", type=int, default=100, metavar="N", help="posterior draws for the band (default 100)")
    p.add_argument("--jobs", type=int, metavar="N", help="processes for the posterior draws (default: every core)")
    p.add_argument("--measured", metavar="FILE", help="a stepped- or swept-sine record to score the prediction on")
    p.add_argument("--measured-columns", metavar="MAP", help="column map of the measured record, e.g. 'f=F,z=x'")
    p.add_argument("--measured-fs", type=float, metavar="HZ", help="sampling frequency of the measured record")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of the tables")
    p.add_argument("--out", metavar="DIR", help="write response.json, .csv, .md, .png (and measured.csv) there")
    add_model_arguments(p, "identifier, when the source is data (default: the preferred installed one)")
    p.set_defaults(func=run)


def _model(args: argparse.Namespace):
    """The identified model: read from JSON, or identified from data."""
    path = Path(args.source)
    if path.suffix.lower() == ".json":
        try:
            data = json.loads(path.read_text())
        except json.JSONDecodeError as exc:
            raise InputError(f"{path} is not JSON ({exc.msg} at line {exc.lineno})") from None
        if isinstance(data, dict) and isinstance(data.get("final_model"), dict):  # an 'nlid discover' result
            data = data["final_model"]
        schema = str(data.get("schema", "")) if isinstance(data, dict) else ""
        if schema.startswith("nlid.IdentifiedStructure"):
            from ..identified.structure import IdentifiedStructure

            return IdentifiedStructure.from_dict(data)
        from ..identified.model import IdentifiedModel

        return IdentifiedModel.from_dict(data)
    from ..api import load
    from ..identification.pipeline import identify

    # the terms are parsed by identify on the record's DOFs: a one-DOF model or a structure's elements
    return identify(load(args.source), args.terms, args.method, **identify_options(args))


def run(args: argparse.Namespace) -> int:
    from ..response import frequency_response
    from ..response.bands import load_posterior
    from ..response.fitted import as_fitted
    from ..response.measured import measure

    measured = None
    if args.measured:
        from ..api import load

        measured = measure(load(args.measured, columns=args.measured_columns, fs=args.measured_fs))
    if args.force is None and measured is None:
        raise InputError("give --force (amplitudes in N) or a --measured record to take it from")
    if args.band is None and measured is None:
        raise InputError("give --band LOW:HIGH (Hz) or a --measured record to take it from")
    force = args.force if args.force is not None else [round(float(sorted(measured.force)[len(measured) // 2]), 6)]
    band = (
        args.band if args.band is not None else (float(measured.frequency_hz.min()), float(measured.frequency_hz.max()))
    )
    fit = _model(args)
    resp = frequency_response(fit, force, band, harmonics=args.harmonics, dof=args.dof, backbone=not args.no_backbone)
    if not args.no_verify:
        resp = resp.verify(sweep_rate=args.sweep_rate)
    if args.posterior:
        resp = resp.with_posterior(load_posterior(args.posterior, as_fitted(fit)), draws=args.draws, jobs=args.jobs)
    if measured is not None:
        resp = resp.compare(measured)
    if args.out:
        try:
            paths = resp.save(args.out)
        except InputError as exc:
            raise InputError(str(exc).replace("give force=True to write beside them", "remove them")) from None
        print(f"wrote {', '.join(str(p) for p in paths)}", file=sys.stderr)
    if args.json:
        print_json(resp.to_dict())
    else:
        print(resp.summary())
    return 0
