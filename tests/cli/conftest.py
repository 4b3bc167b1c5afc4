"""Shared fixtures of the CLI tests."""

from __future__ import annotations

import pytest

from nlid.cli.main import main


@pytest.fixture
def cli(capfd):
    """Run ``nlid ARGS...`` in-process; returns ``(exit status, stdout, stderr)``.

    The file descriptors are read (``capfd``): plugin code runs in a child process, which writes to them.
    """

    def run(*argv: str) -> tuple[int, str, str]:
        status = main(list(argv))
        out = capfd.readouterr()
        return status, out.out, out.err

    return run
