"""What the force did between its samples, and who said so: the one assumption every summary states.

A record's force is either *sampled* (a continuous force read at the sample times: between them it is
interpolated) or *zero-order held* (``zoh``: a digital controller or generator held each value over its
sample, as nlid's own simulations do). The two give different models from the same samples: the
paper-numerical record written without its ``.meta.json`` sidecar (so read as sampled) gives a viscous
coefficient 7 % lower than with it (issue 35). :attr:`Record.force_hold <nlid.data.record.Record.force_hold>`
says which; ``meta["force_hold_source"]`` says where that came from:

``"sidecar <name>"``
    the file's ``.meta.json`` (written by ``nlid simulate`` and :func:`nlid.data.io.write_csv`);
``"option"``
    ``force_hold=`` (``--force-hold``) when the data were loaded;
``"simulation"``, ``"dataset"``, ``"benchmark"``
    a preset simulation, a bundled measured dataset, a benchmark's declaration;
``"record metadata"``
    a record built with ``meta={"force_hold": ...}``;
``"default"``
    nothing said it: the force is taken as sampled.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

__all__ = ["FORCE_HOLDS", "force_hold_source", "describe_force_hold"]

#: The force's behaviour between samples, with what each means.
FORCE_HOLDS = {
    "sampled": "interpolated between samples",
    "zoh": "held over each sample",
}


def force_hold_source(meta: Mapping[str, Any]) -> str:
    """Where a record's force hold came from (the module's list), from the record's metadata."""
    if "force_hold" not in meta:
        return "default"
    return str(meta.get("force_hold_source") or "record metadata")


def describe_force_hold(hold: str, source: str) -> str:
    """One line: ``"zoh: held over each sample [from the sidecar x.csv.meta.json]"``.

    The default says how to change it (``force_hold=``, which the command line spells ``--force-hold``: library
    text speaks Python).
    """
    what = FORCE_HOLDS.get(hold, hold)
    if source == "default":
        return f"{hold}: {what} [the default: nothing said otherwise; force_hold='zoh' if it was held]"
    where = {"option": "the option force_hold="}.get(source, source)
    return f"{hold}: {what} [from {where}]"
