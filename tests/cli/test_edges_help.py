"""Help texts and dataset names a newcomer reads (issue 35, item 5): derived from the registries, wrapped."""

from __future__ import annotations

import pytest

from nlid.cli.common import DATA_HELP
from nlid.cli.main import build_parser
from nlid.data import datasets, names

#: Prose lines of a help text longer than this were not wrapped (command examples are exempt).
WIDTH = 120


def test_the_names_module_agrees_with_the_loaders():
    assert set(names.PARTS) == set(datasets.DATASETS)
    assert set(names.PARTS["silverbox"]) == set(datasets.SILVERBOX_PARTS)


def test_the_data_help_lists_every_dataset_and_part():
    text = " ".join(DATA_HELP.split())
    for name, parts in names.PARTS.items():
        assert f"dataset:{name}" in text
        for part in parts:
            assert part in text, (name, part)
    assert len(names.spellings()) == sum(1 + len(p) for p in names.PARTS.values())


def test_boucwen_is_an_alias_of_bouc_wen(data_dir):
    assert names.canonical_name("boucwen") == "bouc-wen"
    a, b = datasets.load("boucwen"), datasets.load("bouc-wen")
    assert a.n == b.n and (a.z == b.z).all()
    assert [s.benchmark for s in datasets.check(data_dir, ["boucwen"])] == ["bouc-wen"] * 3


def test_boucwen_names_the_bench_protocol_too():
    from nlid.benchmarking.protocol import load_protocol

    assert load_protocol("boucwen").name == load_protocol("bouc-wen").name


def test_one_spelling_in_the_help_and_docstrings():
    parser = build_parser()
    texts = [parser.format_help()]
    for action in parser._subparsers._group_actions:  # every subcommand's help
        texts += [sub.format_help() for sub in action.choices.values()]
    texts.append(datasets.__doc__ or "")
    for text in texts:
        for line in text.splitlines():
            if "boucwen" in line:
                assert "boucwen/" in line or "accepted" in line, line  # the folder's name, or the alias said


@pytest.mark.parametrize("command", ["discover", "identify", "compare", "posterior", "data", "bench", "study"])
def test_help_prose_is_wrapped(command):
    parser = build_parser()
    sub = next(a for a in parser._subparsers._group_actions).choices[command]
    long = [
        line for line in sub.format_help().splitlines() if len(line) > WIDTH and not line.lstrip().startswith("nlid ")
    ]
    assert not long, long
