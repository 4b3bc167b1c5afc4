"""What became of a call in a child process: :class:`ChildResult`, its warnings, and the words for how a process ended.

:func:`nlid.runtime.isolation.run_in_child` returns a :class:`ChildResult`
(built from the child's reply by :func:`result_from_reply`); warnings the child
issued come back as :class:`ChildWarning` and are issued again in nlid's
process as :class:`PluginWarning` (``PluginUserWarning``, ... one per built-in
category); :func:`describe_exit` says how a process ended
(``"segmentation fault (SIGSEGV)"``). :class:`IsolationError` is nlid's own
failure to run the work in a child at all.
"""

from __future__ import annotations

import builtins
import math
import os
import pickle
import signal
import sys
import warnings
from dataclasses import dataclass, field
from typing import Any

from ..errors import IdentificationError, NlidError, PluginError, rebuild_error

__all__ = [
    "ChildResult",
    "ChildWarning",
    "PluginWarning",
    "IsolationError",
    "describe_exit",
    "result_from_reply",
]


class IsolationError(NlidError, RuntimeError):
    """nlid could not run the work in a child process at all (not the work's own failure)."""


class PluginWarning(Warning):
    """A warning issued by code in a child process (a plugin), issued again in nlid's process naming it.

    Each is also an instance of the warning's built-in category
    (``PluginUserWarning`` is a :class:`UserWarning`, ...), so filters on
    that category still apply.
    """


def _plugin_category(base: str) -> type[Warning]:
    return _CATEGORIES.get(base, _CATEGORIES["UserWarning"])


_CATEGORIES: dict[str, type[Warning]] = {}
for _base in (
    "UserWarning",
    "DeprecationWarning",
    "PendingDeprecationWarning",
    "FutureWarning",
    "RuntimeWarning",
    "SyntaxWarning",
    "ImportWarning",
    "UnicodeWarning",
    "BytesWarning",
    "ResourceWarning",
    "EncodingWarning",
):
    if hasattr(builtins, _base):
        _CATEGORIES[_base] = type(f"Plugin{_base}", (PluginWarning, getattr(builtins, _base)), {"__module__": __name__})
        globals()[f"Plugin{_base}"] = _CATEGORIES[_base]


@dataclass(frozen=True)
class ChildWarning:
    """A warning issued in a child: its text, where, and how many times."""

    category: str
    base: str
    message: str
    filename: str
    lineno: int
    count: int = 1

    def line(self, label: str = "") -> str:
        """``"identifier 'x': message (file.py:12)"`` (``x3`` when issued three times)."""
        where = f" ({os.path.basename(self.filename)}:{self.lineno})" if self.filename else ""
        times = f" x{self.count}" if self.count > 1 else ""
        return f"{label + ': ' if label else ''}{self.message}{where}{times}"


@dataclass(frozen=True)
class ChildResult:
    """What became of a call in a child.

    Attributes
    ----------
    status
        ``"ok"`` (it returned :attr:`value`), ``"raised"`` (it raised
        :attr:`kind`; :attr:`error` says what), ``"timeout"`` (killed at the
        time limit), ``"died"`` (its process ended without replying:
        :attr:`exitcode`), ``"unsent"`` (it returned a value that could
        not be sent back: :attr:`error`) or ``"lost"`` (nlid's fork server
        ended while the call ran, e.g. killed by the out-of-memory killer:
        the call's process went with it, and nothing is known of the call:
        not the target's failure, see :attr:`infrastructure`).
    value
        The function's return value (``status == "ok"``).
    exitcode
        The child's exit code (negative: the signal that ended it), when known.
    seconds
        Wall time.
    error, kind, traceback
        ``"raised ValueError: ..."``, the exception's class name and the
        child's traceback (``status == "raised"``).
    warnings
        The warnings the call issued (:class:`ChildWarning`).
    threads
        Names of the threads still running when the call returned (ended
        with the child).
    pid
        The child's process id, which is also its process group's id (POSIX).
    """

    status: str
    value: Any = None
    exitcode: int | None = None
    seconds: float = 0.0
    error: str = ""
    kind: str = ""
    traceback: str = ""
    warnings: tuple[ChildWarning, ...] = field(default=())
    threads: tuple[str, ...] = field(default=())
    pid: int | None = None

    @property
    def infrastructure(self) -> bool:
        """True when nlid's own machinery failed (the fork server died), not the call: it may simply be run again."""
        return self.status == "lost"

    def describe(self, label: str, timeout: float | None = None) -> str:
        """One line saying what went wrong, starting with ``label`` (e.g. ``"identifier 'x'"``)."""
        if self.status == "ok":
            return f"{label} finished"
        if self.status == "lost":
            return (
                f"{label} was cut short: nlid's fork server ended while it ran (killed from outside, e.g. by the "
                "out-of-memory killer); not the identifier's failure"
            )
        if self.status == "timeout":
            limit = f" of {timeout:g} s" if timeout is not None and math.isfinite(timeout) else ""
            return f"{label} did not finish within the time limit{limit} and was stopped"
        if self.status == "died":
            return f"{label} crashed: {describe_exit(self.exitcode)}"
        if self.status == "unsent":
            return f"{label} returned a result that cannot be sent back to nlid ({self.error})"
        return f"{label} {self.error}"

    def answer(self, label: str, timeout: float | None, hint: str) -> Any:
        """The value of a call that returned ``("ok", value)`` or ``("error", class names, message[, traceback])``.

        Raises the nlid error the child raised (:func:`nlid.errors.rebuild_error`; its traceback in the
        child as a note), :class:`~nlid.errors.IdentificationError` at the time limit (with ``hint``, e.g.
        ``"raise --timeout"``), :class:`~nlid.errors.PluginError` when the child crashed or its answer
        could not come back.
        """
        if self.status == "timeout":
            raise IdentificationError(f"{self.describe(label, timeout)} ({hint})")
        if self.infrastructure:
            raise IsolationError(self.describe(label, timeout))
        if self.status != "ok":
            raise PluginError(self.describe(label, timeout))
        kind, *rest = self.value
        if kind == "ok":
            return rest[0]
        error = rebuild_error(rest[0], rest[1])
        if rest[2:] and hasattr(error, "add_note"):  # Python 3.11+
            error.add_note(f"traceback in the child process:\n{rest[2]}")
        raise error

    def warning_lines(self, label: str) -> list[str]:
        """One line per warning issued in the child, and one for threads left running."""
        lines = [w.line(label) for w in self.warnings]
        if self.threads:
            more = len(self.threads) - 3
            shown = ", ".join(self.threads[:3]) + (f" and {more} more" if more > 0 else "")
            lines.append(f"{label} left {len(self.threads)} thread(s) running ({shown}); they ended with its process")
        return lines

    def reissue_warnings(self, label: str, stacklevel: int = 2) -> None:
        """Issue each warning of the child again in this process, as a :class:`PluginWarning` naming ``label``."""
        for w in self.warnings:
            warnings.warn_explicit(w.line(label), _plugin_category(w.base), w.filename or "<child>", w.lineno)
        if self.threads:
            warnings.warn(self.warning_lines(label)[-1], _plugin_category("ResourceWarning"), stacklevel=stacklevel)


_SIGNAL_WORDS = {
    "SIGSEGV": "segmentation fault",
    "SIGABRT": "aborted",
    "SIGBUS": "bus error",
    "SIGFPE": "floating-point exception",
    "SIGILL": "illegal instruction",
    "SIGKILL": "killed",
    "SIGTERM": "terminated",
    "SIGINT": "interrupted",
    "SIGHUP": "hung up",
    "SIGPIPE": "broken pipe",
    "SIGSYS": "bad system call",
    "SIGTRAP": "trace trap",
    "SIGXCPU": "CPU time limit exceeded",
    "SIGXFSZ": "file size limit exceeded",
}
_WINDOWS_CODES = {
    0xC0000005: "access violation (segmentation fault)",
    0xC00000FD: "stack overflow",
    0xC0000409: "aborted (stack buffer overrun or abort())",
    0xC000001D: "illegal instruction",
    0xC0000094: "integer division by zero",
}


def describe_exit(exitcode: int | None) -> str:
    """How a process ended: ``"segmentation fault (SIGSEGV)"``, ``"its process ended with exit code 3"``."""
    if exitcode is None:
        return "its process ended without a reply"
    if exitcode < 0:
        try:
            name = signal.Signals(-exitcode).name
        except ValueError:
            return f"killed by signal {-exitcode}"
        word = _SIGNAL_WORDS.get(name)
        return f"{word} ({name})" if word else f"killed by {name}"
    if sys.platform == "win32" and (exitcode & 0xFFFFFFFF) in _WINDOWS_CODES:  # pragma: no cover - Windows
        return _WINDOWS_CODES[exitcode & 0xFFFFFFFF]
    return f"its process ended with exit code {exitcode}"


def result_from_reply(
    reply: bytes | None, exitcode: int | None, seconds: float, timed_out: bool, pid: int, lost: bool = False
) -> ChildResult:
    """The :class:`ChildResult` of a call: from the child's pickled reply, or from how it ended without one.

    ``lost``: the fork server that started the child ended without reporting the child's exit (the server
    died, and the child with it): a reply-less end is then ``"lost"``, not the child's own ``"died"``.

    Raises
    ------
    IsolationError
        The child could not receive its work (its reply says why).
    """
    if timed_out:
        return ChildResult("timeout", exitcode=exitcode, seconds=seconds, pid=pid)
    if reply is None:
        return ChildResult("lost" if lost else "died", exitcode=exitcode, seconds=seconds, pid=pid)
    try:
        data = pickle.loads(reply)
    except Exception as exc:  # noqa: BLE001 - e.g. a class the child could import and this process cannot
        why = f"{type(exc).__name__}: {exc}"
        return ChildResult("unsent", exitcode=exitcode, seconds=seconds, error=why, pid=pid)
    if data["status"] == "setup":
        raise IsolationError(f"a child process could not receive its work: {data['error']}")
    return ChildResult(
        data["status"],
        value=data.get("value"),
        exitcode=exitcode,
        seconds=seconds,
        error=data.get("error", ""),
        kind=data.get("kind", ""),
        traceback=data.get("traceback", ""),
        warnings=tuple(ChildWarning(**w) for w in data.get("warnings", ())),
        threads=tuple(data.get("threads", ())),
        pid=pid,
    )


__all__ += [f"Plugin{name}" for name in _CATEGORIES]
