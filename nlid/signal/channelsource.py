"""How a channel was obtained, as plain data: the typed provenance an identifier reports in its diagnostics.

A record's :attr:`~nlid.data.record.Record.provenance` says in one line of text how each channel was
obtained ("measured", "estimated from z: zero-phase low-pass (...; fc=57 Hz) + spectral differentiation").
Text is for people; a program that needs to know whether ``v`` was measured, or the cut-off of the filter
that estimated it (the study's verdict), reads a :class:`ChannelSource` instead: the same line and, when
known, what the channel was derived from, how, by which filter and at which cut-off in Hz.

An identifier reports the sources of the channels it used under the diagnostics key
:data:`CHANNEL_SOURCES`, as JSON (:func:`source_entries`)::

    diagnostics = {CHANNEL_SOURCES: source_entries({"v": ChannelSource.differentiated(used, "z")})}
    # {"channel_sources": {"v": {"measured": False, "text": "estimated from z: ...", "derived_from": "z",
    #                            "operation": "differentiated", "filter": "zero-phase low-pass ...",
    #                            "cutoff_hz": 57.2}}}

and a reader gets them back with :func:`read_channel_sources` (entries that are not such objects are
left out, never guessed from text).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # pragma: no cover
    from .derivatives import DerivativeFilter

__all__ = ["CHANNEL_SOURCES", "ChannelSource", "source_entries", "read_channel_sources"]

#: The diagnostics key under which an identifier reports how its channels were obtained (docs/plugins.md).
CHANNEL_SOURCES = "channel_sources"

#: The one line of a measured channel (``Record.source_of`` of a channel without provenance).
MEASURED = "measured"


@dataclass(frozen=True)
class ChannelSource:
    """How one channel was obtained.

    Attributes
    ----------
    measured
        True when the channel was measured (possibly resampled), False when it was estimated.
    text
        The one line of the record's provenance (``"measured"``, ``"estimated from z: ..."``).
    derived_from
        The channel it was estimated from (``"z"``, ``"a"``, a structure's ``"z2"``), or ``None``
        (measured, or not known).
    operation
        ``"differentiated"`` or ``"integrated"``, or ``None``.
    filter
        The filter that was applied, in words (``DerivativeFilter.describe()``), or ``None``.
    cutoff_hz
        The filter's cut-off in Hz (a low-pass for a derivative, a high-pass for an integral), or ``None``.
    """

    measured: bool
    text: str = MEASURED
    derived_from: str | None = None
    operation: str | None = None
    filter: str | None = None
    cutoff_hz: float | None = None

    @classmethod
    def differentiated(cls, used: DerivativeFilter, source: str = "z") -> ChannelSource:
        """A channel estimated from ``source`` by the differentiating filter ``used``."""
        what = used.describe()
        cutoff = None if used.cutoff is None else float(used.cutoff)
        return cls(False, f"estimated from {source}: {what}", source, "differentiated", what, cutoff)

    @classmethod
    def integrated(cls, highpass_hz: float, source: str = "a") -> ChannelSource:
        """A channel integrated from ``source`` with a zero-phase high-pass at ``highpass_hz`` (drift removed)."""
        what = f"zero-phase high-pass at {highpass_hz:.3g} Hz"
        return cls(False, f"integrated from {source}, {what}", source, "integrated", what, float(highpass_hz))

    @classmethod
    def from_text(cls, text: str, measured: bool) -> ChannelSource:
        """A source known only by its line of text (nothing is read from the text)."""
        return cls(bool(measured), str(text))

    def to_dict(self) -> dict[str, Any]:
        """The JSON object of the diagnostics (every field, ``None`` for what is not known)."""
        return {
            "measured": self.measured,
            "text": self.text,
            "derived_from": self.derived_from,
            "operation": self.operation,
            "filter": self.filter,
            "cutoff_hz": self.cutoff_hz,
        }

    @classmethod
    def from_dict(cls, data: Any) -> ChannelSource | None:
        """The source an object of :meth:`to_dict` describes; ``None`` for anything else (no ``measured`` flag).

        Fields of the wrong type are dropped (a cut-off that is not a positive finite number is ``None``).
        """
        if not isinstance(data, Mapping) or not isinstance(data.get("measured"), bool):
            return None

        def text(key: str) -> str | None:
            value = data.get(key)
            return value if isinstance(value, str) else None

        cutoff = data.get("cutoff_hz")
        ok = isinstance(cutoff, (int, float)) and not isinstance(cutoff, bool) and math.isfinite(cutoff) and cutoff > 0
        return cls(
            data["measured"],
            text("text") or (MEASURED if data["measured"] else "estimated"),
            text("derived_from"),
            text("operation"),
            text("filter"),
            float(cutoff) if ok else None,
        )


def source_entries(sources: Mapping[str, ChannelSource]) -> dict[str, dict[str, Any]]:
    """The value of :data:`CHANNEL_SOURCES` in an identifier's diagnostics: ``{channel: source.to_dict()}``."""
    return {channel: source.to_dict() for channel, source in sources.items()}


def read_channel_sources(diagnostics: Mapping[str, Any]) -> dict[str, ChannelSource]:
    """The channel sources an identifier reported under :data:`CHANNEL_SOURCES` (none: an empty dictionary)."""
    entries = diagnostics.get(CHANNEL_SOURCES)
    if not isinstance(entries, Mapping):
        return {}
    out = {}
    for channel, entry in entries.items():
        source = ChannelSource.from_dict(entry)
        if isinstance(channel, str) and source is not None:
            out[channel] = source
    return out
