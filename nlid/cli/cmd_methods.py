"""``nlid methods``: which identifier to choose, the installed ones, their options and defaults.

The advice comes from the identifiers (their ``advice`` and ``advice_order`` attributes,
:class:`nlid.plugin.Identifier`); docs/methods.md has the table with the measurements.
"""

from __future__ import annotations

import argparse

from ..base.formatting import TERMINAL_WIDTH, wrap
from ..errors import InputError, brief, one_line
from .common import print_json


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "methods",
        help="list the installed identifiers and their options",
        description="Which identifier to choose, then the identifiers found through the 'nlid.identifiers' "
        "entry points with a one-line summary. Give NAMEs (or --all) to list their options (set them with "
        "'nlid identify --set NAME=VALUE'). Plugins that failed to load, or provide nothing, are listed with "
        "their error; plugins that printed while loading (kept out of the output) or were slow to import, "
        "with a note. "
        "docs/methods.md has the decision table with the measurements behind it.",
    )
    p.add_argument("names", nargs="*", metavar="NAME", help="identifiers whose options to list")
    p.add_argument("--all", action="store_true", help="list the options of every identifier")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..contract.methods import advice_of, ranked
    from ..contract.registry import default_registry

    reg = default_registry()
    unknown = [n for n in args.names if n not in reg.identifiers]
    if unknown:  # with --json too: a misspelt name is refused, not answered with every method
        reg.get(unknown[0])  # raises the registry's error, with a suggestion
        raise InputError(f"unknown identifier {brief(unknown[0])}")
    if args.json:
        print_json(
            {
                "methods": {
                    name: {
                        "summary": cls.summary,
                        "plugin": reg.plugins[name],
                        "needs_mass": cls.needs_mass,
                        "options": [o.describe() for o in cls.options],
                    }
                    for name, cls in sorted(reg.identifiers.items())
                    if not args.names or name in args.names
                },
                "failures": reg.failures,
                "notes": reg.notes,
            }
        )
        return 0
    if not reg.identifiers:
        print("no identifiers installed")
    detailed = set(args.names) if args.names else set(reg.names()) if args.all else set()
    if not args.names:
        print("Which method? (docs/methods.md has the decision table and the measurements)")
        # each identifier's own advice (its summary when it gives none), in the order the identifiers ask for
        for name in ranked(reg.identifiers, "advice_order"):
            print(wrap(f"{name}: {advice_of(reg.identifiers[name])}", TERMINAL_WIDTH, indent="  ", subsequent="      "))
        print(
            wrap(
                "any fit: 'nlid posterior' puts intervals on its friction coefficients, 'nlid discover' finds "
                "what the model lacks, 'nlid study run' compares methods on the same data.",
                TERMINAL_WIDTH,
                indent="  ",
                subsequent="      ",
            )
        )
        print()
    for name in reg.names():
        if args.names and name not in detailed:
            continue
        cls = reg.identifiers[name]
        mass = "needs --mass" if cls.needs_mass else "estimates the mass when --mass is not given"
        print(f"{name}  ({mass})")
        print(wrap(cls.summary, TERMINAL_WIDTH, indent="    ", subsequent="    "))
        if name not in detailed:
            print(f"    {len(cls.options)} options: nlid methods {name}")
            continue
        for opt in cls.options:
            default = "auto" if opt.default is None else opt.default
            choices = f" [{'|'.join(map(str, opt.choices))}]" if opt.choices else ""
            print(f"    --set {opt.name}=<{opt.type}>{choices}  (default {default})")
            print(wrap(opt.help, TERMINAL_WIDTH, indent="        ", subsequent="        "))
        print()
    for plugin, error in sorted(reg.failures.items()):
        print(f"{plugin}  UNUSABLE: {one_line(error)}")
    for plugin, notes in sorted(reg.notes.items()):
        for note in notes:
            print(f"{plugin}  NOTE: {one_line(note)}")
    return 0
