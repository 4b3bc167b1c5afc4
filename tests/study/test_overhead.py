"""The study's fixed costs beside the identification: cut without changing a number (issue 36)."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from nlid.runtime import parallel
from nlid.study import parse_study, plan_study
from nlid.study.worker import run_isolated

#: Columns that measure the machine, not the result.
MACHINE = ["seconds", "method_seconds", "peak_memory_mb"]
#: An independent held-out record, so that the run has a free run and its chaos check.
HELD_OUT = 'mass = "known"\nholdout = "independent"'


def test_both_gives_the_results_in_order_and_raises_the_first_error_first():
    threads = []

    def record(value):
        def call():
            threads.append(threading.current_thread().name)
            return value

        return call

    def fail(message):
        def call():
            raise ValueError(message)

        return call

    for budget in (1, 2):
        with parallel.thread_budget(budget):
            assert parallel.both(record("a"), record("b")) == ("a", "b")
            with pytest.raises(ValueError, match="first"):
                parallel.both(fail("first"), fail("second"))
            with pytest.raises(ValueError, match="second"):
                parallel.both(record(1), fail("second"))
    assert len(set(threads)) == 2  # with a budget of two the second call ran on a thread of its own
    assert not [t for t in threading.enumerate() if t.name == "nlid-both"]  # every thread joined


def test_a_run_given_two_threads_stores_the_same_row_and_result(small_study, registry):
    """The free run and its chaos check at once (LocalExecutor with fewer runs than cores): the same numbers."""
    run = plan_study(parse_study(small_study('["rfs"]', repetitions=1, extra=HELD_OUT), registry=registry))[0]
    one = run_isolated(run.spec, threads=1)
    two = run_isolated(run.spec, threads=2)
    for payload in (one, two):
        assert payload["row"]["status"] == "ok", payload["row"]["error"]
    assert np.isfinite(one["row"]["freerun_nrmse_pct"])
    assert one["result"]["coefficients"] == two["result"]["coefficients"]
    assert {k: v for k, v in one["row"].items() if k not in MACHINE} == {
        k: v for k, v in two["row"].items() if k not in MACHINE
    }


def test_the_preload_loads_what_each_identifier_plugin_exports_on_first_use(tmp_path, monkeypatch):
    """A plugin that imports its heavy modules on first use (nlid_sindy: pysindy) has them loaded in the server."""
    import sys

    from nlid.runtime.preload import warm_plugins

    package = tmp_path / "lazyplugin"
    package.mkdir()
    (package / "__init__.py").write_text(
        "__all__ = ['Method', 'heavy']\n"
        "class Method:\n    pass\n"
        "def __getattr__(name):\n"
        "    if name == 'heavy':\n"
        "        from . import heavy_module\n"
        "        return heavy_module.VALUE\n"
        "    raise AttributeError(name)\n"
    )
    (package / "heavy_module.py").write_text("VALUE = 1\n")
    (tmp_path / "brokenplugin.py").write_text("__all__ = ['Method', 'missing']\nclass Method:\n    pass\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    import brokenplugin
    import lazyplugin

    assert "lazyplugin.heavy_module" not in sys.modules
    warmed = warm_plugins([lazyplugin.Method, brokenplugin.Method])  # a name that fails is skipped
    assert warmed == ["brokenplugin", "lazyplugin"] and "lazyplugin.heavy_module" in sys.modules
    for name in ("lazyplugin", "lazyplugin.heavy_module", "brokenplugin"):
        monkeypatch.delitem(sys.modules, name)


def _sindy_loaded() -> bool:
    import sys

    return "pysindy" in sys.modules


def test_a_run_child_of_a_study_has_the_sindy_plugin_s_pysindy_loaded():
    from nlid.contract.registry import load_registry
    from nlid.runtime.isolation import run_in_child, start_method

    if "sindy" not in load_registry().identifiers or start_method() != "forkserver":
        pytest.skip("needs the sindy plugin and the fork server")
    outcome = run_in_child(_sindy_loaded, timeout=120, pin_threads=True)
    assert outcome.status == "ok" and outcome.value
