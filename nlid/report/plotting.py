"""Figure helpers shared by every part of nlid that draws.

Figures are built with matplotlib's object-oriented API on a
:class:`matplotlib.figure.Figure` (Agg canvas): no ``pyplot``, no global
state, nothing that opens a window or blocks a batch run. matplotlib is
imported only when a figure is made.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

__all__ = ["new_figure", "save_figure"]

#: matplotlib's warning when constrained layout cannot fit a figure's decorations (a legend of 40 methods taller
#: than its axes): it then draws the figure with its default layout, which is what nlid keeps, without the warning.
COLLAPSED = r"constrained_layout not applied because axes sizes collapsed"


def new_figure(nrows: int = 1, ncols: int = 1, *, width: float = 6.4, height: float = 4.0, **kwargs: Any):
    """A figure and its axes (``squeeze=False`` semantics are not applied).

    Returns
    -------
    fig : matplotlib.figure.Figure
    axes : matplotlib.axes.Axes or numpy.ndarray of them
    """
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), layout="constrained")
    axes = fig.subplots(nrows, ncols, **kwargs)
    return fig, axes


def save_figure(fig, stem: str | Path, formats: Sequence[str] = ("png", "svg"), dpi: int = 120) -> list[Path]:
    """Save ``fig`` as ``stem.png``, ``stem.svg`` ... and return the paths.

    The layout (constrained layout: margins in inches, whatever the format)
    is computed when the first format is drawn and kept for the others,
    which then cost only their drawing. A figure whose decorations do not
    fit (matplotlib's "axes sizes collapsed") keeps matplotlib's default
    layout, silently: the warning names nothing a user can act on.
    """
    stem = Path(stem)
    stem.parent.mkdir(parents=True, exist_ok=True)
    paths = []
    engine = fig.get_layout_engine()
    try:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message=COLLAPSED, category=UserWarning)
            for i, fmt in enumerate(formats):
                if i == 1 and engine is not None:
                    fig.set_layout_engine("none")  # the axes keep the positions the first draw gave them
                path = stem.with_suffix(f".{fmt}")
                fig.savefig(path, dpi=dpi)
                paths.append(path)
    finally:
        if engine is not None and fig.get_layout_engine() is not engine:
            fig.set_layout_engine(engine)
    return paths
