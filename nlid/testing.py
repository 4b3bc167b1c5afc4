"""A compliance check for identifier plugins.

Third-party authors call :func:`check_identifier` from their own tests::

    from nlid.testing import check_identifier
    from my_plugin import MyIdentifier

    def test_contract():
        check_identifier(MyIdentifier)

It checks the contract the core relies on (attributes, declared options,
option validation, result type and fields, coefficient keys, JSON round trip,
determinism, bad input) on a short noise-free record of the
``paper-numerical`` preset, and - when ``accuracy`` is given - that the
coefficients are recovered within that relative tolerance.
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np

from .errors import InputError, NlidError, OptionError
from .interface import IdentificationResult
from .pipeline import identify
from .presets import get_preset
from .registry import check_contract
from .terms import Model

__all__ = ["check_identifier", "contract_record"]


def contract_record(duration: float = 10.0, seed: int = 0, channels: tuple[str, ...] = ("z", "v", "a")):
    """A short noise-free ``paper-numerical`` record with exact channels."""
    return get_preset("paper-numerical").with_overrides(duration=duration).simulate(seed, channels=channels)


def check_identifier(
    cls: type,
    *,
    options: dict[str, Any] | None = None,
    terms: str = "z^3, z^2, v*|v|",
    accuracy: float | None = None,
    record=None,
) -> IdentificationResult:
    """Check that an identifier class honours nlid's plugin contract.

    Parameters
    ----------
    cls
        The identifier class.
    options
        Options to construct it with.
    terms
        Model terms for the check.
    accuracy
        If given, every coefficient must be within this relative error of the
        truth (e.g. ``1e-3``).
    record
        Record to use (default :func:`contract_record`).

    Returns
    -------
    IdentificationResult
        The result of the check run.

    Raises
    ------
    AssertionError
        Describing the first broken rule.
    """
    check_contract(cls)
    for opt in cls.options:
        if opt.default is not None:
            assert opt.parse(opt.default) == opt.default, f"option {opt.name!r}: default does not validate"
    try:
        cls(**{"no_such_option_xyz": 1})
    except OptionError:
        pass
    else:
        raise AssertionError("an unknown option must raise nlid.OptionError")

    record = record if record is not None else contract_record()
    model = Model.from_spec(terms)
    mass = record.mass if cls.needs_mass else None
    first = identify(record, model, cls(**dict(options or {})), mass=mass)
    assert isinstance(first, IdentificationResult), "identify() must return an IdentificationResult"
    assert list(first.coefficients) == list(model.names), "coefficients must be keyed by canonical term, in order"
    assert all(np.isfinite(list(first.coefficients.values()))), "coefficients must be finite"
    assert first.method == cls.name, f"result.method is {first.method!r}, expected {cls.name!r}"
    if not cls.needs_mass:
        assert first.mass is not None and first.mass > 0, "a method that estimates the mass must return it"
    text = json.dumps(first.to_dict(), allow_nan=False)
    again = IdentificationResult.from_dict(json.loads(text))
    assert again.coefficients == first.coefficients, "to_dict()/from_dict() must round-trip"
    second = identify(record, model, cls(**dict(options or {})), mass=mass)
    assert second.coefficients == first.coefficients, "identification must be deterministic"

    bad = record.without("v", "a")
    try:
        identify(bad[: len(bad) // 4], model, cls(**dict(options or {})), mass=mass)
    except NlidError:
        pass  # refusing a short, displacement-only record with a clear error is fine
    try:
        identify(record, "z^3, no_such_term", cls(**dict(options or {})), mass=mass)
    except InputError:
        pass
    else:
        raise AssertionError("an unknown term must raise nlid.InputError")

    if accuracy is not None:
        truth = record.meta["truth"]["coefficients"]
        for name, value in first.coefficients.items():
            rel = abs(value / truth[name] - 1.0)
            assert rel <= accuracy, (
                f"{name}: {value:.6g} vs true {truth[name]:.6g} ({100 * rel:.3g} % > {100 * accuracy:g} %)"
            )
    return first
