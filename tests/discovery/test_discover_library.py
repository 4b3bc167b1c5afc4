"""Candidate effects: the library, user candidates, plugins, shape grids."""

from __future__ import annotations

import pluggy
import pytest

from nlid import hookimpl
from nlid.contract import hookspecs
from nlid.discovery import LIBRARY, Candidate, Shape, library_names, resolve_candidates
from nlid.discovery.library import plugin_candidates
from nlid.errors import InputError
from nlid.model.terms import Model

ISSUE_NAMES = [
    "coulomb",
    "viscous",
    "quadratic-damping",
    "cubic-damping",
    "position-dependent-friction",
    "stribeck",
    "offset",
    "linear-stiffness",
    "quadratic-stiffness",
    "cubic-stiffness",
    "quintic-stiffness",
]
# issue 13: non-smooth stiffness and memory, offered only where the probes find structure of their kind
OPEN_WORLD_NAMES = ["gap", "stop-positive", "stop-negative", "hysteresis-bouc-wen", "dahl-friction"]
# issue 31: effects in the input path (nlid.estimation.inputpath), fitted without adding a term
INPUT_PATH_NAMES = ["input-delay", "actuator-lag", "force-hold"]


def test_the_library_has_the_issue_names_and_terms():
    assert library_names() == ISSUE_NAMES + OPEN_WORLD_NAMES + INPUT_PATH_NAMES
    by_name = {c.name: c for c in LIBRARY}
    assert by_name["gap"].terms == ("gap(z, {c})",) and by_name["gap"].requires == ("z", "z,v")
    assert by_name["hysteresis-bouc-wen"].requires == ("memory",) and len(by_name["hysteresis-bouc-wen"].shapes) == 2
    assert all(not by_name[n].requires for n in ISSUE_NAMES)
    by_name = {c.name: c for c in LIBRARY}
    assert by_name["coulomb"].terms == ("sign(v)",)
    assert by_name["position-dependent-friction"].terms == ("sign(v)*|px(z)|",)
    assert by_name["position-dependent-friction"].uses_px
    assert by_name["quadratic-damping"].terms == ("v*|v|",)
    assert by_name["stribeck"].shape is not None and not by_name["coulomb"].uses_px


def test_variants_leave_out_terms_already_in_the_model():
    model = Model.from_spec("1, z, v, sign(v)", defaults=False)
    coulomb = resolve_candidates("coulomb")[0]
    assert coulomb.variants(model, {"z": 0.01, "v": 1.0}) == []
    cubic = resolve_candidates("cubic-stiffness")[0]
    (variant,) = cubic.variants(model, {"z": 0.01, "v": 1.0})
    assert variant.names == ["z^3"] and variant.extra_parameters == 1


def test_the_stribeck_grid_scales_with_the_velocity_and_counts_the_shape():
    stribeck = resolve_candidates("stribeck")[0]
    model = Model.from_spec("1, z, v", defaults=False)
    variants = stribeck.variants(model, {"z": 0.01, "v": 0.5})
    shapes = [v.shape for v in variants]
    assert shapes == sorted(shapes) and shapes[0] == pytest.approx(0.01) and shapes[-1] == pytest.approx(0.25)
    assert variants[0].names == ["sign(v)*exp(-(v/0.01)^2)"] and variants[0].extra_parameters == 2
    assert stribeck.variant(model, 0.123456).shape == pytest.approx(0.123)


def test_sign_constraints_reject_the_opposite_of_the_named_effect():
    stribeck = resolve_candidates("stribeck")[0]
    variant = stribeck.variant(Model.from_spec("1, z, v, sign(v)", defaults=False), 0.1)
    term = variant.names[0]
    assert variant.inadmissible({term: 2.0}) == ""
    assert "not positive" in variant.inadmissible({term: -2.0})


def test_user_candidates_from_text():
    cand = Candidate.from_spec("drag = v*|v|, v^3")
    assert cand.name == "drag" and cand.terms == ("v*|v|", "v^3")
    chosen = resolve_candidates("coulomb", ["drag=v*|v|"], plugins=False)
    assert [c.name for c in chosen] == ["coulomb", "drag"]


@pytest.mark.parametrize(
    "spec, message",
    [
        ("v*|v|", "NAME=TERMS"),
        ("drag=v*w", "candidate 'drag'"),
        ("9lives=v", "must start with a letter"),
        ("drag=", "has no terms"),
    ],
)
def test_bad_user_candidates_name_what_is_wrong(spec, message):
    with pytest.raises(InputError, match=message):
        Candidate.from_spec(spec)


def test_a_placeholder_needs_a_shape_and_the_reverse():
    with pytest.raises(InputError, match="declares no shape"):
        Candidate("law", ("tanh(v/{c})",))
    with pytest.raises(InputError, match="no term uses"):
        Candidate("law", ("v",), shape=Shape("v", (0.1,)))
    with pytest.raises(InputError, match="positive term"):
        Candidate("law", ("v",), positive=("v^3",))
    smooth = Candidate("smooth-coulomb", ("tanh(v/{c})",), shape=Shape("v", (0.01, 0.1)))
    (a, b) = smooth.variants(Model.from_spec("z", defaults=False), {"z": 1.0, "v": 2.0})
    assert a.names == ["tanh(v/0.02)"] and b.names == ["tanh(v/0.2)"]


def test_unknown_and_duplicate_candidates():
    with pytest.raises(InputError, match=r"unknown candidate 'colomb' \(did you mean 'coulomb'\?\)"):
        resolve_candidates("colomb", plugins=False)
    with pytest.raises(InputError, match="two candidates are called 'coulomb'"):
        resolve_candidates("coulomb", ["coulomb=sign(v)"], plugins=False)


class _GoodPlugin:
    @staticmethod
    @hookimpl
    def nlid_candidates():
        return [Candidate("van-der-pol", ("z^2*v",), "van der Pol damping")]


class _BrokenPlugin:
    @staticmethod
    @hookimpl
    def nlid_candidates():
        return ["not a candidate"]


def test_plugin_candidates_are_found_and_a_broken_plugin_is_isolated():
    pm = pluggy.PluginManager(hookspecs.PROJECT)
    pm.add_hookspecs(hookspecs)
    pm.register(_GoodPlugin(), name="good")
    pm.register(_BrokenPlugin(), name="broken")
    found, failures = plugin_candidates(pm)
    assert [c.name for c in found] == ["van-der-pol"]
    assert set(failures) == {"broken"} and "Candidate" in failures["broken"]
    chosen = resolve_candidates("van-der-pol,coulomb", plugins=found)
    assert [c.name for c in chosen] == ["van-der-pol", "coulomb"]


@pytest.mark.parametrize(
    "term, expected",
    [
        ("sign(v)", True),
        ("v", True),
        ("v*|v|", True),
        ("v^3", True),
        ("sign(v)*exp(-(v/0.1)^2)", True),
        ("tanh(v/0.001)", True),
        ("z^2*v", True),
        ("sign(v)*|px(z)|", True),
        ("v^2", False),
        ("|v|", False),
        ("z*v", False),
        ("z^3", False),
        ("tanh(v/0.1)*tanh(v/0.2)", False),
        ("dahl(0.001)", False),
    ],
)
def test_dissipative_terms_are_friction_and_damping_laws(term, expected):
    from nlid.discovery.library import dissipative
    from nlid.model.terms import parse_term

    assert dissipative(parse_term(term)) is expected


def test_every_dissipative_candidate_carries_its_sign():
    """A friction or damping law with a negative coefficient feeds energy in: library, user and plugin candidates."""
    from nlid.discovery.library import dissipative
    from nlid.model.terms import parse_term

    for cand in LIBRARY:
        for term in cand.terms:
            if dissipative(parse_term(term.replace("{c}", "1").replace("{a}", "1").replace("{b}", "1"))):
                assert term in cand.positive, (cand.name, term)
    by_name = {c.name: c for c in LIBRARY}
    assert by_name["quadratic-damping"].positive == ("v*|v|",) and by_name["cubic-damping"].positive == ("v^3",)
    user = Candidate.from_spec("drag=v*|v|, z^2")
    assert user.positive == ("v*|v|",)
    (variant,) = user.variants(Model.from_spec("1, z, v", defaults=False), {"z": 0.01, "v": 1.0})
    assert "not positive" in variant.inadmissible({"v*|v|": -5.39, "z^2": 1.0})
    assert variant.inadmissible({"v*|v|": 5.39, "z^2": -1.0}) == ""
