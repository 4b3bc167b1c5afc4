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

import numpy as np

from ..simulation.presets import Preset, get_preset

__all__ = ["WELLS", "EFFECTS", "BOTH_WELLS", "OPEN_WORLD", "build_case", "build_open_case"]

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


#: Cases of issue 13 on the single well: an effect outside the first ten candidates. Each is
#: ``(extra true terms, terms the declared model leaves out or None for the added ones,
#: what should be found)``; "found" names the effect the loop should add first, or the probe
#: that should flag what no candidate can express.
OPEN_WORLD: dict[str, tuple[dict[str, float], list[str] | None, str]] = {
    "hysteresis": ({"bouc_wen(150, -50)": 1000.0}, None, "hysteresis-bouc-wen"),
    "pre-sliding": ({"dahl(0.0005)": 2.0}, None, "dahl-friction"),
    "gap": ({"gap(z, 0.007)": 2000.0}, None, "gap"),
    "product-friction": ({"|z|*sign(v)": 300.0}, None, "dictionary"),
    "wrong-mass": ({}, [], "mass"),
    "time-skew": ({}, [], "input-delay"),
}
#: The wrong-mass case gives the mass this many times the true one.
WRONG_MASS_FACTOR = 1.15
#: The time-skew case delays the recorded force by this many samples.
SKEW_SAMPLES = 2


def build_open_case(effect: str, seed: int, noise: float = 0.02):
    """A single-well record with one effect of :data:`OPEN_WORLD`, the declared terms and the mass to give.

    Returns
    -------
    record : Record
        ``noise`` on ``z`` only (velocity and acceleration estimated).
    declared : list of str
        The model without the effect.
    mass : float
        The mass to give the loop (wrong by :data:`WRONG_MASS_FACTOR` in the ``wrong-mass`` case).
    """
    extra, leave_out, _ = OPEN_WORLD[effect]
    base = WELLS["single"]
    coefficients = {**base.coefficients, **extra}
    user_terms = ", ".join(t for t in coefficients if t not in ("1", "z", "v"))
    preset = dataclasses.replace(base, name=f"single-{effect}", terms=user_terms, coefficients=coefficients)
    leave_out = list(extra) if leave_out is None else leave_out
    declared = [t for t in coefficients if t not in leave_out]
    record = preset.simulate(seed, noise={"z": noise}, channels=("z",))
    mass = preset.mass * (WRONG_MASS_FACTOR if effect == "wrong-mass" else 1.0)
    if effect == "time-skew":
        f = np.concatenate([np.full(SKEW_SAMPLES, record.f[0]), record.f[:-SKEW_SAMPLES]])
        record = record.replace(f=f)
    return record, declared, mass
