"""``nlid --help`` starts fast: no heavy module is imported to print help (issue 14).

The time itself is measured by ``benchmarks/bench_import.py``; the test checks
the cause (what ends up in ``sys.modules``) in a fresh interpreter, which is
steady under any machine load.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

import nlid

#: Imported only by the code that uses them, never to print help.
HEAVY = ("numpy", "scipy", "pandas", "matplotlib", "numba", "emcee", "pysindy", "sklearn", "dask", "pluggy")

_PROBE = """
import json, sys
from nlid.cli.main import main
try:
    main({argv!r})
except SystemExit:
    pass
sys.stdout.write("\\n" + json.dumps(sorted(m for m in {heavy!r} if m in sys.modules)))
"""


def _imported(argv: list[str]) -> list[str]:
    root = Path(nlid.__file__).resolve().parent.parent
    path = os.pathsep.join([str(root), str(root / "plugins"), os.environ.get("PYTHONPATH", "")])
    out = subprocess.run(
        [sys.executable, "-c", _PROBE.format(argv=argv, heavy=HEAVY)],
        capture_output=True,
        text=True,
        check=True,
        env={**os.environ, "PYTHONPATH": path},
        timeout=60,
    )
    return json.loads(out.stdout.splitlines()[-1])


@pytest.mark.parametrize(
    "argv",
    [["--help"], ["--version"], ["study", "--help"], ["identify", "--help"], ["simulate", "--help"]],
    ids=" ".join,
)
def test_help_imports_no_heavy_module(argv):
    assert _imported(argv) == []


def test_import_nlid_imports_no_heavy_module():
    root = Path(nlid.__file__).resolve().parent.parent
    code = f"import sys, nlid; print([m for m in {HEAVY!r} if m in sys.modules])"
    out = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        check=True,
        env={**os.environ, "PYTHONPATH": str(root)},
        timeout=60,
    )
    assert out.stdout.strip() == "[]"


# --------------------------------------------------------------------------- issue 35: what the first run costs, said
PLUGINS = ("nlid_rfs", "nlid_sindy", "nlid_nsi", "nlid_oe")


def _plugins_imported(argv: list[str]) -> list[str]:
    root = Path(nlid.__file__).resolve().parent.parent
    path = os.pathsep.join([str(root), str(root / "plugins"), os.environ.get("PYTHONPATH", "")])
    out = subprocess.run(
        [sys.executable, "-c", _PROBE.format(argv=argv, heavy=PLUGINS)],
        capture_output=True,
        text=True,
        check=True,
        env={**os.environ, "PYTHONPATH": path},
        timeout=120,
    )
    return json.loads(out.stdout.splitlines()[-1])


def test_commands_that_need_no_identifier_import_no_plugin(tmp_path):
    assert _plugins_imported(["terms"]) == []
    out = str(tmp_path / "s.csv")
    assert _plugins_imported(["simulate", "--preset", "paper-numerical", "--duration", "1", "--out", out]) == []


def test_a_cold_kernel_cache_is_told_from_file_times(tmp_path, monkeypatch):
    from nlid.runtime import compilation

    source = tmp_path / "kernels.py"
    source.write_text("x = 1\n")
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    assert not compilation._cached(source)  # no index: the next run compiles
    cache = tmp_path / "__pycache__"
    cache.mkdir()
    index = cache / "kernels._rk4-252.py311.nbi"
    index.write_text("")
    os.utime(index, (source.stat().st_mtime + 10, source.stat().st_mtime + 10))
    assert compilation._cached(source)
    os.utime(source, (index.stat().st_mtime + 10, index.stat().st_mtime + 10))  # the source changed since
    assert not compilation._cached(source)


def test_the_first_compilation_is_said_on_a_terminal(monkeypatch, capsys):
    from nlid.cli import main as cli
    from nlid.runtime import compilation, progress

    monkeypatch.setattr(compilation, "cold_kernels", lambda: ["simulation/kernels.py"])
    monkeypatch.setattr(progress, "stderr_is_terminal", lambda: True)
    args = cli.build_parser().parse_args(["identify", "x.csv", "--terms", "z^3"])
    cli._say_compiling(args)
    assert "compiling the simulation kernels (first run only" in capsys.readouterr().err
    cli._say_compiling(cli.build_parser().parse_args(["identify", "x.csv", "--terms", "z^3", "--json"]))
    cli._say_compiling(cli.build_parser().parse_args(["terms"]))
    assert capsys.readouterr().err == ""  # not under --json, not for a command that does not simulate
    monkeypatch.setattr(compilation, "cold_kernels", lambda: [])
    cli._say_compiling(args)
    assert capsys.readouterr().err == ""  # a warm cache: nothing


def test_the_time_line_gives_the_wall_time():
    from nlid.cli.common import with_wall_time

    text = with_wall_time("method: rfs\ntime: 0.39 s\nwarning: x", "identification")
    line = text.splitlines()[1]
    assert line.startswith("time: 0.39 s (identification), ") and line.endswith(" s wall")
    assert float(line.split(", ")[1].split()[0]) > 0
