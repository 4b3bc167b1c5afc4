"""Simulated records with one undeclared effect (see nlid.discovery.cases)."""

from __future__ import annotations

import pytest

from nlid.discovery.cases import build_case


@pytest.fixture(scope="session")
def make_case():
    """``make_case(well, effect, channels, seed) -> (record with 1 % noise, declared terms)``."""

    def make(well: str, effect: str, channels: tuple[str, ...], seed: int):
        preset, declared = build_case(well, effect)
        return preset.simulate(seed, noise=0.01, channels=channels), declared

    return make
