"""Hostile test plugins, registered from outside through an entry point, and a census of processes.

As in tests/study/conftest.py, a module and a ``*.dist-info`` folder with an
``entry_points.txt`` are written to a temporary folder put on ``sys.path``
(and on ``PYTHONPATH`` for the command-line runs): to ``importlib.metadata``
and to nlid's child processes, which get the parent's path, that is an
installed distribution. Each plugin does one hostile thing, then (if it is
still alive) identifies like ``rfs``.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from plugin_dist import write_distribution

PLUGINS = """
import ctypes
import os
import subprocess
import sys
import threading
import time
import warnings
from dataclasses import replace

from nlid.plugin import hookimpl
from nlid_rfs import RestoringForceSurface

if os.environ.get("NLID_TEST_PRINT_AT_IMPORT"):
    print("HOSTILE PLUGIN PRINTS AT IMPORT")


class Segfault(RestoringForceSurface):
    name = "rt-segv"
    summary = "reads address 0 (test plugin)"

    def identify(self, record, model, *, mass=None):
        ctypes.string_at(0)


class Abort(RestoringForceSurface):
    name = "rt-abort"
    summary = "calls abort() (test plugin)"

    def identify(self, record, model, *, mass=None):
        os.abort()


class Hang(RestoringForceSurface):
    name = "rt-hang"
    summary = "never returns (test plugin)"

    def identify(self, record, model, *, mass=None):
        while True:
            time.sleep(0.2)


class Threads(RestoringForceSurface):
    name = "rt-threads"
    summary = "leaves a thread running (test plugin)"

    def identify(self, record, model, *, mass=None):
        def forever():
            while True:
                time.sleep(0.2)

        threading.Thread(target=forever, name="rt-forever").start()
        return super().identify(record, model, mass=mass)


class Grandchild(RestoringForceSurface):
    name = "rt-grandchild"
    summary = "starts a process it never waits for, one in its group and one in a session of its own (test plugin)"

    def identify(self, record, model, *, mass=None):
        subprocess.Popen(["sleep", "100000"])
        subprocess.Popen(["sleep", "100001"], start_new_session=True)
        return super().identify(record, model, mass=mass)


class Prints(RestoringForceSurface):
    name = "rt-print"
    summary = "prints to stdout (test plugin)"

    def identify(self, record, model, *, mass=None):
        print("HOSTILE PLUGIN PRINTS")
        sys.stdout.flush()
        os.write(1, b"HOSTILE PLUGIN WRITES TO FD 1\\n")
        return super().identify(record, model, mass=mass)


class Warns(RestoringForceSurface):
    name = "rt-warn"
    summary = "issues a warning (test plugin)"

    def identify(self, record, model, *, mass=None):
        warnings.warn("this plugin is being careful")
        return super().identify(record, model, mass=mass)


class Interrupt(RestoringForceSurface):
    name = "rt-kbint"
    summary = "raises KeyboardInterrupt (test plugin)"

    def identify(self, record, model, *, mass=None):
        raise KeyboardInterrupt


class NonJson(RestoringForceSurface):
    name = "rt-nonjson"
    summary = "returns diagnostics holding an object (test plugin)"

    def identify(self, record, model, *, mass=None):
        estimate = super().identify(record, model, mass=mass)
        return replace(estimate, diagnostics={**dict(estimate.diagnostics), "fit": object()})


@hookimpl
def nlid_identifiers():
    return [Segfault, Abort, Hang, Threads, Grandchild, Prints, Warns, Interrupt, NonJson]
"""

#: The hostile identifiers by name.
HOSTILE = ("rt-segv", "rt-abort", "rt-hang", "rt-threads", "rt-grandchild", "rt-print", "rt-warn", "rt-kbint")


@pytest.fixture(scope="module")
def hostile_path(tmp_path_factory):
    """A folder holding the hostile plugins as an installed distribution, on sys.path."""
    folder = tmp_path_factory.mktemp("hostile-plugins")
    write_distribution(
        folder,
        "nlid-runtime-test-plugins",
        {"nlid_runtime_test_plugins": PLUGINS},
        {"runtime-test": "nlid_runtime_test_plugins"},
    )
    from nlid.contract.registry import default_registry, registry_for

    def fresh() -> None:  # registries built before (or with) the plugins on the path are stale
        default_registry.cache_clear()
        registry_for.cache_clear()

    with pytest.MonkeyPatch.context() as mp:
        mp.syspath_prepend(str(folder))
        fresh()
        yield folder
    fresh()


@pytest.fixture(scope="module")
def record_csv(tmp_path_factory) -> Path:
    """A short simulated record as a CSV file (4 s of paper-numerical, z and a)."""
    from nlid.data.io import write_csv
    from nlid.simulation.presets import get_preset

    path = tmp_path_factory.mktemp("record") / "x.csv"
    write_csv(get_preset("paper-numerical").with_overrides(duration=4.0).simulate(0, channels=("z", "a")), path)
    return path
