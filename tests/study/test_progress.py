"""The progress line: runs done / total and ETA on a terminal, silent otherwise."""

import io

from nlid.study.runner import Progress


class _Tty(io.StringIO):
    def isatty(self):
        return True


def test_progress_on_a_terminal_shows_counts_and_eta():
    stream = _Tty()
    bar = Progress(5, label="demo: ", stream=stream)
    assert bar.enabled
    for failed in (False, True, False):
        bar.update(failed=failed)
    text = stream.getvalue().split("\r")[-1]
    assert "demo: 3/5 runs (60 %)" in text and "ETA " in text and "1 failed" in text
    bar.update()
    bar.update()
    bar.close()
    assert "5/5 runs (100 %)" in stream.getvalue() and stream.getvalue().endswith("\n")


def test_progress_is_silent_when_not_a_terminal():
    stream = io.StringIO()
    bar = Progress(3, stream=stream)
    bar.update()
    bar.close()
    assert not bar.enabled and stream.getvalue() == ""
