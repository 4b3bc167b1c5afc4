"""Checks of the code base itself (as python-control and datasette do): vocabulary, layering, documentation."""

from __future__ import annotations

import ast
import importlib
import inspect
import pkgutil
import re
from pathlib import Path

import pytest

import nlid
from nlid import hookspecs

ROOT = Path(__file__).resolve().parents[1]
FLAG = re.compile(r"(?:^|[\s('\"])--[a-z][a-z-]+")


def _strings(tree: ast.AST):
    """Every string constant that is not a docstring, with its line."""
    docstrings = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            body = getattr(node, "body", [])
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
                docstrings.add(id(body[0].value))
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docstrings:
            yield node.lineno, node.value


def test_no_library_message_names_a_command_line_flag():
    """Library messages name Python parameters (``mass=``); the CLI maps them to its flags."""
    offenders = []
    for path in sorted((ROOT / "nlid").rglob("*.py")):
        if "cli" in path.relative_to(ROOT / "nlid").parts:
            continue
        for line, text in _strings(ast.parse(path.read_text())):
            if FLAG.search(text):
                offenders.append(f"{path.relative_to(ROOT)}:{line}: {text!r}")
    assert not offenders, "\n".join(offenders)


def test_plugins_import_only_the_plugin_toolkit():
    """nlid's own identifiers use nlid.plugin and nothing else of nlid, exactly as a third party would."""
    offenders = []
    for path in sorted((ROOT / "plugins").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            for name in names:
                if (name == "nlid" or name.startswith("nlid.")) and name != "nlid.plugin":
                    offenders.append(f"{path.relative_to(ROOT)}:{node.lineno}: import {name}")
    assert not offenders, "\n".join(offenders)


def test_every_hook_is_documented():
    """Each hook specification has a docstring and a section of docs/plugins.md (datasette checks the same)."""
    text = (ROOT / "docs" / "plugins.md").read_text()
    specs = [name for name, obj in vars(hookspecs).items() if name.startswith("nlid_") and callable(obj)]
    assert specs
    for name in specs:
        assert inspect.getdoc(getattr(hookspecs, name)), name
        assert f"`{name}`" in text, f"hook {name} is not documented in docs/plugins.md"


DOC_PAGES = {"rfs": "rfs.md", "sindy": "sindy.md", "nsi-ip": "nsi.md", "nsi-shift": "nsi.md", "oe": "oe.md"}


def _entry_points() -> dict[str, str]:
    """The built-in identifiers' entry points (``nlid.identifiers``) in this checkout's pyproject.toml."""
    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10
        import tomli as tomllib
    return tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["entry-points"]["nlid.identifiers"]


def _built_in(method: str) -> type:
    """The identifier class of a built-in method, through its entry point in this checkout's pyproject.toml.

    (An editable install of another checkout may not list a method this one adds.)
    """
    module = importlib.import_module(_entry_points()[method])
    return next(cls for cls in module.nlid_identifiers() if cls.name == method)


def test_every_built_in_identifier_has_a_doc_page():
    assert sorted(_entry_points()) == sorted(DOC_PAGES)


@pytest.mark.parametrize("method", sorted(DOC_PAGES))
def test_every_option_of_the_built_in_identifiers_is_documented(method):
    cls = _built_in(method)
    text = (ROOT / "docs" / DOC_PAGES[method]).read_text()
    missing = [o.name for o in cls.options if f"`{o.name}`" not in text]
    assert not missing, f"{method}: options not in docs/{DOC_PAGES[method]}: {missing}"


def test_public_api_has_docstrings():
    for module in (nlid, importlib.import_module("nlid.plugin")):
        for name in module.__all__:
            obj = getattr(module, name)
            if inspect.isfunction(obj) or inspect.isclass(obj):
                assert inspect.getdoc(obj), f"{module.__name__}.{name} has no docstring"


def test_verbs_survive_importing_every_submodule():
    """``nlid.simulate``, ``nlid.posterior``... stay functions whatever else was imported."""
    for info in pkgutil.walk_packages(nlid.__path__, "nlid."):
        if info.name.endswith("__main__") or ".study.child" in info.name:
            continue
        importlib.import_module(info.name)
    package = Path(nlid.__path__[0])
    for verb in ("load", "simulate", "identify", "compare", "posterior", "discover", "run_study"):
        assert inspect.isfunction(getattr(nlid, verb)), verb
        assert not (package / f"{verb}.py").exists() and not (package / verb).is_dir(), verb
