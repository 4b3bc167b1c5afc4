"""Which study figures are up to date (``figures/index.json``), and the :class:`Figure` record of one.

A figure is drawn again only when what it shows changed: the index keeps the
digest of each figure's inputs (wall times left out) and of the code that
draws it (:func:`nlid.study.report.codedigest.code_digest`).
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ...report.plotting import save_figure
from ...runtime.outputs import atomic_write
from .. import columns as col

__all__ = ["Figure", "FigureCache", "input_digest"]


class Figure:
    """A written figure: title, caption and the path without suffix."""

    def __init__(self, title: str, stem: Path, caption: str = "") -> None:
        self.title, self.stem, self.caption = title, stem, caption

    @property
    def png(self) -> Path:
        """The PNG file."""
        return self.stem.with_suffix(".png")


#: Keys of a stored result that are wall times, not results (a figure that drew them would show the time).
_VOLATILE = (col.SECONDS.key(), "timings_s")


def _feed(h: Any, value: Any) -> None:
    """Hash ``value`` (nested dicts, sequences, arrays, frames and scalars) into ``h``, each with its type."""
    if isinstance(value, np.ndarray):
        h.update(f"a{value.dtype.str}{value.shape}".encode())
        h.update(np.ascontiguousarray(value).tobytes())
    elif isinstance(value, pd.DataFrame):
        h.update(b"f")
        h.update(value.to_csv(index=False).encode())  # floats as repr: exact
    elif isinstance(value, dict):
        h.update(f"d{len(value)}".encode())
        for key in sorted(value, key=str):
            if key in _VOLATILE:
                continue
            _feed(h, str(key))
            _feed(h, value[key])
    elif isinstance(value, (list, tuple)):
        h.update(f"l{len(value)}".encode())
        for item in value:
            _feed(h, item)
    else:
        h.update(f"s{type(value).__name__}:{value!r};".encode())


def input_digest(*parts: Any) -> str:
    """A digest of what a figure is drawn from (wall-time keys, :data:`_VOLATILE`, left out)."""
    h = hashlib.sha256()
    for part in parts:
        _feed(h, part)
    return h.hexdigest()


class FigureCache:
    """Which figures of a study folder are up to date: ``figures/index.json`` maps a figure to its inputs' digest.

    A figure is drawn (PNG and SVG) only when its digest (:func:`input_digest` of what it shows, and of
    the code that draws it) differs from the one stored, or its files are missing. The index is written
    after the figures, so a report killed half-way redraws what it had not recorded.

    Parameters
    ----------
    folder
        The figures folder (created when a figure is written).
    code
        The digest of the code that draws (:func:`nlid.study.report.codedigest.code_digest`; default: nlid's).
    """

    INDEX = "index.json"

    def __init__(self, folder: Path, code: str | None = None) -> None:
        self.folder = Path(folder)
        if code is None:
            from .codedigest import code_digest

            code = code_digest()
        self.code = code
        self.stored: dict[str, str] = {}
        try:
            loaded = json.loads((self.folder / self.INDEX).read_text())
            if isinstance(loaded, dict):
                self.stored = {str(k): str(v) for k, v in loaded.items()}
        except (OSError, ValueError, RecursionError):
            pass
        self.current: dict[str, str] = {}
        self.drawn: list[str] = []
        self.reused: list[str] = []

    def key(self, *parts: Any) -> str:
        """The digest of a figure's inputs, with the drawing code's."""
        return input_digest(self.code, *parts)

    def fresh(self, stem: Path, key: str) -> bool:
        """True when ``stem`` was drawn from the same inputs and its files are there (then it is kept)."""
        ok = self.stored.get(stem.name) == key and all(stem.with_suffix(s).is_file() for s in (".png", ".svg"))
        if ok:
            self.current[stem.name] = key
            self.reused.append(stem.name)
        return ok

    def save(self, fig: Any, stem: Path, key: str) -> None:
        """Write ``fig`` (:func:`nlid.report.plotting.save_figure`) and record its digest."""
        save_figure(fig, stem)
        self.current[stem.name] = key
        self.drawn.append(stem.name)

    def write_index(self) -> None:
        """Store the digests of this report's figures (atomically)."""
        if not self.current and not (self.folder / self.INDEX).exists():
            return
        self.folder.mkdir(parents=True, exist_ok=True)
        path = self.folder / self.INDEX
        atomic_write(path, json.dumps(self.current, indent=1, sort_keys=True).encode())
