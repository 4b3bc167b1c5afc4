"""``nlid simulate``: write a record simulated from a preset."""

from __future__ import annotations

import argparse
import sys

from ..base.validate import DURATION, check_noise
from ..errors import InputError, brief
from ..runtime.outputs import check_new_file
from ..simulation.presets import PRESETS, RESPONSE_CHANNELS, get_preset
from .common import parse_settings, print_json

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
        default="0",
        metavar="F|CH=F,...",
        help="measurement noise on every written response channel, as a fraction of its standard deviation "
        "(0.02 = 2 %%; the force stays clean), or per channel: z=0.02,a=0.01",
    )
    p.add_argument("--duration", type=float, metavar="S", help="record length in s (default: the preset's)")
    p.add_argument(
        "--channels",
        default="",
        metavar="z,v,a",
        help="response channels to write besides the force: z (always written), v and/or a",
    )
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
    p.add_argument("--json", action="store_true", help="print what was written (path, channels, samples...) as JSON")
    p.set_defaults(func=run)


def parse_noise(text: str) -> float | dict[str, float]:
    """``--noise``: one fraction for every response channel (``0.02``) or ``z=0.02,a=0.01`` (as ``noise=``)."""
    text = str(text).strip()
    try:
        return float(text)
    except ValueError:
        pass
    levels: dict[str, float] = {}
    for item in text.split(","):
        channel, sep, value = item.partition("=")
        try:
            levels[channel.strip()] = float(value)
        except ValueError:
            sep = ""
        if not sep or not channel.strip():
            raise InputError(f"--noise expects a fraction or CHANNEL=FRACTION,... (z=0.02,a=0.01), got {brief(text)}")
    return levels


def simulation_summary(record, path: str | None = None) -> dict:
    """What ``nlid simulate --json`` prints about the record it wrote (and :func:`nlid.simulate` returns)."""
    meta = record.meta
    return {
        "path": path,
        "format": None if path is None else path.rsplit(".", 1)[-1].lower(),
        "preset": meta.get("preset"),
        "seed": meta.get("seed"),
        "noise": dict(meta.get("noise") or {}),
        "channels": [c for c in ("t", *record.channels) if c == "t" or record.is_measured(c)],
        "samples": int(record.n),
        "fs": float(record.fs),
        "duration": record.n / record.fs,
        "force_hold": meta.get("force_hold"),
        "source": meta.get("source"),
        "reference": meta.get("reference"),
    }


def run(args: argparse.Namespace) -> int:
    from ..data.io import write_csv, write_npz

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
    # the channel rule of nlid.simulate(channels=): z, v, a (z is always recorded)
    channels = tuple(dict.fromkeys(("z", *(c.strip() for c in args.channels.split(",") if c.strip()))))
    for c in channels:
        if c not in RESPONSE_CHANNELS:
            raise InputError(f"--channels: unknown channel {brief(c)}; choose from {', '.join(RESPONSE_CHANNELS)}")
    noise = parse_noise(args.noise)
    check_noise(noise, channels, name="--noise")  # the rule of nlid.simulate(noise=), named as the flag
    out = args.out
    if not out.lower().endswith((".csv", ".npz")):
        raise InputError(f"--out must end in .csv or .npz, got {out!r}")
    check_new_file(out, force=args.force)
    record = preset.simulate(args.seed, noise=noise, channels=channels)
    try:
        if out.lower().endswith(".csv"):
            write_csv(record, out, ("f", *channels))
        else:
            write_npz(record, out)
    except OSError as exc:
        raise InputError(f"cannot write {out}: {exc.strerror or exc}") from None
    if args.json:
        print_json(simulation_summary(record, out))
    else:
        print(f"wrote {record.n} samples at {record.fs:g} Hz to {out} ({record.meta['source']})", file=sys.stderr)
    return 0
