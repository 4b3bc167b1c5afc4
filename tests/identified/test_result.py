"""The results' one base (:class:`nlid.identified.result.Identified`): what both forms share and how the core
tells them apart (``fit.indexed``, as ``record.indexed``), issue 32."""

from __future__ import annotations

import json

import numpy as np
import pytest

from nlid.errors import InputError
from nlid.identification.structure_fit import as_elements
from nlid.identified.model import IdentifiedModel
from nlid.identified.result import Identified
from nlid.identified.structure import IdentifiedStructure
from nlid.model.structure import StructuralModel
from nlid.model.terms import Model

PAIR = "(z1-z2)^3"


def _one(**fields) -> IdentifiedModel:
    return IdentifiedModel(Model.from_spec("z^3", defaults=False), {"z^3": 1.0}, 1.0, "probe", **fields)


def _many(**fields) -> IdentifiedStructure:
    elements = as_elements(PAIR, 2, without="1")
    structure = StructuralModel(np.eye(2), np.eye(2), 2 * np.eye(2), elements, {PAIR: 1.0})
    return IdentifiedStructure(structure=structure, method="probe", **fields)


def test_both_forms_are_results_and_say_which_form_they_are():
    one, many = _one(), _many()
    assert isinstance(one, Identified) and isinstance(many, Identified)
    assert (one.indexed, one.n_dofs) == (False, 1)
    assert (many.indexed, many.n_dofs) == (True, 2)
    with pytest.raises(AttributeError):
        one.indexed = True  # read-only, as record.indexed


def test_the_shared_fields_are_frozen_the_same_way_on_both():
    fields = {
        "options": {"order": [1, 2]},
        "diagnostics": {"k": {"nested": 1}},
        "warnings": ["w", 3],
        "flags": [{"code": "zeta", "message": "m", "cause": "c"}],
        "arrays": {"a": np.arange(2.0)},
        "provenance": {"nlid": "x"},
    }
    one, many = _one(**fields), _many(**fields)
    for fit in (one, many):
        assert fit.warnings == ("w", "3") and fit.flags[0].code == "zeta"
        with pytest.raises(TypeError):
            fit.options["order"] = 3
        with pytest.raises(TypeError):
            fit.diagnostics["k"]["nested"] = 2
    assert one._shared_dict() == many._shared_dict() | {"z_range": None}


def test_both_layouts_end_with_the_same_fields_in_the_same_order():
    one = _one(seconds=1.5, warnings=["w"], z_range=(-1.0, 1.0))
    many = _many(seconds=1.5, warnings=["w"], z_range=((-1.0, 1.0), (-2.0, 2.0)))
    a, b = list(one.to_dict()), list(many.to_dict())
    tail = ["options", "diagnostics", "warnings", "seconds", "z_range", "provenance"]
    assert a[-len(tail) :] == tail and b[-len(tail) :] == tail
    assert json.loads(json.dumps(many.to_dict()))["z_range"] == [[-1.0, 1.0], [-2.0, 2.0]]


def test_the_summaries_end_the_same_way():
    flag = {"code": "zeta", "message": "negative damping", "cause": "a unit slip"}
    for fit in (
        _one(seconds=2.0, warnings=["look"], flags=[flag]),
        _many(seconds=2.0, warnings=["look"], flags=[flag]),
    ):
        text = str(fit.summary()).splitlines()
        assert [line.split()[0].rstrip(":") for line in text[-3:]] == ["time", "warning", "NOT"]
        assert repr(fit).endswith("; NOT TRUSTED: zeta>")


def test_the_posterior_refuses_what_is_not_a_result_by_name():
    from nlid.bayes.inference import sample_posterior

    with pytest.raises(InputError, match="fit must be the IdentifiedModel nlid.identify returns, got dict"):
        sample_posterior(None, {"coefficients": {}})
