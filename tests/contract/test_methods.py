"""The core picks identifiers by their attributes (nlid.contract.methods), never by name; the built-ins state today's
choices."""

from __future__ import annotations

from pathlib import Path

import pytest

from nlid.contract.identifier import Identifier
from nlid.contract.methods import advice_of, choose_method, choose_refiner, doc_pages, ranked
from nlid.contract.registry import Registry, default_registry
from nlid.errors import InputError

ROOT = Path(__file__).resolve().parents[2]


def _identifier(name: str, **attributes) -> type:
    return type(name.title(), (Identifier,), {"name": name, "summary": f"the {name} method", **attributes})


def test_ranked_puts_the_unranked_last_alphabetically():
    ids = {
        "b": _identifier("b"),
        "a": _identifier("a"),
        "late": _identifier("late", preference=30),
        "first": _identifier("first", preference=10),
        "flag": _identifier("flag", preference=True),  # a bool is not a rank
    }
    assert ranked(ids) == ["first", "late", "a", "b", "flag"]


def test_choose_method_follows_preference_and_skips_what_needs_a_mass():
    reg = Registry(
        identifiers={
            "zzz": _identifier("zzz"),
            "exact": _identifier("exact", preference=1, needs_mass=True),
            "rough": _identifier("rough", preference=2),
        }
    )
    name, notes = choose_method(None, reg)
    assert name == "rough" and notes[0].startswith("skipped 'exact'")
    assert "preference order exact, rough; installed: exact, rough, zzz" in notes[-1]
    assert choose_method(0.2, reg)[0] == "exact"
    with pytest.raises(InputError, match="no installed identifier can run without the mass"):
        choose_method(None, Registry(identifiers={"exact": _identifier("exact", needs_mass=True)}))


def test_choose_refiner_needs_an_identifier_that_refines():
    reg = Registry(identifiers={"a": _identifier("a", preference=1), "r": _identifier("r", refines=True)})
    assert choose_refiner(reg) == "r"
    with pytest.raises(InputError, match="refines another method's fit"):
        choose_refiner(Registry(identifiers={"a": _identifier("a")}))


def test_advice_defaults_to_the_summary():
    assert advice_of(_identifier("plain")) == "the plain method"
    assert advice_of(_identifier("told", advice="when in doubt")) == "when in doubt"


def test_the_built_ins_keep_todays_order_advice_and_pages():
    ids = default_registry().identifiers
    built_in = ("rfs", "nsi-ip", "sindy", "nsi-shift", "oe")
    if not set(built_in) <= set(ids):
        pytest.skip("the built-in plugins are not all installed")
    assert [n for n in ranked(ids) if n in built_in] == ["rfs", "nsi-ip", "sindy", "nsi-shift", "oe"]
    assert [n for n in ranked(ids, "advice_order") if n in built_in] == ["rfs", "sindy", "nsi-ip", "nsi-shift", "oe"]
    assert choose_method(None)[0] == "rfs" and choose_refiner() == "oe"
    for name in built_in:
        page = doc_pages[name]
        assert (ROOT / page).is_file(), page
        assert ids[name].advice
