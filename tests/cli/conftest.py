"""Shared fixtures of the CLI tests."""

from __future__ import annotations

import pytest

from nlid.cli.main import main


@pytest.fixture
def cli(capsys):
    """Run ``nlid ARGS...`` in-process; returns ``(exit status, stdout, stderr)``."""

    def run(*argv: str) -> tuple[int, str, str]:
        status = main(list(argv))
        out = capsys.readouterr()
        return status, out.out, out.err

    return run
