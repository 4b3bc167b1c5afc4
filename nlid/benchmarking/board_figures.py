"""A figure per test set: the RMSE of every leaderboard row on a log axis, the kinds of rows told apart.

nlid's rows are filled circles, the peers' squares, the published figures diamonds (hollow when
scored under another rule), the true model a star; the noise floor is a dashed vertical line. The
caption, under the axes, says the unit, the axis and the rule once. Figures are drawn with the
object-oriented API (:mod:`nlid.report.plotting`: no ``pyplot``) and written as PNG and SVG (the SVG
without a date, so the same rows give the same file).
"""

from __future__ import annotations

import io
import math
import textwrap
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from .board_rows import figure_name, groups, rule_text, who
from .declarations import Protocol

__all__ = ["STYLES", "table_figure", "write_figures"]

#: Marker, colour and legend label of each kind of row.
STYLES: dict[str, dict[str, str]] = {
    "nlid": {"marker": "o", "color": "#1f5fa8", "label": "nlid"},
    "truth": {"marker": "*", "color": "#2a8a3e", "label": "true model"},
    "peer": {"marker": "s", "color": "#d9730d", "label": "peer (another tool)"},
    "published": {"marker": "D", "color": "#6b6b6b", "label": "published"},
}


def _value(x: Any) -> float:
    try:
        return float(x)
    except (TypeError, ValueError):
        return math.nan


def table_figure(rows: Sequence[Mapping[str, Any]], caption: str) -> Any:
    """The figure of one test set's rows (a :class:`matplotlib.figure.Figure`), or ``None`` with no figure to draw."""
    from ..report.plotting import new_figure

    points = [r for r in rows if r["kind"] in STYLES and math.isfinite(_value(r["rmse"])) and _value(r["rmse"]) > 0]
    floors = [r for r in rows if r["kind"] == "reference" and math.isfinite(_value(r["rmse"]))]
    if not points:
        return None
    points = sorted(points, key=lambda r: _value(r["rmse"]))
    fig, ax = new_figure(width=7.2, height=1.6 + 0.32 * len(points))
    for i, r in enumerate(points):
        style = STYLES[r["kind"]]
        hollow = not r.get("same_rule", True)
        ax.plot(
            [_value(r["rmse"])],
            [i],
            linestyle="none",
            marker=style["marker"],
            markersize=11 if r["kind"] == "truth" else 8,
            markerfacecolor="white" if hollow else style["color"],
            markeredgecolor=style["color"],
        )
    for r in floors:
        ax.axvline(_value(r["rmse"]), color="#999999", linestyle="--", linewidth=1.0)
    from matplotlib.ticker import NullFormatter

    values = [_value(r["rmse"]) for r in points] + [_value(r["rmse"]) for r in floors]
    ax.set_xscale("log")
    ax.set_xlim(10 ** math.floor(math.log10(min(values) / 1.2)), 10 ** math.ceil(math.log10(max(values) * 1.2)))
    ax.xaxis.set_minor_formatter(NullFormatter())  # decades only: the axis spans at least one
    ax.set_yticks(range(len(points)))
    ax.set_yticklabels([textwrap.shorten(who(r), 46, placeholder="...") for r in points])
    ax.set_ylim(len(points) - 0.5, -0.5)
    ax.grid(True, axis="x", which="both", color="#e5e5e5")
    ax.set_xlabel(f"free-run RMSE ({points[0]['unit']}), log axis")
    handles = _legend(points, floors)
    ax.legend(
        handles=handles, loc="lower left", bbox_to_anchor=(0.0, 1.01), ncol=min(4, len(handles)), fontsize="small"
    )
    ax.get_legend().set_frame_on(False)
    fig.supxlabel(textwrap.fill(caption, 110), fontsize="small", x=0.01, ha="left")
    return fig


def _legend(points: Sequence[Mapping[str, Any]], floors: Sequence[Mapping[str, Any]]) -> list[Any]:
    """One entry per kind of row shown (filled), one for a hollow marker and one for a noise floor when shown."""
    from matplotlib.lines import Line2D

    kinds = [k for k in STYLES if any(r["kind"] == k for r in points)]
    handles = [
        Line2D([], [], linestyle="none", marker=STYLES[k]["marker"], color=STYLES[k]["color"], label=STYLES[k]["label"])
        for k in kinds
    ]
    if any(not r.get("same_rule", True) for r in points):
        handles.append(
            Line2D([], [], linestyle="none", marker="o", color="#6b6b6b", markerfacecolor="white", label="other rule")
        )
    if floors:
        handles.append(Line2D([], [], color="#999999", linestyle="--", label=str(floors[0]["pipeline"])))
    return handles


def caption(protocol: Protocol, test: str, rows: Sequence[Mapping[str, Any]]) -> str:
    """The figure's caption: what is plotted, the rule once, what a hollow marker means."""
    rule = rule_text(rows).replace("`", "")
    return (
        f"{protocol.name} / {test}: free-run RMSE of every row ({rows[0]['unit']}, log axis), best at the top. "
        f"Rule {rule}. Hollow markers: scored under another rule."
    )


def write_figures(folder: Path, protocols: Mapping[str, Protocol], rows: Sequence[Mapping[str, Any]]) -> dict:
    """Write ``<benchmark>--<test>.png`` and ``.svg`` per test set into ``folder``.

    Returns
    -------
    dict
        ``{(benchmark, test): svg text}`` (for the HTML page to inline).
    """
    from matplotlib import rc_context

    out: dict[tuple[str, str], str] = {}
    for bench, test, group in groups(rows):
        protocol = protocols.get(bench)
        if protocol is None:
            continue
        fig = table_figure(group, caption(protocol, test, group))
        if fig is None:
            continue
        folder.mkdir(parents=True, exist_ok=True)
        stem = folder / figure_name(bench, test)
        fig.savefig(stem.with_suffix(".png"), dpi=110)
        buffer = io.StringIO()
        with rc_context({"svg.hashsalt": stem.name, "svg.fonttype": "none"}):  # stable ids; text as text
            fig.savefig(buffer, format="svg", metadata={"Date": None})
        svg = buffer.getvalue()
        stem.with_suffix(".svg").write_text(svg)
        out[(bench, test)] = svg[svg.index("<svg") :]
    return out
