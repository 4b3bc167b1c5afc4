"""The fork server's preload: what a single identification's server loads, and what it loads only while idle."""

from __future__ import annotations

import pytest

from nlid.runtime import preload


@pytest.fixture
def imports(monkeypatch):
    """The modules the preload imports, recorded instead of imported."""
    seen: list[str] = []
    monkeypatch.setattr(preload.importlib, "import_module", seen.append)
    return seen


def test_core_preload_loads_the_optional_modules_only_while_no_run_waits(imports):
    preload.warm_up("core", idle=lambda: True)
    assert all(name in imports for name in preload.WHILE_IDLE)
    imports.clear()
    preload.warm_up("core", idle=lambda: False)
    assert "nlid.identification.pipeline" in imports
    assert not any(name in imports for name in preload.WHILE_IDLE)
    imports.clear()
    preload.warm_up("core")  # no idle test (a spawned child): as if a run were waiting
    assert not any(name in imports for name in preload.WHILE_IDLE)


def test_a_run_arriving_stops_the_optional_imports(imports, monkeypatch):
    monkeypatch.setattr(preload, "WHILE_IDLE", ("first", "second"))
    answers = iter([True, False])
    preload.warm_up("core", idle=lambda: next(answers))
    assert "first" in imports and "second" not in imports
