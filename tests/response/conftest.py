"""Models with a known response, built once per session: Duffing, the paper's double well, Coulomb, Bouc-Wen."""

from __future__ import annotations

import pytest

from nlid.identified.model import IdentifiedModel
from nlid.model import physics
from nlid.model.terms import Model
from nlid.simulation.presets import get_preset


def oscillator(spec: str, coefficients: dict, mass: float = 1.0, model: Model | None = None) -> IdentifiedModel:
    """A one-DOF model with given coefficients (``z``, ``v``, ``1`` among them), with its equilibria."""
    model = model or Model.from_spec(spec)
    theta = model.vector(dict(coefficients))
    eq = physics.equilibria(model, theta, (-0.05, 0.05)) if not model.uses_memory else None
    return IdentifiedModel(model=model, coefficients=coefficients, mass=mass, method="truth", equilibria=eq)


@pytest.fixture(scope="session")
def make_oscillator():
    """:func:`oscillator`, for tests that build their own."""
    return oscillator


@pytest.fixture(scope="session")
def duffing() -> IdentifiedModel:
    """Hardening Duffing: 1 kg, 1e4 N/m (15.9 Hz), 2 % damping, 5e9 N/m^3."""
    return oscillator("z^3", {"z^3": 5e9, "z": 1e4, "v": 4.0, "1": 0.0})


@pytest.fixture(scope="session")
def double_well() -> IdentifiedModel:
    """The paper's numerical double well (paper-numerical's truth)."""
    p = get_preset("paper-numerical")
    return oscillator("", p.truth()["coefficients"], p.mass, model=p.model())


@pytest.fixture(scope="session")
def coulomb() -> IdentifiedModel:
    """A Duffing spring with Coulomb friction 0.2 N and 1 % viscous damping: at 1 N it slides all the way."""
    return oscillator("z^3, sign(v)", {"z^3": 5e9, "sign(v)": 0.2, "z": 1e4, "v": 2.0, "1": 0.0})


@pytest.fixture(scope="session")
def bouc_wen() -> IdentifiedModel:
    """A softening Bouc-Wen oscillator (weak hysteresis) with a fold near 14 Hz at 3 N."""
    spec = "bouc_wen(20, 200)"
    return oscillator(spec, {spec: 5e3, "z": 5e3, "v": 1.0, "1": 0.0})


@pytest.fixture
def cli(capfd):
    """Run ``nlid ARGS...`` in-process; returns ``(exit status, stdout, stderr)``."""
    from nlid.cli.main import main

    def run(*argv: str) -> tuple[int, str, str]:
        status = main(list(argv))
        out = capfd.readouterr()
        return status, out.out, out.err

    return run
