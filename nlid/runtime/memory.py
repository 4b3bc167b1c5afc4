"""The peak memory a block of code adds, measured without slowing the block where the system allows.

A study row reports, beside each identification's wall time, the peak memory it took. Tracing every
allocation (:mod:`tracemalloc`) slows the traced call unequally: on one paper-numerical record, quiet
2-core machine, rfs by 14 %, nsi-ip by 23 %, nsi-shift by 20 % and sindy by 54 % (Python-heavy code pays
most), so the times of a study's methods were not comparable. On Linux the kernel keeps the process's
resident high-water mark (``VmHWM`` in ``/proc/self/status``) and resets it to the current resident size
when ``5`` is written to ``/proc/self/clear_refs`` (Linux >= 4.0): the peak the block added is then the
high-water mark after it minus the resident size before it, and nothing runs during the block.
Elsewhere (or when ``/proc`` cannot be written) the peak traced allocation is used, as before.

The two measure slightly different things, and :attr:`PeakMemory.how` says which one was used: the
resident peak counts every page the block touched (numpy's buffers, the modules it imported, the
allocator's slack) and nothing it allocated without touching; the traced peak counts Python's and
numpy's allocations as requested.
"""

from __future__ import annotations

import tracemalloc
from pathlib import Path
from types import TracebackType

__all__ = ["PeakMemory", "RESIDENT", "TRACED"]

#: :attr:`PeakMemory.how` when the resident high-water mark was used.
RESIDENT = "resident"
#: :attr:`PeakMemory.how` when :mod:`tracemalloc` was used.
TRACED = "traced"

_PROC = Path("/proc/self")


def _status_kb(*fields: str) -> tuple[int | None, ...]:
    """``kB`` fields of ``/proc/self/status`` (``VmRSS``, ``VmHWM``), read at once; ``None`` for each one missing."""
    found: dict[str, int] = {}
    try:
        with open(_PROC / "status", encoding="ascii") as handle:
            for line in handle:
                name, _, rest = line.partition(":")
                if name in fields:
                    found[name] = int(rest.split()[0])
    except (OSError, ValueError, IndexError):
        return tuple(None for _ in fields)
    return tuple(found.get(field) for field in fields)


def _reset_high_water() -> bool:
    """Reset the process's resident high-water mark to its resident size; whether that worked."""
    try:
        with open(_PROC / "clear_refs", "w", encoding="ascii") as handle:
            handle.write("5")
    except OSError:
        return False
    return True


class PeakMemory:
    """Context manager: the peak memory (bytes) the block added, in :attr:`bytes` after it ends.

    Examples
    --------
    >>> import numpy as np
    >>> with PeakMemory() as peak:
    ...     x = np.ones(2_000_000)
    >>> peak.bytes >= 0
    True
    """

    def __init__(self) -> None:
        self.bytes: int = 0
        self.how: str = ""
        self._before_kb: int | None = None

    def __enter__(self) -> PeakMemory:
        before, high = _status_kb("VmRSS", "VmHWM") if _reset_high_water() else (None, None)
        if before is not None and high is not None:  # the mark was reset to the resident size
            self.how, self._before_kb = RESIDENT, before
        else:
            self.how = TRACED
            tracemalloc.start()
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        trace: TracebackType | None,
    ) -> None:
        if self.how == TRACED:
            _, peak = tracemalloc.get_traced_memory()
            tracemalloc.stop()
            self.bytes = int(peak)
            return
        (after,) = _status_kb("VmHWM")
        before = self._before_kb if self._before_kb is not None else 0
        self.bytes = max(0, (after if after is not None else before) - before) * 1024
