"""One hardened check of what a plugin returns, on one DOF and on a structure (issue 32).

Every class of hostile return is given once to :func:`nlid.contract.estimate.check_estimate` (one DOF,
model ``z^3``) and once to :func:`nlid.contract.structure_estimate.check_structure_estimate` (two DOFs,
element ``(z1-z2)^3``): the same exception type and the same one-line message, apart from the name of
the term, or the same normalised content when the value is trimmed or dropped rather than refused.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from nlid.contract.estimate import MAX_WARNING, Estimate, check_estimate
from nlid.contract.structure_estimate import StructureEstimate, check_structure_estimate
from nlid.errors import IdentificationError, PluginError
from nlid.identification.structure_fit import as_elements
from nlid.model.terms import Model

ONE = "z^3"
PAIR = "(z1-z2)^3"


class BrokenFloat(float):
    """A number whose conversion raises: a plugin's own numeric type gone wrong."""

    def __float__(self) -> float:
        raise RuntimeError("no float today")


class Opaque:
    """Neither a number nor JSON."""


class Unreadable(dict):
    """A mapping that breaks when it is read: a plugin's own container gone wrong."""

    def items(self):
        raise RuntimeError("no items today")

    def __iter__(self):
        raise RuntimeError("no keys today")


def _one(coefficient=1.0, **fields) -> Exception | Estimate:
    model = Model.from_spec(ONE, defaults=False)
    fields.setdefault("coefficients", {ONE: coefficient})
    try:
        return check_estimate(Estimate(**fields), model, "probe", mass=1.0)
    except (PluginError, IdentificationError) as exc:
        return exc


def _many(coefficient=1.0, **fields) -> Exception | StructureEstimate:
    elements = as_elements(PAIR, 2, without="1")
    fields.setdefault("coefficients", {PAIR: coefficient})
    fields = {"K": np.eye(2), "C": np.eye(2), **fields}
    try:
        return check_structure_estimate(StructureEstimate(**fields), elements, "probe", np.eye(2))
    except (PluginError, IdentificationError) as exc:
        return exc


def _said(outcome: Exception | object) -> tuple[str, str]:
    assert isinstance(outcome, Exception), f"accepted: {outcome!r}"
    return type(outcome).__name__, str(outcome).replace(PAIR, "TERM").replace(ONE, "TERM")


REFUSED = {
    "a string coefficient": {"coefficient": "oops"},
    "None as coefficient": {"coefficient": None},
    "a bool coefficient": {"coefficient": True},
    "an array coefficient": {"coefficient": np.ones(3)},
    "a complex coefficient": {"coefficient": 1 + 2j},
    "a non-finite coefficient": {"coefficient": math.nan},
    "an infinite coefficient": {"coefficient": 10**400},
    "a number that cannot be read": {"coefficient": BrokenFloat(1.0)},
    "coefficients not a mapping": {"coefficients": [1.0]},
    "a coefficient missing": {"coefficients": {}},
    "a coefficient too many": {"coefficients": {ONE: 1.0, PAIR: 1.0, "x": 2.0}},
    "standard errors not a mapping": {"standard_errors": [0.1]},
    "standard errors of other terms": {"standard_errors": {"nope": 0.1}},
    "a standard error that is text": {"standard_errors": {"TERM": "small"}},
    "warnings as one string": {"warnings": "careful"},
    "a warning that is not a string": {"warnings": ["fine", 3]},
    "an object among the warnings": {"warnings": [Opaque()]},
    "coefficients that break when read": {"coefficients": "UNREADABLE"},
    "standard errors that break when read": {"standard_errors": "UNREADABLE"},
}


def _fields(case: dict, name: str) -> dict:
    """The case's fields, with the term's own name in the standard errors and in exact coefficient keys."""
    out = {}
    for key, value in case.items():
        if key == "standard_errors" and isinstance(value, dict):
            value = {(name if k == "TERM" else k): v for k, v in value.items()}
        if key == "coefficients" and isinstance(value, dict) and len(value) == 3:
            value = {name: 1.0, "zz1": 2.0, "zz2": 3.0}
        if isinstance(value, str) and value == "UNREADABLE":
            value = Unreadable({name: 1.0})
        out[key] = value
    return out


@pytest.mark.parametrize("case", list(REFUSED), ids=list(REFUSED))
def test_a_hostile_return_gets_the_same_line_on_one_dof_and_on_a_structure(case):
    one, many = _said(_one(**_fields(REFUSED[case], ONE))), _said(_many(**_fields(REFUSED[case], PAIR)))
    assert one == many
    assert "\n" not in one[1] and one[1].startswith("identifier 'probe'")


def test_a_runaway_warning_is_cut_the_same_way():
    runaway = "w" * 1_000_000 + "\nsecond line"
    one, many = _one(warnings=[runaway]), _many(warnings=[runaway])
    assert one.warnings == many.warnings
    assert len(one.warnings[0]) <= MAX_WARNING and "\n" not in one.warnings[0]


def test_unserialisable_diagnostics_and_odd_arrays_are_dropped_the_same_way():
    fields = {
        "diagnostics": {"ok": 1.5, "object": Opaque(), "big": "d" * 100},
        "arrays": {"good": np.arange(3.0), "text": np.array(["a", "b"]), 7: np.ones(2)},
    }
    one, many = _one(**fields), _many(**fields)
    assert dict(one.diagnostics) == dict(many.diagnostics) == {"ok": 1.5, "big": "d" * 100}
    assert list(one.arrays) == list(many.arrays) == ["good"]
    assert one.warnings == many.warnings and len(one.warnings) == 2


@pytest.mark.parametrize("field", ["diagnostics", "arrays"])
def test_diagnostics_or_arrays_that_are_not_a_mapping_are_dropped_the_same_way(field):
    one, many = _one(**{field: "not a mapping"}), _many(**{field: "not a mapping"})
    assert not dict(getattr(one, field)) and not dict(getattr(many, field))
    assert one.warnings == many.warnings and len(one.warnings) == 1
    assert one.warnings[0].startswith(f"{field} dropped")


def test_a_return_that_is_no_estimate_is_refused_by_name_on_both():
    """Each form names the type it expects (they differ), in one line naming the identifier."""
    model = Model.from_spec(ONE, defaults=False)
    elements = as_elements(PAIR, 2, without="1")
    with pytest.raises(PluginError) as one:
        check_estimate(None, model, "probe", mass=1.0)
    with pytest.raises(PluginError) as many:
        check_structure_estimate(None, elements, "probe", np.eye(2))
    for said, expected in ((one, "nlid.Estimate"), (many, "StructureEstimate")):
        line = str(said.value)
        assert line.startswith("identifier 'probe' returned NoneType") and expected in line and "\n" not in line


def _result(indexed: bool, error: float) -> object:
    """A result of each form whose one term has the standard error ``error``, as the core drafts it."""
    from nlid.identified.model import IdentifiedModel
    from nlid.identified.structure import IdentifiedStructure
    from nlid.model.structure import StructuralModel

    if not indexed:
        se = {ONE: error}
        return IdentifiedModel(Model.from_spec(ONE, defaults=False), {ONE: 1.0}, 1.0, "probe", standard_errors=se)
    elements = as_elements(PAIR, 2, without="1")
    structure = StructuralModel(np.eye(2), np.eye(2), np.eye(2), elements, {PAIR: 1.0})
    return IdentifiedStructure(structure=structure, method="probe", standard_errors={PAIR: error})


@pytest.mark.parametrize("value", [-0.1, math.nan, math.inf], ids=["negative", "nan", "infinite"])
def test_a_standard_error_that_cannot_be_trusted_is_refused_the_same_way(value):
    """A standard error the contract lets through (a number) but that means nothing: the core refuses both forms."""
    from nlid.identified.plausibility import trusted

    said = []
    for indexed in (False, True):
        with pytest.raises(IdentificationError) as caught:
            trusted(_result(indexed, value), "probe", [], lambda fit: ())
        said.append(str(caught.value).replace(PAIR, "TERM").replace(ONE, "TERM"))
    assert said[0] == said[1]
    assert said[0].startswith("the identification by 'probe' cannot be trusted: standard errors")


def test_a_structure_estimate_comes_back_normalised():
    out = _many(coefficient=np.float32(2.5), standard_errors={PAIR: np.float64(0.1)}, warnings=("a",))
    assert isinstance(out, StructureEstimate)
    assert type(out.coefficients[PAIR]) is float and out.coefficients[PAIR] == 2.5
    assert out.standard_errors == {PAIR: 0.1} and out.warnings == ("a",)
    assert out.elements is not None and list(out.elements.names) == [PAIR]


def test_a_candidate_plugin_needs_only_the_plugin_toolkit():
    """``nlid.plugin`` hands on what the ``nlid_candidates`` hook returns (issue 32, seams)."""
    import nlid.plugin
    from nlid.discovery.library import Candidate, Shape

    assert nlid.plugin.Candidate is Candidate and nlid.plugin.Shape is Shape
    made = nlid.plugin.Candidate("soft", ("tanh(v/{c})",), "tanh friction", nlid.plugin.Shape("v", (0.01, 0.1)))
    assert made.terms == ("tanh(v/{c})",)
