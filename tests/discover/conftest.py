"""Simulated records with one undeclared effect, on a double well and on a single well.

``make_case(well, effect)`` returns a preset whose true model is the well's
base model plus (or minus) one effect of the library, and the declared model
that lacks exactly that effect (``effect="none"``: the declared model is
complete). Effect sizes are a few newtons (a few % to a few tens of % of the
restoring force), the size of a friction or stiffness term worth finding.
"""

from __future__ import annotations

import dataclasses

import pytest

from nlid.presets import Preset, get_preset

G = 9.81

#: The double well: paper-numerical without its quadratic damping, 20 s at 1024 Hz.
DOUBLE = get_preset("paper-numerical").with_overrides(fs=1024.0, duration=20.0)
#: A single-well (hardening) Duffing oscillator: fn = 15.9 Hz, force 20 N RMS, 20 s at 1024 Hz.
SINGLE = Preset(
    name="single-well",
    description="single-well hardening Duffing oscillator with viscous damping",
    terms="z^3",
    coefficients={"z": 2000.0, "z^3": 5e6, "v": 2.0, "1": 0.2 * G},
    mass=0.2,
    g=G,
    fs=1024.0,
    duration=20.0,
    force_rms=20.0,
)

#: effect -> (true terms added to the base model, declared model leaves out these terms
#: (default: the added ones)).
EFFECTS = {
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
#: Stribeck friction (next to declared Coulomb friction) sized per well: a law strong
#: enough to be seen through a velocity estimated from a 1 %-noisy displacement, and
#: weak enough not to make the lighter single-well system stick.
STRIBECK = {
    "double": ({"sign(v)": 1.0, "sign(v)*exp(-(v/0.3)^2)": 8.0}, ["sign(v)*exp(-(v/0.3)^2)"]),
    "single": ({"sign(v)": 1.0, "sign(v)*exp(-(v/0.2)^2)": 4.0}, ["sign(v)*exp(-(v/0.2)^2)"]),
}


def build_case(well: str, effect: str) -> tuple[Preset, list[str]]:
    """The true preset and the declared terms lacking ``effect``."""
    base = DOUBLE if well == "double" else SINGLE
    extra, leave_out = STRIBECK[well] if effect == "stribeck" else EFFECTS[effect]
    coefficients = dict(base.coefficients)
    coefficients.pop("v*|v|", None)  # the double well's own quadratic damping is not part of the base
    coefficients.update(extra)
    user_terms = ", ".join(t for t in coefficients if t not in ("1", "z", "v"))
    preset = dataclasses.replace(base, name=f"{well}-{effect}", terms=user_terms, coefficients=coefficients)
    leave_out = list(extra) if leave_out is None else leave_out
    declared = [t for t in coefficients if t not in leave_out]
    return preset, declared


@pytest.fixture(scope="session")
def make_case():
    """``make_case(well, effect, channels, seed) -> (record with 1 % noise, declared terms)``."""

    def make(well: str, effect: str, channels: tuple[str, ...], seed: int):
        preset, declared = build_case(well, effect)
        return preset.simulate(seed, noise=0.01, channels=channels), declared

    return make
