"""Checks of the code base itself (as python-control and datasette do): vocabulary, layering, documentation."""

from __future__ import annotations

import ast
import dataclasses
import importlib
import importlib.util
import inspect
import pkgutil
import re
import textwrap
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


@pytest.mark.parametrize("method", sorted(_entry_points()))
def test_every_built_in_identifier_has_a_doc_page(method):
    """The page is the identifier's own ``docs`` attribute (what the study verdict links to)."""
    page = _built_in(method).docs
    assert page.startswith("docs/") and page.endswith(".md") and (ROOT / page).is_file(), (method, page)


@pytest.mark.parametrize("method", sorted(_entry_points()))
def test_every_option_of_the_built_in_identifiers_is_documented(method):
    cls = _built_in(method)
    text = (ROOT / cls.docs).read_text()
    missing = [o.name for o in cls.options if f"`{o.name}`" not in text]
    assert not missing, f"{method}: options not in {cls.docs}: {missing}"


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


# ============================================================================ the house rules (issue 22)
# Each rule is a checker over a source tree (this checkout, or a synthetic one in the tests below that show it
# fails on a violation). They cover nlid/ and every plugin package under plugins/.


def _load_import_circles():
    """``benchmarks/import_circles.py``: the import graph and its circles (one definition for the script and us)."""
    spec = importlib.util.spec_from_file_location("import_circles", ROOT / "benchmarks" / "import_circles.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


IMPORTS = _load_import_circles()

#: Longest module (lines) in nlid/ and plugins/.
MAX_LINES = 600
#: Modules allowed to be longer, each with the reason (none: a module that grows past the limit is split by job).
LONG_MODULES: dict[str, str] = {}


def _sources(root: Path) -> list[Path]:
    """Every Python file of nlid/ and of the plugin packages."""
    return sorted(p for package in IMPORTS.packages(root) for p in package.rglob("*.py"))


def long_modules(root: Path, limit: int = MAX_LINES, exempt: dict[str, str] | None = None) -> list[str]:
    """``"path: N lines"`` for each module over ``limit`` lines that is not exempt."""
    exempt = LONG_MODULES if exempt is None else exempt
    out = []
    for path in _sources(root):
        rel = path.relative_to(root).as_posix()
        n = len(path.read_text().splitlines())
        if n > limit and rel not in exempt:
            out.append(f"{rel}: {n} lines")
    return out


def import_circles(root: Path) -> list[str]:
    """The import circles of each package (``benchmarks/import_circles.py``'s rule)."""
    return [
        " <-> ".join(c) for package in IMPORTS.packages(root) for c in IMPORTS.circles(IMPORTS.import_graph(package))
    ]


def _inside(module: str, package: str) -> bool:
    return module == package or module.startswith(package + ".")


def import_paths(root: Path, importer: str, imported: str) -> list[str]:
    """Chains ``a -> b -> c`` by which a module of package ``importer`` imports one of ``imported``, directly or not.

    Function-body imports count, ``if TYPE_CHECKING:`` imports do not (as for circles).
    """
    graph = IMPORTS.import_graph(root / "nlid")
    chains = []
    for start in sorted(m for m in graph if _inside(m, importer)):
        seen = {start: [start]}
        todo = [start]
        while todo:
            module = todo.pop()
            for target in sorted(graph[module]):
                if target not in seen:
                    seen[target] = [*seen[module], target]
                    todo.append(target)
        chains += [" -> ".join(chain) for target, chain in seen.items() if _inside(target, imported)]
    return sorted(set(chains))


def _by_place(finding: str) -> tuple[str, int, str]:
    """Sort key of ``"path:line: what"``: the file, the line as a number, then what."""
    path, line, what = finding.split(":", 2)
    return path, int(line), what


def _is_private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def private_imports(root: Path) -> list[str]:
    """Imports that reach a private name (``_x``: a function, class or module) held by another package.

    A private name belongs to the package that holds it: the package of the module that defines it,
    or the package a private module sits in. Only that package's own modules may import it; its
    subpackages, its parent and every other package (plugins included) may not. Dunder names
    (``__all__``, ``__version__``) are not private. The imported dotted path is read whole:
    ``from nlid.terms._kernels import f`` reaches ``_kernels`` of ``nlid.terms``.
    """
    packages = IMPORTS.packages(root)
    modules = {name: path for package in packages for name, path in IMPORTS.module_names(package).items()}
    out = []
    for package in packages:
        for importer, line, module, name in IMPORTS.resolved_imports(package):
            path = modules[importer]
            home = importer if path.name == "__init__.py" else importer.rpartition(".")[0]
            parts = (module if name is None else f"{module}.{name}").split(".")
            for k, part in enumerate(parts):
                if not _is_private(part):
                    continue
                prefix = ".".join(parts[:k])
                held = modules.get(prefix)
                owner = prefix if held is None or held.name == "__init__.py" else prefix.rpartition(".")[0]
                if owner != home:
                    rel = path.relative_to(root).as_posix()
                    out.append(f"{rel}:{line}: {'.'.join(parts[: k + 1])} (private to {owner or 'its package'})")
                break
    return sorted(set(out), key=_by_place)


def _declared_keys() -> tuple[tuple[str, ...], set[str]]:
    """What a study-column key literal is: the labelled families' prefixes, and the study's own metric names.

    The metric names are the scalar families that are neither the run's identity (``method``, ``dataset``...,
    and ``mass``) nor a word of the core's result objects: a field of :class:`nlid.scoring.Scores` or of
    :class:`nlid.IdentifiedModel` (``eps_percent``, ``seconds``...), which ``nlid.compare`` and reports use
    as their own vocabulary.
    """
    from nlid import columns as col
    from nlid.identified import IdentifiedModel
    from nlid.scoring import Scores

    identity = (col.RUN_ID, col.DATASET, col.MODEL, col.METHOD, col.REPETITION, col.SEED, col.STATUS, col.ERROR)
    words = {f.name for f in (*identity, col.WARNINGS, col.MASS)}
    words |= {f.name for f in dataclasses.fields(Scores)} | {f.name for f in dataclasses.fields(IdentifiedModel)}
    prefixes = tuple(f"{f.name}:" for f in col.FAMILIES if f.labelled)
    metrics = {f.name for f in col.FAMILIES if not f.labelled} - words
    return prefixes, metrics


#: ``(file, key)``: a study column's name used by another vocabulary for the same quantity, with the reason.
SHARED_KEYS = {
    ("nlid/discovery/report.py", "eps_holdout_percent"): "a column of nlid discover's models.csv (its own file)",
}


def column_key_literals(root: Path, shared: dict[tuple[str, str], str] | None = None) -> list[str]:
    """String literals outside ``nlid/columns.py`` that spell a study-column key (see :func:`_declared_keys`)."""
    shared = SHARED_KEYS if shared is None else shared
    prefixes, metrics = _declared_keys()
    out = []
    for path in _sources(root):
        rel = path.relative_to(root).as_posix()
        if rel == "nlid/columns.py":
            continue
        for line, text in _strings(ast.parse(path.read_text())):
            if (text.startswith(prefixes) or text in metrics) and (rel, text) not in shared:
                out.append(f"{rel}:{line}: {text!r}")
    return sorted(out, key=_by_place)


def plugin_name_literals(root: Path, names: list[str]) -> list[str]:
    """String literals in the core (nlid/) equal to a built-in identifier's name.

    The core picks identifiers by their attributes (:mod:`nlid.methods`), never by name. A literal
    *equal* to a name (``"rfs"``, ``registry.create("oe")``, a ``{"nsi-ip": ...}`` key) is a use as a
    method name; docstrings, comments, the built-in study files (data, not code) and prose or CLI
    examples that mention a name inside a longer text (``"nlid identify x.csv --method rfs"``) are not.
    """
    out = []
    for path in sorted((root / "nlid").rglob("*.py")):
        for line, text in _strings(ast.parse(path.read_text())):
            if text in names:
                out.append(f"{path.relative_to(root).as_posix()}:{line}: {text!r}")
    return sorted(out, key=_by_place)


def test_no_module_is_over_600_lines():
    assert not long_modules(ROOT), "split by job:\n" + "\n".join(long_modules(ROOT))
    assert all((ROOT / rel).is_file() for rel in LONG_MODULES), "an exemption names a module that is gone"


def test_no_import_circle():
    """``python benchmarks/import_circles.py --edges`` shows the imports that make a circle."""
    assert not import_circles(ROOT), "\n".join(import_circles(ROOT))


def test_bayes_never_imports_study():
    """nlid.bayes sits below nlid.study (the study calls the posterior, never the reverse), even indirectly."""
    assert not import_paths(ROOT, "nlid.bayes", "nlid.study"), "\n".join(import_paths(ROOT, "nlid.bayes", "nlid.study"))


def test_no_study_column_key_is_spelled_outside_the_declarations():
    """Producers and consumers build keys through nlid/columns.py (``COEF_ERROR.key(term)``)."""
    assert not column_key_literals(ROOT), "\n".join(column_key_literals(ROOT))
    assert all((ROOT / rel).is_file() for rel, _ in SHARED_KEYS)


def test_the_core_names_no_plugin():
    names = sorted(_entry_points())
    assert names and not plugin_name_literals(ROOT, names), "\n".join(plugin_name_literals(ROOT, names))


def test_no_private_name_is_imported_across_packages():
    assert not private_imports(ROOT), "\n".join(private_imports(ROOT))


# ---------------------------------------------------------------------------- each rule fails on a violation
def _tree(root: Path, files: dict[str, str]) -> Path:
    """A synthetic checkout: ``{relative path: source}`` written under ``root``."""
    for rel, text in files.items():
        path = root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(textwrap.dedent(text))
    return root


CLEAN = {"nlid/__init__.py": "", "plugins/nlid_p/__init__.py": ""}


def test_the_size_rule_catches_a_long_module(tmp_path):
    root = _tree(tmp_path, {**CLEAN, "nlid/ok.py": "x = 1\n" * 600, "plugins/nlid_p/big.py": "x = 1\n" * 601})
    assert long_modules(root) == ["plugins/nlid_p/big.py: 601 lines"]
    assert long_modules(root, exempt={"plugins/nlid_p/big.py": "why"}) == []


def test_the_circle_rule_catches_deferred_imports_and_a_package_read_back(tmp_path):
    root = _tree(
        tmp_path,
        {
            **CLEAN,
            # a function-body import still closes a circle
            "nlid/a.py": "def f():\n    from .b import g\n",
            "nlid/b.py": "from .a import f\n",
            # annotations only: not a circle
            "nlid/c.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from .d import D\n",
            "nlid/d.py": "from .c import C\n",
            # a package importing its submodule, which reads the package's namespace back
            "nlid/study/__init__.py": "from .runner import run\n",
            "nlid/study/runner.py": "from . import columns\n",
            "nlid/study/columns.py": "",
            # the same in a plugin package
            "plugins/nlid_p/__init__.py": "from .x import y\n",
            "plugins/nlid_p/x.py": "from nlid_p import z\n",
        },
    )
    assert import_circles(root) == ["nlid.a <-> nlid.b", "nlid.study <-> nlid.study.runner", "nlid_p <-> nlid_p.x"]
    fixed = {"nlid/study/runner.py": "from .columns import KEY\n", "plugins/nlid_p/x.py": "import nlid_p.w\n"}
    _tree(root, {**fixed, "plugins/nlid_p/w.py": ""})
    assert import_circles(root) == ["nlid.a <-> nlid.b"]


def test_the_layer_rule_catches_bayes_reaching_study_through_another_module(tmp_path):
    root = _tree(
        tmp_path,
        {
            **CLEAN,
            "nlid/bayes/__init__.py": "",
            "nlid/bayes/fit.py": "def f():\n    from ..helper import g\n",
            "nlid/bayes/study.py": "from ..columns import KEY\n",  # bayes' own module called study: fine
            "nlid/helper.py": "from .study.plan import p\n",
            "nlid/columns.py": "",
            "nlid/study/__init__.py": "",
            "nlid/study/plan.py": "",
        },
    )
    assert import_paths(root, "nlid.bayes", "nlid.study") == ["nlid.bayes.fit -> nlid.helper -> nlid.study.plan"]


def test_the_column_rule_catches_a_key_spelled_outside_the_declarations(tmp_path):
    root = _tree(
        tmp_path,
        {
            **CLEAN,
            "nlid/columns.py": 'X = "coef_error_pct:"\n',  # the declarations themselves
            "nlid/producer.py": '''\
                """Writes coef_error_pct:<term> (a docstring may say so)."""
                def row(t, x):
                    return {f"coef_error_pct:{t}": x, "freerun_fit_pct": x, "method": "a", "seconds": 1.0}
                ''',
            "plugins/nlid_p/plot.py": 'KEY = "ci_lo:v"\nMASS = "mass"\n',
        },
    )
    found = column_key_literals(root)
    assert found == [
        "nlid/producer.py:3: 'coef_error_pct:'",
        "nlid/producer.py:3: 'freerun_fit_pct'",
        "plugins/nlid_p/plot.py:1: 'ci_lo:v'",
    ]
    assert column_key_literals(root, {("nlid/producer.py", "freerun_fit_pct"): "why"}) == [found[0], found[2]]


def test_the_plugin_rule_catches_a_method_named_in_the_core(tmp_path):
    root = _tree(
        tmp_path,
        {
            **CLEAN,
            "nlid/loop.py": '''\
                """Refines with oe when installed."""  # docstring: fine
                PREFERRED = ("rfs", "sindy")
                def refine(registry):
                    # a comment naming nsi-ip is fine
                    help = "example: nlid identify x.csv --method rfs"
                    return registry.create("oe")
                ''',
            "plugins/nlid_p/__init__.py": 'name = "rfs"\n',  # a plugin names itself
        },
    )
    names = ["nsi-ip", "oe", "rfs", "sindy"]
    found = plugin_name_literals(root, names)
    assert found == ["nlid/loop.py:2: 'rfs'", "nlid/loop.py:2: 'sindy'", "nlid/loop.py:6: 'oe'"]


def test_the_private_rule_catches_a_private_name_imported_across_packages(tmp_path):
    root = _tree(
        tmp_path,
        {
            **CLEAN,
            "nlid/interface.py": "def _helper(): pass\n",
            "nlid/plugin.py": "def _check(): pass\n",
            "nlid/_frozen.py": "",
            "nlid/record.py": "from .interface import _helper\nfrom ._frozen import F\n",  # same package: fine
            "nlid/study/__init__.py": "",
            "nlid/study/a.py": "from ..interface import _helper\nfrom .. import _frozen\nfrom .b import _own\n",
            "nlid/study/b.py": "def _own(): pass\n",
            "nlid/terms/__init__.py": "",
            "nlid/terms/_kernels.py": "",
            "nlid/sim/__init__.py": "",
            "nlid/sim/k.py": "def f():\n    from nlid.terms._kernels import step\nfrom ..columns import __all__\n",
            "plugins/nlid_p/__init__.py": "from nlid.plugin import _check\nimport numpy._core\n",
        },
    )
    assert private_imports(root) == [
        "nlid/sim/k.py:2: nlid.terms._kernels (private to nlid.terms)",
        "nlid/study/a.py:1: nlid.interface._helper (private to nlid)",
        "nlid/study/a.py:2: nlid._frozen (private to nlid)",
        "plugins/nlid_p/__init__.py:1: nlid.plugin._check (private to nlid)",
        "plugins/nlid_p/__init__.py:2: numpy._core (private to numpy)",
    ]
