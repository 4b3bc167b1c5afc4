"""``nlid study``: list, run (summary on stdout), one-line errors with exit status 2."""

import re

import pytest

from nlid.cli.main import main

STUDY = """
[study]
name = "cli-small"
repetitions = 1
identifiers = ["rfs"]

[[datasets]]
name = "short"
preset = "paper-numerical"
overrides = { duration = 4.0 }
noise = { z = 0.02 }
"""


def _status(argv):
    try:
        return main(argv)
    except SystemExit as exc:
        return exc.code


def test_study_list(capsys):
    assert main(["study", "list"]) == 0
    out = capsys.readouterr().out
    for name in ("paper-numerical", "noise-sweep", "paper-experimental", "emps", "silverbox"):
        assert name in out


def test_study_run_prints_the_summary(tmp_path, capsys):
    path = tmp_path / "cli-small.toml"
    path.write_text(STUDY)
    assert main(["study", "run", str(path), "--out", str(tmp_path / "out"), "--jobs", "1"]) == 0
    captured = capsys.readouterr()
    # the terminal summary (summary.txt): the verdict first, tables as aligned text within 100 columns
    out = captured.out
    assert out.startswith("Study cli-small") and "VERDICT" in out and re.search(r"^rfs\s+1/1\s", out, re.M)
    assert out.rstrip("\n") == (tmp_path / "out" / "summary.txt").read_text().rstrip("\n")
    assert max(len(line) for line in out.splitlines()) <= 100
    assert "1 runs executed, 0 reused" in captured.err
    assert main(["study", "run", str(path), "--out", str(tmp_path / "out")]) == 0
    assert "0 runs executed, 1 reused" in capsys.readouterr().err
    assert (tmp_path / "out" / "report.html").is_file()


@pytest.mark.parametrize(
    "argv, message",
    [
        (["study", "run", "paper-numerica"], "unknown study 'paper-numerica' (did you mean 'paper-numerical'?)"),
        (["study", "run", "missing.toml"], "study file missing.toml not found"),
        (["study", "run", "paper-numerical", "--scheduler", "tcp://x:1"], "--scheduler needs --executor dask"),
        (["study", "run", "paper-numerical", "--jobs", "0"], "--jobs must be at least 1"),
        (["study", "run", "{bad}"], "datasets[0].terms: unknown name 'q'"),
        (["study", "run", "paper-numerical", "--executor", "ray"], "invalid choice: 'ray'"),
    ],
)
def test_study_errors_are_one_line_with_status_2(argv, message, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    bad = tmp_path / "bad.toml"
    bad.write_text("[[datasets]]\npreset = 'paper-numerical'\nterms = 'q^3'\n")
    status = _status([a.format(bad=bad) for a in argv])
    err = capsys.readouterr().err
    assert status == 2 and message in err, err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
