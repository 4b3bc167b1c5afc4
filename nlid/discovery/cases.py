"""Validation cases: simulated records with one undeclared effect, on a double and a single well.

:func:`build_case` returns a preset whose true model is a base model plus (or
minus) one effect of the library and the declared model that lacks exactly
that effect (``effect="none"``: the declared model is complete). The test
suite and ``benchmarks/bench_discover_cases.py`` run the loop on them.

Base models (20 s at 1024 Hz, force held over each sample):

* ``double``: the paper's numerical example (Sec. 3) without its quadratic
  damping: ``1, z, z^2, z^3, v`` with m = 0.2 kg, 50 N RMS white force;
* ``single``: a hardening single-well Duffing oscillator, k = 2000 N/m,
  k3 = 5e6 N/m^3, c = 2 N s/m, m = 0.2 kg (fn = 15.9 Hz), 20 N RMS.

Effect sizes are a few newtons, a few % to a few tens of % of the restoring
force: the size of a friction or stiffness term worth finding.
"""

from __future__ import annotations

import dataclasses

from ..presets import Preset, get_preset

__all__ = ["WELLS", "EFFECTS", "BOTH_WELLS", "build_case"]

_G = 9.81

#: The base presets.
WELLS: dict[str, Preset] = {
    "double": get_preset("paper-numerical").with_overrides(fs=1024.0, duration=20.0),
    "single": Preset(
        name="single-well",
        description="single-well hardening Duffing oscillator with viscous damping",
        terms="z^3",
        coefficients={"z": 2000.0, "z^3": 5e6, "v": 2.0, "1": 0.2 * _G},
        mass=0.2,
        g=_G,
        fs=1024.0,
        duration=20.0,
        force_rms=20.0,
    ),
}

#: effect -> (true terms added to the base model, terms the declared model leaves out
#: (``None``: the added ones)).
EFFECTS: dict[str, tuple[dict[str, float], list[str] | None]] = {
    "coulomb": ({"sign(v)": 2.0}, None),
    "viscous": ({"v": 3.0}, ["v"]),
    "quadratic-damping": ({"v*|v|": 3.0}, None),
    "cubic-damping": ({"v^3": 1.0}, None),
    "offset": ({}, ["1"]),
    "quadratic-stiffness": ({"z^2": 5e3}, None),
    "cubic-stiffness": ({}, ["z^3"]),
    "quintic-stiffness": ({"z^5": 2e10}, None),
    "position-dependent-friction": ({"sign(v)*|px(z)|": 3.0}, None),
    "none": ({}, []),
}
#: Stribeck friction next to declared Coulomb friction, sized per well: strong
#: enough to be seen through a velocity estimated from a 1 %-noisy
#: displacement, weak enough not to make the lighter single-well system stick
#: (a sticking mass is outside every model of the library).
STRIBECK: dict[str, tuple[dict[str, float], list[str]]] = {
    "double": ({"sign(v)": 1.0, "sign(v)*exp(-(v/0.3)^2)": 8.0}, ["sign(v)*exp(-(v/0.3)^2)"]),
    "single": ({"sign(v)": 1.0, "sign(v)*exp(-(v/0.2)^2)": 4.0}, ["sign(v)*exp(-(v/0.2)^2)"]),
}
#: Effects tested on both wells (position-dependent friction needs the double well).
BOTH_WELLS: tuple[str, ...] = (
    "coulomb",
    "viscous",
    "quadratic-damping",
    "cubic-damping",
    "stribeck",
    "offset",
    "quadratic-stiffness",
    "cubic-stiffness",
    "quintic-stiffness",
)


def build_case(well: str, effect: str) -> tuple[Preset, list[str]]:
    """The true preset and the declared terms lacking ``effect``.

    Parameters
    ----------
    well
        ``"double"`` or ``"single"``.
    effect
        A library name, or ``"none"`` for a complete declared model.
    """
    base = WELLS[well]
    extra, leave_out = STRIBECK[well] if effect == "stribeck" else EFFECTS[effect]
    coefficients = dict(base.coefficients)
    coefficients.pop("v*|v|", None)  # the double well's own quadratic damping is not part of the base
    coefficients.update(extra)
    user_terms = ", ".join(t for t in coefficients if t not in ("1", "z", "v"))
    preset = dataclasses.replace(base, name=f"{well}-{effect}", terms=user_terms, coefficients=coefficients)
    leave_out = list(extra) if leave_out is None else leave_out
    declared = [t for t in coefficients if t not in leave_out]
    return preset, declared
