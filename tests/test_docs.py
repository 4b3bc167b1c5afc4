"""The documentation site: every page is in the table of contents, every example is shown, and every public
function, class and method of the API reference has a docstring. The site itself is built with warnings as
errors by ``.ci/run`` (``python -m sphinx -W``)."""

from __future__ import annotations

import importlib
import inspect
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
DIRECTIVE = re.compile(r"^\.\. (automodule|autoclass|autofunction):: (\S+)\n((?:   :[^\n]*\n)*)", re.M)


def _documented() -> list[tuple[str, object]]:
    """``(qualified name, object)`` of everything the API reference pages document."""
    out = []
    for page in sorted((DOCS / "api").glob("*.rst")):
        for kind, target, options in DIRECTIVE.findall(page.read_text()):
            members = re.search(r":members:(.*)", options)
            listed = [m.strip() for m in members.group(1).split(",") if m.strip()] if members else []
            if kind == "automodule":
                module = importlib.import_module(target)
                if ":no-members:" in options:
                    continue
                names = listed or list(getattr(module, "__all__", []))
                out += [(f"{target}.{n}", getattr(module, n)) for n in names]
            else:
                module_name, _, name = target.rpartition(".")
                out.append((target, getattr(importlib.import_module(module_name), name)))
    return out


def _public_methods(cls: type) -> list[tuple[str, object]]:
    out = []
    for name, value in vars(cls).items():
        if name.startswith("_"):
            continue
        if isinstance(value, (staticmethod, classmethod)):
            value = value.__func__
        if inspect.isfunction(value) or isinstance(value, property):
            out.append((name, value))
    return out


def test_every_documented_function_class_and_method_has_a_docstring():
    documented = _documented()
    assert len(documented) > 60
    missing = []
    for name, obj in documented:
        if inspect.isfunction(obj) or inspect.isclass(obj):
            if not inspect.getdoc(obj):
                missing.append(name)
        if inspect.isclass(obj):
            missing += [f"{name}.{m}" for m, value in _public_methods(obj) if not (value.__doc__ or "").strip()]
    assert not missing, "no docstring: " + ", ".join(missing)


def test_every_page_is_in_the_table_of_contents():
    index = (DOCS / "index.md").read_text() + (DOCS / "api" / "index.rst").read_text()
    pages = {p.stem for p in DOCS.glob("*.md")} - {"index"}
    missing = [p for p in sorted(pages) if not re.search(rf"^\s*{re.escape(p)}\s*$", index, re.M)]
    assert not missing, f"pages not in a toctree of docs/index.md: {missing}"
    api = {p.stem for p in (DOCS / "api").glob("*.rst")} - {"index"}
    assert all(re.search(rf"^\s+{p}$", index, re.M) for p in api)


def test_every_example_is_in_the_docs():
    text = (DOCS / "examples.md").read_text()
    for script in sorted((ROOT / "examples").glob("*.py")):
        assert f"../examples/{script.name}" in text, script.name


def test_the_built_in_identifiers_are_in_the_decision_table():
    text = (DOCS / "methods.md").read_text()
    for method in ("rfs", "sindy", "nsi-ip", "nsi-shift"):
        assert f"**`{method}`**" in text, method


@pytest.mark.slow
def test_the_site_builds_without_warnings(tmp_path):
    """The same build as .ci/run (skipped when the docs extra is not installed)."""
    pytest.importorskip("sphinx")
    pytest.importorskip("numpydoc")
    pytest.importorskip("myst_parser")
    import subprocess
    import sys

    proc = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html", str(DOCS), str(tmp_path / "html")],
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert (tmp_path / "html" / "api" / "identified.html").is_file()


def test_licence_and_citation():
    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10
        import tomli as tomllib

    import nlid

    assert (ROOT / "LICENSE").read_text().startswith("MIT License")
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert project["license"] == {"text": "MIT"}
    citation = (ROOT / "CITATION.cff").read_text()
    assert "cff-version: 1.2.0" in citation and f"version: {nlid.__version__}" in citation
    assert "license: MIT" in citation


def test_the_gallery_shows_every_figure_with_its_code():
    """docs/gallery.md: every marker it includes is in docs/make_gallery.py, every image it shows is committed,
    and every ``plot_*`` method of the identified model and every figure function of the posterior is shown."""
    from nlid.bayes import plots as posterior_plots
    from nlid.identified.model import IdentifiedModel

    page = (DOCS / "gallery.md").read_text()
    script = (DOCS / "make_gallery.py").read_text()
    markers = re.findall(r':start-after: "# \[([^\]]+)\]"', page)
    assert len(markers) > 10
    for name in markers:
        assert f"# [{name}]" in script and f"# [/{name}]" in script, name
    images = re.findall(r"\]\((_static/gallery/[^)]+\.png)\)", page)
    assert images and all((DOCS / image).is_file() for image in images), images
    shown = "\n".join(
        script[script.index(f"# [{n}]") : script.index(f"# [/{n}]")] for n in markers if f"# [{n}]" in script
    )
    methods = [name for name in vars(IdentifiedModel) if name.startswith("plot_")]
    assert len(methods) >= 6
    for name in [*methods, *posterior_plots.__all__]:
        assert f"{name}(" in shown, name
