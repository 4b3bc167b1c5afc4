"""Promises kept (issue 25 group 5, issue 23): --force never replaces a user's file, locks leave no stale name."""

from __future__ import annotations

import os

import pytest

from nlid.cli.main import main
from nlid.runtime.outputs import LOCK, MARKER, STUDY_OUTPUTS, WRITER, FolderBusyError, output_folder

STUDY = """
[study]
name = "tiny"
seed = 1
repetitions = 1
identifiers = ["rfs"]

[[datasets]]
name = "short"
preset = "paper-numerical"
overrides = { duration = 2.0 }
terms = "z^3, z^2, v*|v|"
"""


@pytest.mark.slow
def test_a_study_writes_only_what_it_declares_and_force_never_replaces_a_users_summary(tmp_path, capsys):
    study = tmp_path / "s.toml"
    study.write_text(STUDY)
    out = tmp_path / "out"
    assert main(["study", "run", str(study), "--out", str(out), "--no-progress"]) == 0
    written = {p.name for p in out.iterdir()} - {MARKER, LOCK}
    assert written <= set(STUDY_OUTPUTS), written - set(STUDY_OUTPUTS)
    assert "summary.txt" in written
    assert not (out / WRITER).exists(), "a finished study left its writer's name"
    assert (out / LOCK).read_text() == "", "the lock file names no process"

    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "summary.txt").write_text("my notes")
    capsys.readouterr()
    assert main(["study", "run", str(study), "--out", str(mine), "--no-progress", "--force"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "already holds summary.txt, which nlid did not write" in err[0], err
    assert (mine / "summary.txt").read_text() == "my notes"
    assert sorted(p.name for p in mine.iterdir()) == ["summary.txt"], "something was written before refusing"


def test_the_lock_names_its_holder_only_while_held(tmp_path):
    folder = tmp_path / "out"
    with output_folder(folder, STUDY_OUTPUTS):
        assert (folder / WRITER).read_text().startswith(f"nlid process {os.getpid()} on ")
        with pytest.raises(FolderBusyError, match=f"is being written by nlid process {os.getpid()} on "):
            with output_folder(folder, STUDY_OUTPUTS):
                pass
    assert not (folder / WRITER).exists()
    with output_folder(folder, STUDY_OUTPUTS):  # released: the next writer gets it
        pass


def test_the_force_help_says_exactly_what_is_never_replaced(capsys):
    with pytest.raises(SystemExit):
        main(["study", "run", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "nlid never replaces them: if one has the name of an output (" + ", ".join(STUDY_OUTPUTS) + ")" in text
