"""Units of the channels: a declared vocabulary, converted to SI on the way in.

nlid computes in SI units (N, m, m/s, m/s^2, s). Data measured in other units
are declared, channel by channel, and converted when the record is built:
``units={"z": "mm", "a": "g"}`` on :class:`~nlid.data.record.Record`,
:meth:`Record.from_time <nlid.data.record.Record.from_time>`, :func:`nlid.load`,
:meth:`Record.from_frame <nlid.data.record.Record.from_frame>` and
:meth:`Record.from_table <nlid.data.record.Record.from_table>`; ``--units z=mm,a=g``
on the command line; or ``z[mm]=disp`` in a column map
(:mod:`nlid.data.columnmap`). A unit outside the vocabulary is refused with an
:class:`~nlid.errors.InputError` naming the channel, the unit and the units
accepted, never ignored.

The vocabulary (:data:`VOCABULARY`)
-----------------------------------
========  ==============  ===================================================
channel   quantity        units (SI value of one unit)
========  ==============  ===================================================
``t``     time            ``s``, ``ms`` (1e-3), ``µs`` (1e-6; also ``us``)
``f``     force           ``N``, ``kN`` (1e3), ``mN`` (1e-3)
``z``     displacement    ``m``, ``cm`` (1e-2), ``mm`` (1e-3), ``µm`` (1e-6; also ``um``, ``micron``)
``v``     velocity        ``m/s``, ``cm/s``, ``mm/s``, ``µm/s``
``a``     acceleration    ``m/s^2``, ``cm/s^2``, ``mm/s^2``, ``µm/s^2``, and
                          ``g`` = 9.80665 m/s^2
========  ==============  ===================================================

``g`` is *standard* gravity, g_n = 9.80665 m/s^2 exactly (the definition of
accelerometers' "g"), not the local gravity of a test rig: the model's own
``g`` (``meta["g"]``, the weight ``m g`` of a static load) is a separate
number. ``^2`` may also be written ``²``, ``**2`` or ``2`` (``m/s2``); the
micro sign may be ``µ`` (U+00B5) or the Greek ``μ`` (U+03BC).

``V`` (and ``V/s``, ``V/s^2``) declares an *uncalibrated* signal in volts
(the Silverbox benchmark): it is kept as given, not converted, and the
record's units say so.

After conversion, :attr:`Record.units <nlid.data.record.Record.units>` holds the
SI unit of each channel and ``record.meta["input_units"]`` what each channel
was given in and the factor applied (:meth:`Unit.to_dict`); an
identified model keeps both in its provenance, so its coefficients can be
shown in the units of the data (:func:`coefficient_conversion`,
``fit.summary(units="input")``).

Coefficients in other units
---------------------------
A term's value has the dimensions ``m^M s^-S`` (:attr:`nlid.model.terms.Term.unit`),
where ``S`` is the power of the velocity and ``M - S`` that of the
displacement, so its coefficient is in ``N s^S / m^M``. With a displacement
unit worth ``Lz`` m, a velocity unit worth ``Lv`` m/s and a force unit worth
``F`` N, the coefficient in those units is

    c_units = c_SI * Lz^(M - S) * Lv^S / F

e.g. a stiffness of 2000 N/m is 2 N/mm, a cubic stiffness of 1e9 N/m^3 is
1 N/mm^3 and a quadratic damping of 5 N s^2/m^2 is 5e-6 N s^2/mm^2. Shape
parameters inside a term (``tanh(v/0.01)``, ``gap(z, 0.002)``) stay in SI:
they are part of the term's name.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

from ..base.validate import did_you_mean
from ..errors import InputError

if TYPE_CHECKING:  # pragma: no cover
    from ..model.terms import Term

__all__ = [
    "Unit",
    "VOCABULARY",
    "QUANTITIES",
    "SI",
    "STANDARD_GRAVITY",
    "unit_of",
    "parse_units",
    "accepted",
    "display_units",
    "coefficient_conversion",
    "INDEXED",
]

#: Standard gravity g_n in m/s^2 (exact, by definition): the acceleration unit ``g``.
STANDARD_GRAVITY = 9.80665

#: What each channel measures, as the messages name it.
QUANTITIES: Mapping[str, str] = MappingProxyType(
    {"t": "time", "f": "force", "z": "displacement", "v": "velocity", "a": "acceleration"}
)
#: An indexed channel of a structure: ``f``, ``z``, ``v`` or ``a`` and a DOF number from 1 (``z1``, ``f12``).
INDEXED = re.compile(r"([fzva])([1-9][0-9]*)")
#: The SI unit of each channel.
SI: Mapping[str, str] = MappingProxyType({"t": "s", "f": "N", "z": "m", "v": "m/s", "a": "m/s^2"})


@dataclass(frozen=True)
class Unit:
    """One unit of the vocabulary.

    Attributes
    ----------
    symbol
        The canonical spelling (``"mm"``, ``"m/s^2"``, ``"g"``).
    channel
        The channel it measures (``"t"``, ``"f"``, ``"z"``, ``"v"``, ``"a"``).
    factor
        The value of one unit in :attr:`si` (``0.001`` for ``mm``).
    si
        The unit the values are converted to: the channel's SI unit, or
        ``V``, ``V/s``, ``V/s^2`` for an uncalibrated signal (kept as given).
    length
        For a displacement, velocity or acceleration: the length it is
        written with (``"mm"`` for ``mm/s``); ``None`` for ``g`` and for
        force and time.
    aliases
        Other accepted spellings.
    note
        What the unit is, when its symbol does not say it all.
    """

    symbol: str
    channel: str
    factor: float
    si: str
    length: str | None = None
    aliases: tuple[str, ...] = ()
    note: str = ""

    @property
    def is_si(self) -> bool:
        """True when values in this unit are kept as they are (factor 1, the symbol of the SI unit)."""
        return self.factor == 1.0 and self.symbol == self.si

    def to_dict(self) -> dict[str, Any]:
        """``{"unit", "si", "factor"}``: what a channel was given in, what it became, and the factor applied."""
        return {"unit": self.symbol, "si": self.si, "factor": self.factor}


def _build() -> tuple[dict[str, tuple[Unit, ...]], dict[tuple[str, str], Unit]]:
    lengths = (("m", 1.0, ()), ("cm", 1e-2, ()), ("mm", 1e-3, ()), ("µm", 1e-6, ("um", "μm", "micron")))
    per: dict[str, list[Unit]] = {c: [] for c in QUANTITIES}
    per["t"] += [
        Unit("s", "t", 1.0, "s"),
        Unit("ms", "t", 1e-3, "s"),
        Unit("µs", "t", 1e-6, "s", aliases=("us", "μs")),
    ]
    per["f"] += [Unit("N", "f", 1.0, "N"), Unit("kN", "f", 1e3, "N"), Unit("mN", "f", 1e-3, "N")]
    for name, factor, aliases in lengths:
        micro = [a for a in aliases if a != "micron"]
        per["z"].append(Unit(name, "z", factor, "m", length=name, aliases=aliases))
        per["v"].append(Unit(f"{name}/s", "v", factor, "m/s", length=name, aliases=tuple(f"{a}/s" for a in micro)))
        spellings = [f"{n}/s{sq}" for n in (name, *micro) for sq in ("^2", "²", "**2", "2")]
        per["a"].append(Unit(f"{name}/s^2", "a", factor, "m/s^2", length=name, aliases=tuple(spellings[1:])))
    per["a"].append(Unit("g", "a", STANDARD_GRAVITY, "m/s^2", note="standard gravity, 9.80665 m/s^2"))
    # an uncalibrated signal in volts: kept as given
    volts = {"f": "V", "z": "V", "v": "V/s", "a": "V/s^2"}
    for channel, symbol in volts.items():
        aliases = (f"V/s{sq}" for sq in ("²", "**2", "2")) if channel == "a" else ()
        per[channel].append(
            Unit(
                symbol,
                channel,
                1.0,
                symbol,
                length="V" if channel != "f" else None,
                aliases=tuple(aliases),
                note="an uncalibrated signal in volts, kept as given",
            )
        )
    lookup: dict[tuple[str, str], Unit] = {}
    for channel, units in per.items():
        for unit in units:
            for spelling in (unit.symbol, *unit.aliases):
                lookup[(channel, spelling)] = unit
    return {c: tuple(u) for c, u in per.items()}, lookup


_PER_CHANNEL, _LOOKUP = _build()
#: The units each channel accepts, canonical spellings, SI first.
VOCABULARY: Mapping[str, tuple[Unit, ...]] = MappingProxyType(_PER_CHANNEL)


def accepted(channel: str) -> str:
    """The units ``channel`` accepts, as a message lists them: ``"m, cm, mm, µm (or um), V"``."""
    parts = []
    for unit in VOCABULARY[channel]:
        text = unit.symbol
        ascii_ = [a for a in unit.aliases if a.startswith("u")]
        if ascii_:
            text += f" (or {ascii_[0]})"
        if unit.symbol == "g":
            text += " (standard gravity)"
        parts.append(text)
    return ", ".join(parts)


def unit_of(channel: str, text: Any, *, where: str = "units", indexed: bool = False) -> Unit:
    """The :class:`Unit` named ``text`` for ``channel``.

    Parameters
    ----------
    channel
        ``"t"``, ``"f"``, ``"z"``, ``"v"`` or ``"a"``; with ``indexed``, also
        a channel of one DOF of a structure (``"z2"``: the vocabulary of ``z``).
    text
        The unit as written (surrounding spaces ignored).
    where
        What gave it, for the message (``"units"``, ``"column map"``).
    indexed
        Accept indexed channels (``z1``, ``f2``...).

    Raises
    ------
    InputError
        An unknown channel, or a unit outside the vocabulary (one line naming
        the channel, the unit and the units accepted).
    """
    group = channel
    if indexed and channel not in QUANTITIES:
        m = INDEXED.fullmatch(channel) if isinstance(channel, str) else None
        group = m.group(1) if m else channel
    if group not in QUANTITIES:
        extra = " (f1, z1, v1, a1... for the DOFs of a structure)" if indexed else ""
        raise InputError(f"{where}: unknown channel {channel!r}; channels are {', '.join(QUANTITIES)}{extra}")
    if not isinstance(text, str):
        raise InputError(
            f"{where}: the unit of {channel!r} must be a string such as {VOCABULARY[group][1].symbol!r}, "
            f"got {type(text).__name__}"
        )
    spelled = "".join(text.split())
    unit = _LOOKUP.get((group, spelled))
    if unit is not None:
        return unit
    quantity = QUANTITIES[group]
    elsewhere = [c for c in QUANTITIES if (c, spelled) in _LOOKUP]
    if elsewhere:
        why = f" ({spelled!r} is a unit of {QUANTITIES[elsewhere[0]]}, channel {elsewhere[0]!r})"
    else:
        folded = [u.symbol for u in VOCABULARY[group] if u.symbol.lower() == spelled.lower()]
        hint = (
            f" (did you mean {folded[0]!r}?)"
            if folded
            else did_you_mean(spelled, [u.symbol for u in VOCABULARY[group]])
        )
        why = hint
    shown = spelled if len(spelled) <= 40 else spelled[:37] + "..."
    raise InputError(
        f"{where}: unknown unit {shown!r} for channel {channel!r}{why}; "
        f"the {quantity} {group} accepts {accepted(group)}"
    )


def parse_units(
    spec: str | Mapping[str, Any] | None, *, where: str = "units", indexed: bool = False
) -> dict[str, Unit]:
    """``{channel: Unit}`` from ``{"z": "mm"}`` or the command line's ``"z=mm,a=g"``.

    With ``indexed``, the channels of a structure's DOFs (``z2``) are accepted too (:func:`unit_of`).

    Raises
    ------
    InputError
        A malformed entry, an unknown channel or unit, or a channel given twice.
    """
    if spec is None:
        return {}
    items: list[tuple[str, Any]]
    if isinstance(spec, str):
        items = []
        for entry in spec.split(","):
            if not entry.strip():
                continue
            if "=" not in entry:
                raise InputError(f"{where}: entry {entry.strip()!r} must look like channel=unit (e.g. z=mm)")
            key, value = entry.split("=", 1)
            items.append((key.strip(), value))
    elif isinstance(spec, Mapping):
        items = [(str(k).strip(), v) for k, v in spec.items()]
    else:
        raise InputError(f"{where} must map channels to units, e.g. {{'z': 'mm'}}, got {type(spec).__name__}")
    out: dict[str, Unit] = {}
    for channel, value in items:
        if channel in out:
            raise InputError(f"{where}: channel {channel!r} is given twice")
        if isinstance(value, Unit) and value.channel == (channel.rstrip("0123456789") if indexed else channel):
            out[channel] = value
        else:
            out[channel] = unit_of(channel, value, where=where, indexed=indexed)
    return out


def display_units(units: str | Mapping[str, Any] | None, given: Mapping[str, Any] | None = None) -> dict[str, Unit]:
    """The units coefficients are shown in: ``f``, ``z`` and ``v``.

    Parameters
    ----------
    units
        ``None`` or ``"SI"`` (N, m, m/s), ``"input"`` (the units the data were
        given in: ``given``), or a mapping / ``"z=mm,f=kN"`` naming some
        channels (the others SI).
    given
        The units of the data, ``{channel: unit or {"unit": ...}}`` (a model's
        provenance), used by ``"input"``.

    Returns
    -------
    dict
        ``{"f": Unit, "z": Unit, "v": Unit}``. A velocity unit not named is
        the displacement's per second (``mm/s`` for ``mm``).
    """
    if units is None or (isinstance(units, str) and units.strip().lower() == "si"):
        chosen: dict[str, Unit] = {}
    elif isinstance(units, str) and units.strip().lower() == "input":
        raw = {c: (u["unit"] if isinstance(u, Mapping) else u) for c, u in dict(given or {}).items()}
        # the channels given in other units than SI (a velocity given in SI follows the displacement's unit)
        chosen = parse_units({c: u for c, u in raw.items() if c in ("f", "z", "v") and u != SI[c]}, where="input units")
    else:
        if isinstance(units, str) and "=" not in units:
            raise InputError(f"units= must be 'SI', 'input' or a mapping such as {{'z': 'mm'}}, got {units!r}")
        chosen = parse_units(units)
    out = {"f": chosen.get("f", _LOOKUP[("f", "N")]), "z": chosen.get("z", _LOOKUP[("z", "m")])}
    if "v" in chosen:
        out["v"] = chosen["v"]
    else:
        length = out["z"].length or "m"
        out["v"] = _LOOKUP[("v", f"{length}/s")]
    return out


def _power(symbol: str, n: int) -> str:
    return symbol if n == 1 else f"{symbol}^{n}"


def coefficient_conversion(term: Term, units: Mapping[str, Unit]) -> tuple[float, str]:
    """``(factor, unit)``: the coefficient of ``term`` in ``units`` is ``factor`` times its SI value.

    Parameters
    ----------
    term
        The term (:class:`nlid.model.terms.Term`).
    units
        ``{"f": Unit, "z": Unit, "v": Unit}`` (:func:`display_units`).

    Returns
    -------
    tuple
        The factor and the unit's text, written as
        :attr:`Term.coefficient_unit <nlid.model.terms.Term.coefficient_unit>`
        writes SI units (``"N*s^2/mm^2"``; ``"N*s/(mm*m)"`` when two lengths
        meet). With SI units: ``(1.0, term.coefficient_unit)``.
    """
    meters, seconds = term._dimensions()  # the powers of m and 1/s of the term's value: the unit algebra
    pz, pv = meters - seconds, seconds  # only the velocity brings 1/s
    force, z, v = units["f"], units["z"], units["v"]
    factor = z.factor**pz * v.factor**pv / force.factor
    lengths: dict[str, int] = {}
    for symbol, power in ((z.length or z.symbol, pz), (v.length or v.symbol, pv)):
        if power:
            lengths[symbol] = lengths.get(symbol, 0) + power
    text = force.symbol
    if seconds:
        text += "*" + _power("s", seconds)
    denominators = [_power(s, p) for s, p in lengths.items() if p]
    if len(denominators) == 1:
        text += "/" + denominators[0]
    elif denominators:
        text += "/(" + "*".join(denominators) + ")"
    return float(factor), text
