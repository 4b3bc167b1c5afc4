"""Progress of long work: on a terminal only, when the caller asked, never with --json or --quiet
(nlid.runtime.progress)."""

from __future__ import annotations

import io
import json

import pytest

import nlid
import nlid.runtime.progress as progress
from nlid.runtime.progress import ProgressLine, progress_line, showing

TERMS = "z^3,z^2,v*|v|"
#: What a redrawn progress line starts with.
REDRAW = "\r\x1b[2K"


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


@pytest.fixture
def fake_terminal(monkeypatch):
    """Every stream nlid.runtime.progress looks at is a terminal."""
    monkeypatch.setattr(progress, "_isatty", lambda stream: True)


@pytest.fixture(scope="module")
def record_file(tmp_path_factory):
    from nlid.cli.main import main

    path = tmp_path_factory.mktemp("progress") / "x.npz"
    argv = ["simulate", "--preset", "paper-numerical", "--seed", "4", "--duration", "3", "--set", "fs=1000"]
    assert main([*argv, "--channels", "v,a", "--noise", "0.01", "--out", str(path)]) == 0
    return path


# --------------------------------------------------------------------------- the line itself
def test_a_line_is_drawn_only_on_a_terminal_when_asked():
    for stream, asked, shown in [
        (_Terminal(), True, True),
        (_Terminal(), False, False),  # the library never asks by itself
        (io.StringIO(), True, False),  # a pipe, a file, a notebook's stream
    ]:
        with showing(asked):
            line = ProgressLine("work", total=10, unit="steps", stream=stream)
        for i in range(10):
            line.update(i + 1, force=True)
        line.close()
        text = stream.getvalue()
        assert (REDRAW + "work: 10/10 steps (100 %)" in text) is shown, (asked, text)
        assert (text == "") is not shown


def test_showing_is_scoped_and_off_by_default():
    assert not progress.active()
    with showing():
        assert progress.active()
        with showing(False):
            assert not progress.active()
        assert progress.active()
    assert not progress.active()


def test_milestones_are_kept_and_the_line_erased_at_the_end():
    stream = _Terminal()
    with ProgressLine("search", stream=stream, enabled=True) as line:
        line.update(note="stage one", force=True)
        line.keep("step 1: accepted coulomb")
    text = stream.getvalue()
    assert "step 1: accepted coulomb\n" in text and text.endswith(REDRAW)
    assert max(len(x) for x in text.split(REDRAW)) <= progress.MAX_WIDTH + 1


# --------------------------------------------------------------------------- the long computations
def test_posterior_progress_on_a_terminal_only(cli, record_file, monkeypatch):
    argv = ["posterior", str(record_file), "--method", "rfs", "--terms", TERMS, "--mass", "0.2", "--params", "v*|v|"]
    argv += ["--no-bias-correction", "--steps", "5000"]
    status, out, err = cli(*argv)  # stderr is a pipe here
    assert status == 0 and REDRAW not in err and "posterior:" not in err
    monkeypatch.setattr(progress, "_isatty", lambda stream: True)
    status, out, err = cli(*argv)
    assert status == 0 and REDRAW + "posterior: " in err and "steps" in err and "autocorrelation time" in err
    assert REDRAW not in out  # the table on stdout is untouched
    for quiet in (["--quiet"], ["--json"]):
        status, out, err = cli(*argv, *quiet)
        assert status == 0 and REDRAW not in err and REDRAW not in out
    json.loads(out)  # --json: stdout is one JSON object and nothing else


def test_oe_progress_when_asked_on_a_terminal(fake_terminal, capsys, record_file):
    record = nlid.load(record_file)
    options = {"max_nfev": 30, "tol": 1e-3, "segment_seconds": 0}
    nlid.identify(record, TERMS, "oe", mass=0.2, options=options)
    assert REDRAW not in capsys.readouterr().err  # the library does not ask by itself
    with showing():
        nlid.identify(record, TERMS, "oe", mass=0.2, options=options)
    err = capsys.readouterr().err
    assert REDRAW + "oe: " in err and "free runs" in err and "cost" in err


def test_discover_draws_its_stages_on_a_terminal_and_nothing_when_piped(cli, record_file, monkeypatch):
    argv = ["discover", str(record_file), "--declared", "1, z, z^3, v", "--method", "rfs", "--mass", "0.2"]
    argv += ["--max-steps", "1"]
    status, out, err = cli(*argv)  # piped: no stage lines (they used to be printed one per line)
    assert status == 0 and err == "" and "quadratic-damping" in out
    monkeypatch.setattr("nlid.cli.cmd_discover.stderr_is_terminal", lambda: True)
    status, out, err = cli(*argv)
    assert status == 0 and REDRAW + "nlid discover: " in err
    assert "nlid discover: step 1: accepted quadratic-damping" in err  # a milestone kept as its own line
    assert REDRAW not in out
    status, _, err = cli(*argv, "--quiet")
    assert status == 0 and err == ""


def test_progress_line_is_exported_to_plugins():
    import nlid.plugin

    assert nlid.plugin.progress_line is progress_line
