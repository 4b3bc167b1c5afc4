"""The search as an object: steps() yields a state per round, run() drains it, discover() wraps it."""

from __future__ import annotations

import ast
import json
from pathlib import Path

import pytest

from nlid.discovery import CandidateLibrary, Discovery, SearchState, Split, discover
from nlid.discovery.cases import build_case
from nlid.errors import InputError

SETTINGS = {"mass": None, "max_steps": 2, "simulate": False, "views": False}
CANDIDATES = "coulomb, viscous, mass"


@pytest.fixture(scope="module")
def case():
    preset, declared = build_case("single", "coulomb")
    return preset.simulate(5, noise={"z": 0.01}, channels=("z", "a")), declared, preset.mass


@pytest.fixture(scope="module")
def search(case):
    _, _, mass = case
    return Discovery("rfs", mass=mass, library=CandidateLibrary.select(CANDIDATES), max_steps=2, simulate=False)


@pytest.fixture(scope="module")
def states(case, search):
    record, declared, _ = case
    lines: list[str] = []
    out = list(search.steps(record, declared, progress=lines.append))
    assert lines[0].startswith("identifying the declared model")
    return out


def _json(result) -> str:
    """The JSON without the wall times."""

    def strip(x):
        if isinstance(x, dict):
            return {k: strip(v) for k, v in x.items() if k != "seconds"}
        return [strip(v) for v in x] if isinstance(x, list) else x

    return json.dumps(strip(result.to_dict()), sort_keys=True)


def test_each_round_yields_a_new_state_and_the_last_is_done(states):
    assert all(isinstance(s, SearchState) for s in states)
    assert [s.done for s in states] == [False] * (len(states) - 1) + [True]
    first = states[0]
    assert first.step is not None and first.step.effect == "coulomb" and len(first.stages) == 2
    assert first.stage is first.step.after and first.added == {"coulomb"}
    last = states[-1]
    assert last.stop_reason.startswith("no candidate passes") and last.ranking
    # nothing is changed in place: the first state still has one step
    assert len(first.steps) == 1 and first.ranking == ()


def test_each_stage_carries_the_mass_it_was_given(states, case):
    _, _, mass = case
    assert all(stage.given_mass == mass and not stage.identified.mass_estimated for stage in states[-1].stages)


def test_run_and_discover_give_the_same_result(case, search, states):
    record, declared, mass = case
    finished = search.finish(states[-1])
    ran = search.run(record, declared)
    wrapped = discover(record, declared, "rfs", candidates=CANDIDATES, **{**SETTINGS, "mass": mass})
    assert _json(finished) == _json(ran) == _json(wrapped)
    assert str(ran.summary()) == str(wrapped.summary())


def test_a_search_stopped_early_says_so(states, search):
    result = search.finish(states[0])
    assert [s.effect for s in result.steps] == ["coulomb"]
    assert result.stop_reason.startswith("stopped by the caller after 1 step(s); ")
    assert result.final_ranking == []


def test_settings_are_checked_before_any_data():
    with pytest.raises(InputError, match="max_steps must be >= 0"):
        Discovery("rfs", max_steps=-1)
    with pytest.raises(InputError, match="mass= must be a positive number of kg"):
        Discovery("rfs", mass=-1.0, library=CandidateLibrary(()))
    with pytest.raises(InputError, match="holdout must be a fraction between 0 and 1 or a Record"):
        Split("most")


def test_split_divides_or_takes_a_separate_record(case):
    record = case[0]
    est, held, text = Split(0.25).divide(record)
    assert est.n + held.n == record.n and text == f"last 25 % of the record ({held.n} samples)"
    est, held, text = Split(record).divide(record)
    assert est is record and held is record and text.startswith(f"separate record ({record.n} samples")


def test_candidate_libraries_select_and_compose():
    lib = CandidateLibrary.select("coulomb, mass")
    assert lib.names == ["coulomb"] and lib.mass and not lib.dictionary
    both = lib + "drag=v*|v|"
    assert both.names == ["coulomb", "drag"] and both.mass and not both.dictionary
    assert (CandidateLibrary.select("viscous") + CandidateLibrary.select("dictionary")).dictionary
    with pytest.raises(InputError, match="two candidates are called 'coulomb'"):
        lib + CandidateLibrary.select("coulomb")
    with pytest.raises(InputError, match="unknown candidate 'columb'"):
        CandidateLibrary.select("columb")


def test_the_result_its_report_and_its_plots_import_in_one_direction():
    """result -> report -> plots, never back (not even for type hints): the old loop <-> report <-> plots circle."""
    root = Path(__file__).resolve().parents[2] / "nlid" / "discovery"

    def imported(name: str) -> set[str]:
        tree = ast.parse((root / f"{name}.py").read_text())
        return {node.module or "" for node in ast.walk(tree) if isinstance(node, ast.ImportFrom) and node.level == 1}

    for presenter in ("report", "plots"):
        assert not imported(presenter) & {"result", "search", "trials", "loop"}, presenter
    assert "report" not in imported("plots")
