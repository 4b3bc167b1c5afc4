"""``nlid simulate``: write a record simulated from a preset."""

from __future__ import annotations

import argparse
import sys

from ..errors import InputError
from ..outputs import check_new_file
from ..presets import PRESETS, get_preset
from ..validate import DURATION, NOISE_FRACTION
from .common import parse_settings

_FIELDS = {"mass": float, "force_rms": float, "fs": float, "duration": float, "g": float}


def add_parser(sub: argparse._SubParsersAction) -> None:
    presets = "; ".join(f"{p.name}: {p.description}" for p in PRESETS.values())
    p = sub.add_parser(
        "simulate",
        help="simulate a preset and write it to CSV or NPZ",
        description="Simulate m z'' + R(z, z') = f with a preset's model and random force, and write t, f, z "
        "(and v, a with --channels); a structure's preset writes f1, z1, z2... for its DOFs. "
        f"Presets: {presets}.",
    )
    p.add_argument("--preset", required=True, metavar="NAME", help="preset name (" + ", ".join(PRESETS) + ")")
    p.add_argument("--seed", type=int, default=0, help="seed of the force and the noise (default 0)")
    p.add_argument(
        "--noise",
        type=float,
        default=0.0,
        help="measurement noise on every written response channel, as a fraction of its standard deviation "
        "(0.02 = 2 %%; the force stays clean)",
    )
    p.add_argument("--duration", type=float, metavar="S", help="record length in s (default: the preset's)")
    p.add_argument("--channels", default="", metavar="v,a", help="extra response channels to write: v and/or a")
    p.add_argument(
        "--set",
        action="append",
        metavar="KEY=VALUE",
        help="override a preset parameter (mass, force_rms, fs, g) or a coefficient (e.g. --set 'z^3=8e5')",
    )
    p.add_argument(
        "--out", required=True, metavar="FILE", help="output file, .csv or .npz (not replaced unless --force)"
    )
    p.add_argument("--force", action="store_true", help="replace the output file if it exists")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..io import write_csv, write_npz

    preset = get_preset(args.preset)
    overrides: dict = {}
    coefficients = {}
    for key, value in parse_settings(args.set).items():
        try:
            number = float(value)
        except ValueError:
            raise InputError(f"--set {key}: expected a number, got {value!r}") from None
        if key in _FIELDS:
            overrides[key] = number
        else:
            coefficients[key] = number
    if coefficients:
        overrides["coefficients"] = coefficients
    if args.duration is not None:
        overrides["duration"] = DURATION.check(args.duration, "--duration")
    if overrides:
        preset = preset.with_overrides(**overrides)
    extra = tuple(c.strip() for c in args.channels.split(",") if c.strip())
    for c in extra:
        if c not in ("v", "a"):
            raise InputError(f"--channels: unknown channel {c!r}; choose from v, a")
    NOISE_FRACTION.check(args.noise, "--noise")
    out = args.out
    if not out.lower().endswith((".csv", ".npz")):
        raise InputError(f"--out must end in .csv or .npz, got {out!r}")
    check_new_file(out, force=args.force)
    record = preset.simulate(args.seed, noise=args.noise, channels=("z", *extra))
    try:
        if out.lower().endswith(".csv"):
            write_csv(record, out, ("f", "z", *extra))
        else:
            write_npz(record, out)
    except OSError as exc:
        raise InputError(f"cannot write {out}: {exc.strerror or exc}") from None
    print(f"wrote {record.n} samples at {record.fs:g} Hz to {out} ({record.meta['source']})", file=sys.stderr)
    return 0
