"""Whether numba's on-disk cache of nlid's compiled kernels is cold: the first run compiles them.

The simulation kernels (:mod:`nlid.simulation.kernels` and its neighbours) are compiled by numba with
``cache=True``: once per machine (and per change of their source) into ``__pycache__`` beside the source,
then loaded in a fraction of a second. The first compilation takes about 30 s on a quiet machine and
minutes under load; the command line says so before it starts (:func:`cold_kernels`) instead of
seeming to hang. Nothing here imports numba or the kernels: the check reads file names and times only.
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["KERNEL_MODULES", "cold_kernels", "COMPILING_NOTE"]

#: The files (under the ``nlid`` package) whose functions numba compiles with ``cache=True`` on nlid's
#: common paths.
KERNEL_MODULES = (
    "simulation/kernels.py",
    "simulation/sensitivity.py",
    "model/terms/memory_kernels.py",
)
#: What the command line says when the cache is cold.
COMPILING_NOTE = "compiling the simulation kernels (first run only: about 30 s, longer on a busy machine)"


def _cached(source: Path) -> bool:
    """True when numba's index of ``source`` exists (beside it or under ``NUMBA_CACHE_DIR``) and is not older."""
    roots = [source.parent / "__pycache__"]
    if os.environ.get("NUMBA_CACHE_DIR"):
        roots.append(Path(os.environ["NUMBA_CACHE_DIR"]))
    since = source.stat().st_mtime
    for root in roots:
        if not root.is_dir():
            continue
        pattern = f"**/{source.stem}.*.nbi" if root != roots[0] else f"{source.stem}.*.nbi"
        if any(index.stat().st_mtime >= since for index in root.glob(pattern)):
            return True
    return False


def cold_kernels() -> list[str]:
    """The kernel modules (:data:`KERNEL_MODULES`) that numba has not cached yet: the next run compiles them.

    Empty when every one is cached, or when their files cannot be found or read (say nothing then).
    """
    package = Path(__file__).resolve().parents[1]
    cold = []
    for name in KERNEL_MODULES:
        try:
            if not _cached(package / name):
                cold.append(name)
        except OSError:  # not found, not readable: say nothing
            continue
    return cold
