"""Progress of long work, shown on a terminal only: one line on stderr, redrawn in place.

Long computations (the posterior's sampler, the ``oe`` identifier's optimiser, a
``discover`` search) report their progress through :func:`progress_line`; the
caller decides whether it is shown. It is shown when both hold:

* the caller asked for it (:func:`showing`; the commands ask unless
  ``--quiet`` or ``--json`` is given; the library never asks by itself, so
  ``nlid.posterior(...)`` in a script prints nothing);
* the stream is a terminal (``isatty()``): piped or redirected stderr, CI
  logs and notebooks get nothing, never a stream of carriage returns.

The switch crosses process boundaries where nlid starts a child for one
computation (``identify(..., timeout=)``, ``nlid discover``): the child shows
progress when the caller did (:func:`active` is sent with the work), on the
same stderr. Studies and ``nlid bench`` have their own runs-done line
(:class:`nlid.study.runner.Progress`) and do not ask their workers for any.

Examples
--------
>>> from nlid.runtime.progress import progress_line, showing
>>> with showing(), progress_line("oe", total=100, unit="evaluations") as line:  # doctest: +SKIP
...     for i in range(100):
...         line.update(i + 1, note="cost 1.2e-3")
"""

from __future__ import annotations

import contextvars
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import TextIO

__all__ = ["ProgressLine", "progress_line", "showing", "active", "stderr_is_terminal"]

_ACTIVE: contextvars.ContextVar[bool] = contextvars.ContextVar("nlid_progress", default=False)
#: Least time between two redraws (s): a fast loop does not flood the terminal.
MIN_INTERVAL = 0.1
#: Longest line drawn (characters), so that a redrawn line never wraps on a narrow terminal.
MAX_WIDTH = 100


def active() -> bool:
    """Whether the caller asked for progress in this context (:func:`showing`)."""
    return _ACTIVE.get()


@contextmanager
def showing(on: bool = True) -> Iterator[None]:
    """Within the block, long work shows its progress on a terminal (``on=False``: it does not)."""
    token = _ACTIVE.set(bool(on))
    try:
        yield
    finally:
        _ACTIVE.reset(token)


def stderr_is_terminal() -> bool:
    """``sys.stderr.isatty()``, False for a stream without one (a notebook's, a closed one)."""
    try:
        return bool(sys.stderr.isatty())
    except (AttributeError, ValueError, OSError):
        return False


class ProgressLine:
    """One progress line, redrawn in place on a terminal and silent anywhere else.

    Parameters
    ----------
    label
        Shown first, e.g. ``"nlid posterior"``.
    total
        Units of work in all, if known (then ``done/total`` and a percentage are shown).
    unit
        What is counted (``"steps"``, ``"evaluations"``).
    stream
        Default ``sys.stderr``.
    enabled
        Default: the caller asked for progress (:func:`active`) and ``stream`` is a terminal.
    """

    def __init__(
        self,
        label: str,
        *,
        total: int | None = None,
        unit: str = "",
        stream: TextIO | None = None,
        enabled: bool | None = None,
    ) -> None:
        self.label, self.total, self.unit = label, total, unit
        self.stream = stream if stream is not None else sys.stderr
        if enabled is None:
            enabled = active() and _isatty(self.stream)
        self.enabled = bool(enabled)
        self.start = time.monotonic()
        self.done = 0
        self.note = ""
        self._drawn = 0.0
        self._shown = False

    def text(self) -> str:
        """The current line."""
        parts = [self.label + ":"] if self.label else []
        if self.total:
            parts.append(f"{self.done}/{self.total} {self.unit} ({100.0 * self.done / self.total:.0f} %)".strip())
        elif self.done:
            parts.append(f"{self.done} {self.unit}".strip())
        if self.note:
            parts.append(self.note)
        parts.append(f"[{_clock(time.monotonic() - self.start)}]")
        line = " ".join(parts)
        return line if len(line) <= MAX_WIDTH else line[: MAX_WIDTH - 3] + "..."

    def update(self, done: int | None = None, *, note: str | None = None, force: bool = False) -> None:
        """Set the count (and the note) and redraw, at most every :data:`MIN_INTERVAL` s unless ``force``."""
        if done is not None:
            self.done = int(done)
        if note is not None:
            self.note = note
        if not self.enabled:
            return
        now = time.monotonic()
        if not force and self._shown and now - self._drawn < MIN_INTERVAL:
            return
        self._drawn, self._shown = now, True
        self.stream.write("\r\x1b[2K" + self.text())
        self.stream.flush()

    def keep(self, message: str) -> None:
        """Print ``message`` as a line of its own above the progress line (a milestone worth keeping)."""
        if not self.enabled:
            return
        self.stream.write("\r\x1b[2K" + message + "\n")
        self._shown = False
        self.update(force=True)

    def close(self) -> None:
        """Erase the line (the results that follow take its place)."""
        if self.enabled and self._shown:
            self.stream.write("\r\x1b[2K")
            self.stream.flush()
        self._shown = False

    def __enter__(self) -> ProgressLine:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def progress_line(label: str, *, total: int | None = None, unit: str = "") -> ProgressLine:
    """A :class:`ProgressLine` on stderr, shown when the caller asked (:func:`showing`) and stderr is a terminal."""
    return ProgressLine(label, total=total, unit=unit)


def _isatty(stream: TextIO) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError, OSError):
        return False


def _clock(seconds: float) -> str:
    seconds = int(seconds)
    minutes, secs = divmod(seconds, 60)
    return f"{minutes}:{secs:02d}" if minutes < 60 else f"{minutes // 60}:{minutes % 60:02d}:{secs:02d}"
