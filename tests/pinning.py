"""Pinned numbers, compared with a tolerance measured for each quantity (issue 35, item 1).

The pin tests (``tests/test_pins_spine.py``, ``tests/test_pins.py``) flatten what they pin into leaves
(``identify.nsi_ip_known.diagnostics.quality.v*|v|``, ``compare.estimated_mass[rfs,fn_hz,s1].value``,
``study.num/main/rfs/r0.coef:v``...) and compare each leaf with the tolerance of its *group*: the leaf's path
with list positions dropped (``...k_tilde_ensemble[].quality.v*|v|`` holds the five members of the
ensemble).

The tolerances live in ``tests/data/pin_tolerances.json``, written by ``python benchmarks/pin_spreads.py
--write``. That script recomputes every leaf under each OpenBLAS kernel this CPU accepts, one BLAS thread,
numpy without its run-time SIMD loops, numba compiled for a generic x86-64, and with the input records
multiplied by ``1 + eps N(0, 1)`` for eps = 1e-15, 1e-14, 1e-13 (the order of the last bits a different
kernel changes); the spread of a leaf is the range of those values and the pinned one (written on another
machine), relative to the pin. A group's tolerance is ``max(1e-9, 100 x worst spread)``: numbers that are
reproducible to the last bits keep the 1e-9 floor, ill-conditioned ones (a quality index from an
eigenvalue problem, an error in percent of a near-exact estimate) get what their conditioning needs, and
nothing is widened beyond that. Numbers that come from an MCMC chain get an absolute tolerance (3 x the
largest deviation measured); a text with such a number inside has it masked.

Text, flags and counts are compared exactly. A pinned ``None`` accepts ``None`` and NaN.
"""

from __future__ import annotations

import csv
import fnmatch
import json
import math
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

TOLERANCE_PATH = Path(__file__).parent / "data" / "pin_tolerances.json"
_INDEX = re.compile(r"\[\d+\]")
#: The length of a pinned list, as its own leaf (a list that grows or shrinks is a change).
LENGTH = "[#]"


def leaves(value: Any, path: str, out: dict[str, Any] | None = None) -> dict[str, Any]:
    """Every scalar of a JSON value by its path: ``a.b[2].c``; a list's length under ``path[#]``."""
    out = {} if out is None else out
    if isinstance(value, Mapping):
        for key, item in value.items():
            leaves(item, f"{path}.{key}", out)
    elif isinstance(value, (list, tuple)):
        out[path + LENGTH] = len(value)
        for i, item in enumerate(value):
            leaves(item, f"{path}[{i}]", out)
    else:
        out[path] = value
    return out


def csv_leaves(text: str, path: str, key_columns: int = 3) -> dict[str, Any]:
    """Every cell of a CSV text: ``path[<first key_columns cells>].<column>``; numbers as floats.

    The first cells name the row (``method,quantity,name`` in an :func:`nlid.compare` frame); a row whose
    name repeats gets its line number as well. The number of lines is a leaf of its own (``path[#]``).
    """
    rows = list(csv.reader(text.splitlines()))
    out: dict[str, Any] = {path + LENGTH: len(rows)}
    if not rows:
        return out
    header, seen = rows[0], set()
    for line, row in enumerate(rows[1:], start=1):
        name = ",".join(row[:key_columns])
        name = name if name not in seen else f"{name}#{line}"
        seen.add(name)
        for column, cell in zip(header, row, strict=True):
            out[f"{path}[{name}].{column}"] = _cell(cell)
    return out


def _cell(text: str) -> Any:
    try:
        return float(text) if text.strip() else text
    except ValueError:
        return text


def group_of(path: str) -> str:
    """The group of a leaf: its path with list positions dropped (``[3]`` becomes ``[]``)."""
    return _INDEX.sub("[]", path)


def is_number(value: Any) -> bool:
    """A float or an int, not a bool."""
    return isinstance(value, (int, float)) and not isinstance(value, bool)


class Tolerances:
    """The measured tolerance of every group of one pin file (``tests/data/pin_tolerances.json``).

    Parameters
    ----------
    suite
        ``"issue22"`` (``tests/test_pins_spine.py``) or ``"issue12"`` (``tests/test_pins.py``).
    data
        The parsed file (default: read :data:`TOLERANCE_PATH`).
    """

    def __init__(self, suite: str, data: Mapping[str, Any] | None = None) -> None:
        data = json.loads(TOLERANCE_PATH.read_text()) if data is None else data
        entry = data["suites"][suite]
        self.suite = suite
        self.floor = float(entry["floor"])
        self.absolute = float(entry.get("abs", 0.0))
        self.groups: dict[str, Mapping[str, Any]] = dict(entry["groups"])
        self.masked: dict[str, str] = {g: v["mask"] for g, v in entry.get("masked", {}).items()}
        #: Limits of a posterior compared to Monte Carlo precision (``shift_sd``, ``sd_rel``), if the suite has one.
        self.posterior: dict[str, Any] = dict(entry.get("posterior", {}))

    def limits(self, path: str) -> tuple[float, float]:
        """``(rel, abs)`` of a leaf: its group's (the floor for a group that was never measured)."""
        item = self.groups.get(group_of(path), {})
        return float(item.get("rel", self.floor)), float(item.get("abs", self.absolute))

    def mask(self, path: str) -> str | None:
        """The regular expression masked before a text leaf is compared, if its group matches a masked pattern."""
        group = group_of(path)
        return next((mask for pattern, mask in self.masked.items() if fnmatch.fnmatchcase(group, pattern)), None)


def mismatch(new: Any, old: Any, rel: float, absolute: float = 0.0) -> bool:
    """True when ``new`` is not the pinned ``old``.

    Numbers agree within ``rel`` relative or ``absolute`` (two ints exactly: they are counts and settings);
    text and flags exactly. A pinned ``None`` (or ``""``, a missing cell) also accepts ``None`` and NaN.
    """
    missing = new is None or (isinstance(new, float) and math.isnan(new))
    if old is None:
        return not missing
    if old == "" and missing:
        return False
    if isinstance(old, bool) or isinstance(new, bool) or not (is_number(old) and is_number(new)):
        return type(new) is not type(old) or new != old
    if isinstance(old, int) and isinstance(new, int):
        return new != old
    if not math.isfinite(old):
        return not (new == old or (math.isnan(old) and math.isnan(new)))
    return not abs(new - old) <= max(rel * abs(old), absolute)


def assert_pinned(new: Mapping[str, Any], old: Mapping[str, Any], tolerances: Tolerances, where: str = "") -> None:
    """Every pinned leaf of ``old`` is in ``new`` with its value, to its group's tolerance.

    Leaves added later (new columns, new JSON fields) are allowed; a pinned leaf that is gone fails. A text
    whose group has a mask is compared with the masked part replaced by ``#``. All failures are listed at
    once, each with its tolerance.
    """
    __tracebackhide__ = True
    failures = []
    for path, pinned in old.items():
        if path not in new:
            failures.append(f"{path}: gone (pinned {pinned!r})")
            continue
        value, mask = new[path], tolerances.mask(path)
        if mask and isinstance(pinned, str) and isinstance(value, str):
            value, pinned = re.sub(mask, "#", value), re.sub(mask, "#", pinned)
        rel, absolute = tolerances.limits(path)
        if mismatch(value, pinned, rel, absolute):
            shown = ""
            if _both_numbers(value, pinned):
                shown = f"(rel {abs(value - pinned) / abs(pinned):.2g}; tolerance rel {rel:.2g}, abs {absolute:.2g})"
            failures.append(f"{path}: {value!r} != {pinned!r} {shown}".rstrip())
    assert not failures, f"{where}: {len(failures)} pinned value(s) changed:\n" + "\n".join(failures[:40])


def _both_numbers(a: Any, b: Any) -> bool:
    return is_number(a) and is_number(b) and b != 0 and math.isfinite(a) and math.isfinite(b)
