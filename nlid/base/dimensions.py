"""Units as products of symbols with integer powers: the little algebra every displayed unit goes through.

A record's channels carry units (``N`` and ``m``, or ``V`` and ``V`` for an electrical analogue such as
the Silverbox circuit); a coefficient's unit is the force's unit per unit of its term, a mass the force per
unit of acceleration. Written out naively these give ``V*s^2/V``; :func:`simplify` cancels them to ``s^2``,
the same spelling in every command, figure and JSON. No dependency: a unit is a mapping
``{symbol: power}``, spelled ``a*b^2/c^3`` (``1`` when nothing is left).

Example::

    >>> simplify("V*s^2/V")
    's^2'
    >>> unit_of(("N", 1), ("s", 2), ("m", -2))
    'N*s^2/m^2'
    >>> unit_of(("V", 1), ("V", -3))
    '1/V^2'
"""

from __future__ import annotations

import re

from ..errors import InputError

__all__ = ["parse_unit", "format_unit", "unit_of", "simplify", "coefficient_unit", "mass_unit", "energy_unit"]

_FACTOR = re.compile(r"^([A-Za-zµμ°%]+)(?:\^(-?\d+))?$")


def parse_unit(text: str) -> dict[str, int]:
    """``"N*s^2/m^2"`` as ``{"N": 1, "s": 2, "m": -2}`` (symbols in the order written; ``"1"`` is ``{}``).

    Raises
    ------
    InputError
        A factor that is not ``symbol`` or ``symbol^integer``.
    """
    out: dict[str, int] = {}
    text = str(text).strip()
    numerator, _, denominator = text.partition("/")
    for part, sign in ((numerator, 1), *((d, -1) for d in denominator.split("/") if denominator)):
        for factor in part.split("*"):
            factor = factor.strip()
            if factor in ("", "1"):
                continue
            match = _FACTOR.match(factor)
            if match is None:
                raise InputError(f"unit {text!r}: cannot read the factor {factor!r} (expected e.g. m, s^2)")
            symbol, power = match.group(1), int(match.group(2) or 1)
            out[symbol] = out.get(symbol, 0) + sign * power
    return out


def format_unit(powers: dict[str, int]) -> str:
    """``{"N": 1, "s": 2, "m": -2}`` as ``"N*s^2/m^2"``: positive powers first, in the order given; ``"1"`` if none."""

    def spell(symbol: str, power: int) -> str:
        return symbol if power == 1 else f"{symbol}^{power}"

    up = [spell(s, p) for s, p in powers.items() if p > 0]
    down = [spell(s, -p) for s, p in powers.items() if p < 0]
    text = "*".join(up) or "1"
    return text + ("/" + "/".join(down) if down else "")


def unit_of(*factors: tuple[str, int]) -> str:
    """The product of ``(unit, power)`` factors, each unit itself a product (``"V/s"``), simplified."""
    out: dict[str, int] = {}
    for unit, power in factors:
        for symbol, p in parse_unit(unit).items():
            out[symbol] = out.get(symbol, 0) + p * power
    return format_unit({s: p for s, p in out.items() if p})


def simplify(text: str) -> str:
    """A unit with its symbols cancelled: ``"V*s^2/V"`` -> ``"s^2"``, ``"N*s/m"`` unchanged."""
    return unit_of((text, 1))


def coefficient_unit(length_power: int, time_power: int, force: str = "N", length: str = "m") -> str:
    """The unit of a coefficient whose term has the unit ``length^length_power / s^time_power``.

    ``force / term``: in SI ``N*s^S/m^M`` (``N*s^2/m^2`` for ``v*|v|``); for a record in volts
    (``force="V"``, ``length="V"``) the same, cancelled (``s^2/V``).
    """
    return unit_of((force, 1), ("s", time_power), (length, -length_power))


def mass_unit(force: str = "N", length: str = "m") -> str:
    """The unit of the mass, ``force / acceleration``: ``kg`` in SI, ``s^2`` for a record in volts."""
    unit = unit_of((force, 1), ("s", 2), (length, -1))
    return "kg" if unit == "N*s^2/m" else unit


def energy_unit(force: str = "N", length: str = "m") -> str:
    """The unit of a potential, ``force * length``: ``J`` in SI, ``V^2`` for a record in volts."""
    unit = unit_of((force, 1), (length, 1))
    return "J" if unit == "N*m" else unit
