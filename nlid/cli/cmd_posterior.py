"""``nlid posterior``: Bayesian posterior of the friction coefficients with emcee."""

from __future__ import annotations

import argparse
import math
import sys

from ..base.validate import NOISE_SD
from ..errors import DataError, InputError, brief
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

DESCRIPTION = """\
Identify a model (as 'nlid identify' does), then sample the posterior of the
chosen coefficients with emcee, starting the walkers from the identified
values. Coefficients that are not sampled are integrated out of the
likelihood (--others marginal, default) or kept at the identified values
(--others fixed).

The likelihood is the error of the force balance f - m a = sum theta_i g_i(z, v)
(Eq. 25), with the noise scale marginalised, the effective number of
independent samples taken from the residual's autocorrelation, the sandwich
covariance of the estimate, and the errors-in-variables bias of regressors
built from a noisy displacement corrected by simulating the identified model
(see docs/posterior.md for what this assumes). Priors default to
normal(0, 10 RMS(f - m a) / RMS(g_i)) per term.

The sampler runs until the chains are at least 50 autocorrelation times long;
if --steps is reached first, nothing is reported and the message says how
many steps to ask for (exit status 1).
"""

EPILOG = """\
examples:
  nlid simulate --preset paper-experimental --seed 1 --noise 0.02 --channels a --out x.csv
  nlid posterior x.csv --mass 0.265 --terms "z^3,z^2,sign(v)*|px(z)|,v*|px(z)|,v*|v|*|px(z)|,v^3*|px(z)|" \\
      --params "sign(v)*|px(z)|,v*|px(z)|,v*|v|*|px(z)|,v^3*|px(z)|" --out post/
  nlid posterior x.csv --mass 0.2 --terms "z^3,z^2,v*|v|" --params damping --prior "v*|v|=uniform(0,20)" --json
"""


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "posterior",
        help="posterior (credible intervals) of the friction coefficients, sampled with emcee",
        description=DESCRIPTION,
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_data_arguments(p)
    add_model_arguments(p, "identifier giving the starting point (default: the preferred installed one)")
    p.add_argument(
        "--params",
        default="damping",
        metavar="TERMS",
        help="coefficients to sample: 'damping' (every velocity-dependent term, default), 'all', "
        "or a comma-separated list such as 'sign(v)*|px(z)|,v*|v|'; on a structure record also 'elements' "
        "(every element on a connection) and names such as '(z1-z2)^3,C[1,1]'",
    )
    p.add_argument(
        "--prior",
        action="append",
        metavar="TERM=SPEC",
        help="prior of one sampled term: normal(MEAN,SD), uniform(LOW,HIGH) or flat (repeatable)",
    )
    p.add_argument("--walkers", type=int, metavar="W", help="number of walkers (default max(32, 8 x parameters))")
    p.add_argument(
        "--steps", type=int, default=20000, metavar="S", help="give up after S steps unconverged (default 20000)"
    )
    p.add_argument("--seed", type=int, default=0, metavar="S", help="random seed (default 0)")
    p.add_argument(
        "--move",
        default="de",
        choices=("de", "stretch"),
        help="emcee move: differential evolution (de, default) or stretch",
    )
    p.add_argument(
        "--no-bias-correction",
        action="store_true",
        help="do not correct the errors-in-variables bias by simulation (faster; intervals may miss the truth)",
    )
    p.add_argument("--bias-pairs", type=int, default=4, metavar="N", help="antithetic noise pairs (default 4)")
    p.add_argument(
        "--noise-level",
        action="append",
        metavar="CHANNEL=SD",
        help="known noise standard deviation of a channel in its SI unit, e.g. z=4e-4 (m) or v=0.003 (m/s) "
        "(repeatable; default: z from its noise floor, a measured v from its consistency with dz/dt)",
    )
    p.add_argument("--noise-z", type=float, metavar="M", help="same as --noise-level z=M")
    p.add_argument(
        "--others",
        default="marginal",
        choices=("fixed", "marginal"),
        help="coefficients not sampled: integrated out (default) or fixed at the identified values",
    )
    p.add_argument("--cutoff", type=float, metavar="HZ", help="equation band in Hz (default: from the noise floor)")
    p.add_argument(
        "--slices",
        metavar="Z,Z,...",
        help="positions (m) of the damping-force slices (default: the equilibria, as in the paper's Fig. 21)",
    )
    p.add_argument("--json", action="store_true", help="print one JSON object instead of a table")
    p.add_argument(
        "--quiet", action="store_true", help="no progress on stderr (it is shown only on a terminal, never with --json)"
    )
    p.add_argument(
        "--out",
        metavar="DIR",
        help="write the table (CSV), JSON, samples (NPZ; and posterior.nc, ArviZ's format, with the netcdf extra) "
        "and figures (PNG) to DIR",
    )
    p.add_argument("--no-figures", action="store_true", help="with --out, skip the PNG figures")
    p.add_argument(
        "--force",
        action="store_true",
        help="with --out, write into a folder that holds files nlid did not write (it never replaces them)",
    )
    p.set_defaults(func=run)


def _floats(text: str | None, what: str) -> list[float] | None:
    if not text:
        return None
    try:
        values = [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise InputError(f"{what} expects comma-separated numbers, got {brief(text)}") from None
    if not all(math.isfinite(x) for x in values):
        raise InputError(f"{what} expects finite numbers, got {brief(text)}")
    return values


def parse_noise_levels(items: list[str] | None, noise_z: float | None = None) -> dict[str, float] | None:
    """``["v=0.003", ...]`` (and ``--noise-z``) to ``{"v": 0.003, ...}``; ``None`` when nothing is given."""
    levels: dict[str, float] = {}
    if noise_z is not None:
        levels["z"] = noise_z
    for item in items or []:
        channel, sep, value = item.partition("=")
        channel = channel.strip()
        if not sep or channel not in ("z", "v"):
            raise InputError(
                f"--noise-level expects CHANNEL=SD with CHANNEL z or v (noise on a needs no level), got {brief(item)}"
            )
        try:
            level = float(value)
        except ValueError:
            raise InputError(f"--noise-level {channel}= expects a number, got {brief(value.strip())}") from None
        NOISE_SD[channel].check(level, f"--noise-level {channel}=")
        if channel in levels:
            raise InputError(f"--noise-level gives the level of {channel} twice")
        levels[channel] = level
    return levels or None


def run(args: argparse.Namespace) -> int:
    from ..bayes import PosteriorSampler
    from ..bayes.inference import check_params_spelling
    from ..bayes.noise import UNITS, UnknownNoiseError
    from ..bayes.priors import parse_prior_assignments
    from ..identification.pipeline import identify

    if args.noise_z is not None:
        NOISE_SD["z"].check(args.noise_z, "--noise-z")
    noise = parse_noise_levels(args.noise_level, args.noise_z)
    slices = _floats(args.slices, "--slices")
    if slices is not None and not args.out:
        raise InputError("--slices sets the damping-force slices of the figures written with --out; give --out DIR")
    # read priors and parameter names before the (slower) identification, so typos fail at once
    parse_prior_assignments(args.prior, canonical=lambda name: name)  # the specs; the names once the model is known
    check_params_spelling(args.params)
    sampler = PosteriorSampler(
        args.params,
        priors=args.prior,
        walkers=args.walkers,
        max_steps=args.steps,
        seed=args.seed,
        move=args.move,
        bias_correction=False if args.no_bias_correction else None,
        bias_pairs=args.bias_pairs,
        noise=noise,
        cutoff=args.cutoff,
        others=args.others,
    )
    record = load_data(args)
    show = not (args.quiet or args.json)  # the sampler's progress, on a terminal only
    with showing(show):  # the terms are parsed by identify on the record's DOFs: a model or a structure's elements
        result = identify(record, args.terms, args.method, **identify_options(args))
    try:
        with showing(show):
            posterior = sampler.run(record, result)
    except UnknownNoiseError as exc:
        wanted = " ".join(f"{c}=SD" for c in exc.channels)
        units = ", ".join(f"{c} in {UNITS[c]}" for c in exc.channels)
        raise DataError(
            f"{exc.reason}; give the level with --noise-level {wanted} ({units}) from the sensor's specification "
            "or a record at rest"
        ) from None
    if args.out:
        paths = posterior.save(args.out, figures=not args.no_figures, slices=slices, force=args.force)
        print(f"wrote {', '.join(str(p) for p in paths)}", file=sys.stderr)
        if not any(p.suffix == ".nc" for p in paths):
            print("note: posterior.nc (ArviZ's format) needs the extra: pip install 'nlid[netcdf]'", file=sys.stderr)
    if args.json:
        print_json(posterior.to_dict())
    else:
        print(with_wall_time(posterior.format_table(), "posterior"))
    from ..identified.plausibility import headline

    return untrusted("posterior", headline(posterior.flags))
