"""``nlid methods``: installed identifiers, their options and defaults."""

from __future__ import annotations

import argparse

from ..registry import default_registry
from .common import print_json


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "methods",
        help="list the installed identifiers and their options",
        description="List the identifiers found through the 'nlid.identifiers' entry points, with their "
        "options (set them with 'nlid identify --set NAME=VALUE'). Plugins that failed to load are listed "
        "with their error.",
    )
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    reg = default_registry()
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
                },
                "failures": reg.failures,
            }
        )
        return 0
    if not reg.identifiers:
        print("no identifiers installed")
    for name in reg.names():
        cls = reg.identifiers[name]
        mass = "needs --mass" if cls.needs_mass else "estimates the mass when --mass is not given"
        print(f"{name}  ({mass})")
        print(f"    {cls.summary}")
        for opt in cls.options:
            default = "auto" if opt.default is None else opt.default
            choices = f" [{'|'.join(map(str, opt.choices))}]" if opt.choices else ""
            print(f"    --set {opt.name}=<{opt.type}>{choices}  (default {default})  {opt.help}")
        print()
    for plugin, error in sorted(reg.failures.items()):
        print(f"{plugin}  UNUSABLE: {error}")
    return 0
