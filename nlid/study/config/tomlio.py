"""TOML in and out: the reader (``tomllib``; ``tomli`` on Python 3.10) and a small writer, :func:`dumps`.

The writer covers what a study holds: tables, arrays of tables, strings,
booleans, integers, finite floats (written with :func:`repr`, so that they
read back to the same float), arrays and inline tables. A table whose values
hold no table is written inline inside its parent (``noise = { z = 0.02 }``);
a top-level table is a ``[section]``, a top-level array of tables a
``[[section]]`` list. TOML has no null: a ``None`` value is an error (the
callers leave such keys out).
"""

from __future__ import annotations

import math
import re
import sys
from collections.abc import Mapping
from typing import Any

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised on 3.10 only
    import tomli as tomllib

__all__ = ["tomllib", "dumps"]

_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")
_ESCAPES = {'"': '\\"', "\\": "\\\\", "\b": "\\b", "\t": "\\t", "\n": "\\n", "\f": "\\f", "\r": "\\r"}


def _string(text: str) -> str:
    """A TOML basic string (quotes, backslashes and control characters escaped)."""
    out = []
    for ch in text:
        if ch in _ESCAPES:
            out.append(_ESCAPES[ch])
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            out.append(f"\\u{ord(ch):04x}")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def _key(key: Any) -> str:
    key = str(key)
    return key if _BARE_KEY.match(key) else _string(key)


def _value(value: Any) -> str:
    """One TOML value, written on one line."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            return ("-inf" if value < 0 else "inf") if math.isinf(value) else "nan"
        return repr(value)
    if isinstance(value, str):
        return _string(value)
    if isinstance(value, Mapping):
        items = ", ".join(f"{_key(k)} = {_value(v)}" for k, v in value.items())
        return "{ " + items + " }" if items else "{}"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_value(v) for v in value) + "]"
    if value is None:
        raise ValueError("TOML has no null: leave the key out")
    raise TypeError(f"cannot write a {type(value).__name__} as TOML")


def _nested(value: Any) -> bool:
    """True for a table that holds a table (written under its own header)."""
    return isinstance(value, Mapping) and any(isinstance(v, Mapping) for v in value.values())


def _table(path: list[str], table: Mapping[str, Any], lines: list[str], header: str | None) -> None:
    if header is not None:
        lines.extend(["", header])
    for key, value in table.items():
        if not _nested(value):
            lines.append(f"{_key(key)} = {_value(value)}")
    for key, value in table.items():
        if _nested(value):
            sub = [*path, _key(key)]
            _table(sub, value, lines, f"[{'.'.join(sub)}]")


def dumps(document: Mapping[str, Any]) -> str:
    """A TOML document: top-level tables as ``[sections]``, top-level lists of tables as ``[[sections]]``.

    Raises
    ------
    ValueError
        A ``None`` value anywhere.
    TypeError
        A value TOML cannot hold.
    """
    lines: list[str] = []
    for key, value in document.items():
        if not isinstance(value, Mapping) and not _tables(value):
            lines.append(f"{_key(key)} = {_value(value)}")
    for key, value in document.items():
        if isinstance(value, Mapping):
            _table([_key(key)], value, lines, f"[{_key(key)}]")
        elif _tables(value):
            for item in value:
                _table([_key(key)], item, lines, f"[[{_key(key)}]]")
    return "\n".join(lines).lstrip("\n") + "\n"


def _tables(value: Any) -> bool:
    """True for a non-empty list of tables (a ``[[section]]`` list at the top level)."""
    return isinstance(value, (list, tuple)) and bool(value) and all(isinstance(v, Mapping) for v in value)
