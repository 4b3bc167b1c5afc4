"""The exceptions nlid raises.

A small hierarchy rooted in :class:`NlidError`. Every error caused by what a
user gave us (a file, a term, an option, a configuration) is an
:class:`InputError`; the command line turns those into one line on stderr and
exit status 2. Errors that mean "the method ran but could not produce a
trustworthy answer" are :class:`IdentificationError`.

Each class also derives from the matching built-in exception, so callers that
catch ``ValueError`` or ``RuntimeError`` keep working.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

__all__ = [
    "rebuild_error",
    "NlidError",
    "InputError",
    "DataError",
    "TermError",
    "OptionError",
    "PluginError",
    "IdentificationError",
    "describe_exception",
    "excerpt",
    "brief",
    "listing",
    "one_line",
    "MAX_LINE",
    "PASS_THROUGH",
    "grouped",
]

#: Exceptions a plugin boundary lets through (the user pressed Ctrl-C): everything else a plugin
#: raises, ``SystemExit`` included, is reported as that plugin's failure.
PASS_THROUGH = (KeyboardInterrupt,)


def describe_exception(exc: BaseException) -> str:
    """What a plugin did, in a few words: ``"called sys.exit(3)"`` or ``"raised ValueError: ..."``."""
    if isinstance(exc, SystemExit):
        return f"called sys.exit({exc.code!r})" if exc.code is not None else "called sys.exit()"
    text = str(exc)
    return f"raised {type(exc).__name__}" + (f": {text}" if text else "")


def excerpt(text: str, position: int | None = None, width: int = 60) -> str:
    """``repr(text)``, shortened around ``position`` when longer than ``width`` (messages stay one readable line)."""
    if len(text) <= width:
        return repr(text)
    centre = 0 if position is None else position
    start = max(0, min(centre - width // 2, len(text) - width))
    piece = text[start : start + width]
    return f"{'...' if start else ''}{piece!r}{'...' if start + width < len(text) else ''} ({len(text)} characters)"


def brief(value: object, width: int = 80) -> str:
    """``repr(value)``, cut to about ``width`` characters (a huge value stays one readable line).

    The one helper for echoing a value in a message: a 100 000-character term or option value comes
    back as ``'xxxx...'... (100002 characters)``, and line breaks stay escaped (``repr``).
    """
    try:
        text = repr(value)
    except Exception:  # noqa: BLE001 - a hostile object's __repr__ must not replace the message
        text = f"<{type(value).__name__} object>"
    if len(text) <= width:
        return text
    return (
        f"{text[: max(width - 20, 10)]}... ({grouped(len(value) if isinstance(value, str) else len(text))} characters)"
    )


def grouped(n: int) -> str:
    """``99990`` as ``"99 990"`` (a thin grouping, readable in any locale)."""
    return f"{n:,}".replace(",", " ")


def listing(items: Iterable[object], limit: int = 10, width: int = 40, quote: bool = False) -> str:
    """Items joined by ``", "``, at most ``limit`` of them, each cut by :func:`brief` to ``width``.

    ``listing(f"c{i}" for i in range(100000))`` is ``"c0, c1, ..., c9 ... and 99 990 more"``: the
    way every message lists names the user gave or a file holds. ``quote`` shows each item as its
    ``repr``; otherwise strings are shown as they are (still cut, line breaks escaped).
    """
    items = list(items)
    shown = [
        brief(item, width) if quote or not isinstance(item, str) else one_line(item, width) for item in items[:limit]
    ]
    more = len(items) - len(shown)
    return ", ".join(shown) + (f" ... and {grouped(more)} more" if more > 0 else "")


#: Longest line the command line prints for one error or warning (characters).
MAX_LINE = 1000


def one_line(text: str, width: int = MAX_LINE) -> str:
    """``text`` as one line of at most about ``width`` characters, whatever it holds.

    The command line's last resort: line breaks and other control characters are escaped
    (``\\n``), and a longer text keeps its start and its end (what went wrong, and the hint that
    usually closes the message) around ``... (N characters in all) ...``.
    """
    text = str(text)
    if not text.isprintable():
        text = "".join(ch if ch.isprintable() else repr(ch)[1:-1] for ch in text)
    if len(text) <= width:
        return text
    if width < 200:  # a short value: its start is enough
        return f"{text[: max(width - 20, 10)]}... ({grouped(len(text))} characters)"
    tail = width // 4
    head = width - tail - 40
    return f"{text[:head]} ... ({grouped(len(text))} characters in all) ... {text[-tail:]}"


class NlidError(Exception):
    """Base class of every error raised by nlid on purpose."""


class InputError(NlidError, ValueError):
    """Something the user supplied is invalid (file, term, option, config)."""


class DataError(InputError):
    """A record or data file is unusable (NaN, unequal lengths, bad time axis...)."""


class TermError(InputError):
    """A model term could not be parsed or evaluated.

    Parameters
    ----------
    message
        What is wrong.
    text
        The offending input string, if any.
    position
        0-based index of the offending character in ``text``.
    """

    def __init__(self, message: str, text: str | None = None, position: int | None = None):
        self.text = text
        self.position = position
        self.reason = message
        if text is not None and position is not None:
            message = f"{message} at character {position + 1} of {excerpt(text, position)}"
        super().__init__(message)


class OptionError(InputError):
    """An identifier option is unknown or has a value of the wrong type."""


class PluginError(NlidError):
    """An identifier plugin failed to load, is missing, or broke its contract."""


class IdentificationError(NlidError, RuntimeError):
    """The identification ran but its result cannot be trusted.

    Examples: the underlying-linear system identified by NSI has real
    eigenvalues, or a regression matrix is rank deficient.
    """


def rebuild_error(names: Sequence[str], message: str) -> NlidError:
    """The error a child process reported, rebuilt in the parent: the first of ``names`` (the error's class
    and its bases, most derived first) that is an nlid error class, else :class:`NlidError`, with ``message``."""
    for name in names:
        cls = globals().get(name)
        if isinstance(cls, type) and issubclass(cls, NlidError) and cls is not TermError:
            return cls(message)
    return NlidError(message)
