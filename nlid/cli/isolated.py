"""Plugin code in a child process, for the commands: the ``--timeout`` option and the plugin's warnings as one line.

``nlid identify`` and ``nlid discover`` run the plugin's code in a child
process (:mod:`nlid.runtime.isolation`) with a default time limit, so a
plugin that crashes, hangs, prints or leaves processes behind gives one
error line, never a dead or hung ``nlid`` or corrupt ``--json`` output.
"""

from __future__ import annotations

import argparse
import math
import sys
import warnings
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["add_timeout_argument", "parse_timeout", "plugin_warnings", "IDENTIFY_TIMEOUT", "DISCOVER_TIMEOUT"]

#: Default time limit of ``nlid identify`` (s), the same as a study's run.
IDENTIFY_TIMEOUT = 600.0
#: Default time limit of ``nlid discover`` (s): a whole search, many identifications.
DISCOVER_TIMEOUT = 1800.0
#: Longest finite time limit (s): a week.
MAX_TIMEOUT = 7 * 24 * 3600.0


def parse_timeout(text: str | float | None) -> float | None:
    """``--timeout``: seconds, or ``0``/``none`` for no time limit (``math.inf``); ``None`` stays ``None``.

    Raises
    ------
    InputError
        Not a number of seconds in (0, a week], nor ``0``/``none``.
    """
    from ..errors import InputError

    if text is None or isinstance(text, float):
        return text
    value = str(text).strip().lower()
    if value in ("none", "off", "0", "0.0", "inf"):
        return math.inf
    try:
        seconds = float(value)
    except ValueError:
        seconds = float("nan")
    if not (0 < seconds <= MAX_TIMEOUT):
        raise InputError(
            f"--timeout must be a number of seconds between 0 and {MAX_TIMEOUT:g} (0 or 'none': no limit), got {text!r}"
        )
    return seconds


def add_timeout_argument(parser: argparse.ArgumentParser, default: float, what: str) -> None:
    """Add ``--timeout SECONDS`` (default ``default``) to a command that runs ``what`` in a child process."""
    parser.add_argument(
        "--timeout",
        default=default,
        metavar="SECONDS",
        help=f"{what} runs in a separate process, stopped after SECONDS (default {default:g}; 0 or 'none': no "
        "limit); a plugin that crashes or hangs then gives one error line, and what it prints goes to stderr",
    )


@contextmanager
def plugin_warnings(command: str) -> Iterator[None]:
    """Print each warning a plugin issued in its child process as one line ``nlid CMD: warning: ...``.

    Other warnings are issued again, unchanged, when the block ends.
    """
    from ..runtime.outcome import PluginWarning

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("default", PluginWarning)
        try:
            yield
        finally:
            others = []
            for w in caught:
                if issubclass(w.category, PluginWarning):
                    print(f"nlid {command}: warning: {w.message}", file=sys.stderr)
                else:
                    others.append(w)
    for w in others:
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno, source=w.source)
