"""discover's acceptance rule is ``accept=``; ``rule=`` means the transient rule everywhere else (issue 35)."""

from __future__ import annotations

import pytest

import nlid
from nlid.discovery import AcceptanceRule, Discovery, discover
from nlid.discovery.structure import discover_structure
from nlid.errors import InputError


@pytest.fixture(scope="module")
def record(short_record):
    return short_record


def test_accept_takes_the_acceptance_rule():
    chosen = AcceptanceRule(min_explained=0.3, max_delta_bic=-20.0)
    assert Discovery("rfs", mass=0.2, accept=chosen).rule is chosen


@pytest.mark.parametrize("value", ["window:50", 0.1, {"min_explained": 0.2}])
def test_a_wrong_accept_is_an_input_error_naming_it(record, value):
    with pytest.raises(InputError, match=r"^accept= must be an AcceptanceRule"):
        discover(record, "z, v", "rfs", mass=0.2, accept=value)
    with pytest.raises(InputError, match=r"^accept= must be an AcceptanceRule"):
        Discovery("rfs", mass=0.2, accept=value)


@pytest.mark.parametrize("call", ["discover", "nlid.discover", "Discovery", "discover_structure"])
def test_a_transient_rule_given_as_rule_names_the_new_keywords(record, call):
    """The old keyword given a string used to end in AttributeError: 'str' object has no attribute 'min_explained'."""
    with pytest.raises(InputError, match=r"rule= is not a setting of discover.*accept=.*freerun_rule="):
        if call == "discover":
            discover(record, "z, v", "rfs", mass=0.2, rule="window:50")
        elif call == "nlid.discover":
            nlid.discover(record, "z, v", "rfs", mass=0.2, rule="first-sample")
        elif call == "Discovery":
            Discovery("rfs", mass=0.2, rule="window:50")
        else:
            discover_structure(record, "", rule="window:50")


def test_an_acceptance_rule_given_as_rule_still_works_with_a_warning():
    chosen = AcceptanceRule(min_explained=0.2)
    with pytest.warns(DeprecationWarning, match="now accept="):
        search = Discovery("rfs", mass=0.2, rule=chosen)
    assert search.rule is chosen
    with pytest.raises(InputError, match="rule= is not a setting"):  # both: ambiguous
        Discovery("rfs", mass=0.2, rule=chosen, accept=chosen)
