"""``nlid terms``: the term language, or the canonical form of given terms."""

from __future__ import annotations

import argparse

from .common import print_json


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "terms",
        help="the term language and canonical spellings",
        description="Show the term language, or check terms: 'nlid terms \"sign(v)*|v|^2, z*z*z\"' prints "
        "each term's canonical spelling, family and units.",
    )
    p.add_argument("check", nargs="?", metavar="TERMS", help="comma-separated terms to normalise and describe")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..model.terms import EXAMPLES, LANGUAGE, Model

    if args.check:
        model = Model.from_spec(args.check, defaults=False)
        rows = [
            {"term": t.name, "family": t.family, "unit": t.unit, "coefficient_unit": t.coefficient_unit}
            for t in model.terms
        ]
        if args.json:
            print_json(rows)
        else:
            width = max(len(r["term"]) for r in rows)
            for r in rows:
                units = f"value in {r['unit']:<8}  coefficient in {r['coefficient_unit']}"
                print(f"{r['term']:<{width}}  {r['family']:<9}  {units}")
        return 0
    if args.json:
        print_json({"language": LANGUAGE, "examples": [{"terms": a, "meaning": b} for a, b in EXAMPLES]})
        return 0
    print(LANGUAGE)
    print("Canonical spellings:")
    width = max(len(a) for a, _ in EXAMPLES)
    for spelling, meaning in EXAMPLES:
        print(f"  {spelling:<{width}}  {meaning}")
    return 0
