"""The contract hands each identifier the record it declared it can take (issue 32).

A one-DOF record goes to ``identify(record, model, mass=...)``; for an identifier declaring
``dofs = "multi"`` a structure goes to ``identify_structure(record, elements, mass=...)``, so that no
identifier asks which record it was given. ``Identifier.identify_structure`` passes the structure on to
``identify`` (the contract before it existed), and a class that does not subclass ``Identifier`` is still
called by ``identify``.
"""

from __future__ import annotations

import numpy as np
import pytest

import nlid
from nlid.errors import InputError
from nlid.plugin import ElementSet, Estimate, Identifier, Record, StructureEstimate, StructureRecord


@pytest.fixture(scope="module")
def pair() -> StructureRecord:
    rng = np.random.default_rng(32)
    n = 400
    return StructureRecord(f=rng.normal(size=(n, 2)), z=rng.normal(size=(n, 2)), fs=100.0)


@pytest.fixture(scope="module")
def single() -> Record:
    rng = np.random.default_rng(33)
    n = 400
    return Record(f=rng.normal(size=n), z=rng.normal(size=n), v=rng.normal(size=n), a=rng.normal(size=n), fs=100.0)


def _structure_estimate(elements: ElementSet) -> StructureEstimate:
    return StructureEstimate(coefficients=dict.fromkeys(elements.names, 1.0), K=np.eye(2), C=0.1 * np.eye(2))


class Calls:
    """Each call an identifier receives: ``(method, kind of record, type of model, type of mass)``.

    The kind of an indexed record is ``"StructureRecord"`` (its deprecated alias still answers ``isinstance``).
    """

    seen: list[tuple[str, str, str, str]] = []

    @classmethod
    def note(cls, method: str, record: object, model: object, mass: object) -> None:
        kind = "StructureRecord" if isinstance(record, StructureRecord) else type(record).__name__
        cls.seen.append((method, kind, type(model).__name__, type(mass).__name__))


class Both(Identifier):
    name = "probe-both"
    summary = "one DOF in identify, structures in identify_structure (test)"
    dofs = "multi"

    def identify(self, record, model, *, mass=None):
        Calls.note("identify", record, model, mass)
        return Estimate(coefficients=dict.fromkeys(model.names, 1.0))

    def identify_structure(self, record, elements, *, mass=None):
        Calls.note("identify_structure", record, elements, mass)
        return _structure_estimate(elements)


class OldStyle(Identifier):
    """A third-party identifier written before identify_structure: it takes both in identify."""

    name = "probe-old"
    summary = "both in identify (test)"
    dofs = "multi"

    def identify(self, record, model, *, mass=None):
        Calls.note("identify", record, model, mass)
        if isinstance(model, ElementSet):
            return _structure_estimate(model)
        return Estimate(coefficients=dict.fromkeys(model.names, 1.0))


class NoBase:
    """Declares the contract's attributes without subclassing Identifier."""

    name = "probe-nobase"
    summary = "not an Identifier subclass (test)"
    options = ()
    needs_mass = False
    dofs = "multi"
    settings: dict = {}

    def identify(self, record, model, *, mass=None):
        Calls.note("identify", record, model, mass)
        return _structure_estimate(model)


def _calls(run) -> list[tuple[str, str, str, str]]:
    Calls.seen = []
    run()
    return Calls.seen


def test_each_record_goes_to_its_own_method(pair, single):
    assert _calls(lambda: nlid.identify(pair, "(z1-z2)^3", Both(), mass=np.eye(2))) == [
        ("identify_structure", "StructureRecord", "ElementSet", "ndarray")
    ]
    assert _calls(lambda: nlid.identify(single, "z^3", Both(), mass=1.0)) == [("identify", "Record", "Model", "float")]


@pytest.mark.parametrize("identifier", [OldStyle, NoBase], ids=["subclass", "no base class"])
def test_an_identifier_taking_structures_in_identify_still_gets_them(pair, identifier):
    fits = []
    assert _calls(lambda: fits.append(nlid.identify(pair, "(z1-z2)^3", identifier(), mass=np.eye(2)))) == [
        ("identify", "StructureRecord", "ElementSet", "ndarray")
    ]
    assert dict(fits[0].coefficients) == {"(z1-z2)^3": 1.0}


def test_a_single_dof_identifier_gets_todays_arguments(single):
    class Single(Both):
        name = "probe-single"
        dofs = "single"

    assert _calls(lambda: nlid.identify(single, "z^3", Single(), mass=2.0)) == [
        ("identify", "Record", "Model", "float")
    ]


def test_one_dofs_px_roots_are_refused_on_a_structure(pair):
    with pytest.raises(InputError, match=r"^px_roots= of a structure maps each connection"):
        nlid.identify(pair, "(z1-z2)^3", Both(), mass=np.eye(2), px_roots=(-0.01, 0.01))
