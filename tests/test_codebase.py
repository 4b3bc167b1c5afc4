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
from nlid.contract import hookspecs

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
#: Modules of one job kept whole although longer, each with the reason (the limit is a guideline: a module is split
#: by job, never by size alone).
LONG_MODULES: dict[str, str] = {
    "nlid/bayes/result.py": "one job, the Posterior result (its numbers, table, flags, JSON and files): issue 35 "
    "added its flags, force hold, channel units and DataTree export; splitting it would cut the type in two",
}


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
    ``from nlid.model.terms._kernels import f`` reaches ``_kernels`` of ``nlid.model.terms``.
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
    from nlid.identified.model import IdentifiedModel
    from nlid.scoring import Scores
    from nlid.study import columns as col

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
    """String literals outside ``nlid/study/columns.py`` that spell a study-column key (see
    :func:`_declared_keys`)."""
    shared = SHARED_KEYS if shared is None else shared
    prefixes, metrics = _declared_keys()
    out = []
    for path in _sources(root):
        rel = path.relative_to(root).as_posix()
        if rel == "nlid/study/columns.py":
            continue
        for line, text in _strings(ast.parse(path.read_text())):
            if (text.startswith(prefixes) or text in metrics) and (rel, text) not in shared:
                out.append(f"{rel}:{line}: {text!r}")
    return sorted(out, key=_by_place)


def plugin_name_literals(root: Path, names: list[str]) -> list[str]:
    """String literals in the core (nlid/) equal to a built-in identifier's name.

    The core picks identifiers by their attributes (:mod:`nlid.contract.methods`), never by name. A literal
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
    """Producers and consumers build keys through nlid/study/columns.py (``COEF_ERROR.key(term)``)."""
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
            "nlid/scoring/columns.py": "",
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
            "nlid/study/columns.py": 'X = "coef_error_pct:"\n',  # the declarations themselves
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


# ============================================================================ the one house (issue 32)
# nlid/ is a few top-level modules (the facades and the errors) and packages by job. Each package stands on a
# floor of docs/architecture.md and imports only packages on the floors below it, so no two packages import
# each other; an import by name (importlib.import_module) counts. A public name has one home: the module that
# defines it, its own package's __init__, and the facades. Each rule is a checker over a source tree, shown
# to fail on a synthetic violation below.

#: The modules at the top of nlid/: the facades and the errors (everything else belongs to a package).
TOP_LEVEL = {"__init__.py", "api.py", "errors.py", "plugin.py", "testing.py"}
#: Modules whose ``__all__`` hands on names of other packages on purpose: the public facades.
FACADES = {"nlid", "nlid.plugin", "nlid.testing"}
#: Modules that hand on a name defined in another module (a second import path), each with the reason.
SECOND_PATHS = {
    "nlid.signal.derivatives": "plugins read the noise floor as an attribute of the module that nlid.plugin hands "
    "them (derivatives.suggest_cutoff, derivatives.noise_sd...): it goes when the toolkit exports those names",
}
#: Modules that import a module of nlid by name (``importlib.import_module("nlid....")``) across the floors.
BY_NAME = {
    "nlid/runtime/preload.py": "the fork server warms the floors above it by name: the seam of issue 32 has the "
    "callers hand it what to load",
}
#: The page that names every package and the floor it stands on.
ARCHITECTURE = "docs/architecture.md"


_CACHE: dict[tuple, object] = {}


def _cached(kind: str, root: Path, make):
    """``make()`` once per state of the tree's Python files (their paths, sizes and times)."""
    files = tuple((str(p), p.stat().st_mtime_ns, p.stat().st_size) for p in sorted((root / "nlid").rglob("*.py")))
    key = (kind, str(root), files)
    if key not in _CACHE:
        _CACHE[key] = make()
    return _CACHE[key]


def _module_name(root: Path, path: Path) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def imports_by_name(root: Path) -> list[tuple[str, str, int, str]]:
    """``(file, importer, line, module)`` of each ``importlib.import_module("nlid...")`` with a literal name."""
    return _cached("by name", root, lambda: _imports_by_name(root))


def _imports_by_name(root: Path) -> list[tuple[str, str, int, str]]:
    out = []
    for path in sorted((root / "nlid").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if not (isinstance(node, ast.Call) and node.args and isinstance(node.args[0], ast.Constant)):
                continue
            func = node.func
            name = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
            target = node.args[0].value
            if name in ("import_module", "__import__") and isinstance(target, str) and target.startswith("nlid"):
                out.append((path.relative_to(root).as_posix(), _module_name(root, path), node.lineno, target))
    return out


def package_of(root: Path, module: str) -> str:
    """``nlid.data`` for every module of ``nlid/data/``; a top-level module is its own."""
    parts = module.split(".")
    return ".".join(parts[:2]) if len(parts) > 1 and (root / "nlid" / parts[1]).is_dir() else module


def package_graph(root: Path, by_name: dict[str, str] | None = None) -> dict[str, dict[str, list[str]]]:
    """Package -> {package it imports: ["module -> module", ...]}, imports by name included (but ``by_name``'s)."""
    by_name = BY_NAME if by_name is None else by_name
    modules = _cached("graph", root, lambda: IMPORTS.import_graph(root / "nlid"))
    edges = [(a, b) for a, targets in modules.items() for b in targets]
    edges += [(a, t) for rel, a, _, t in imports_by_name(root) if rel not in by_name]
    graph: dict[str, dict[str, list[str]]] = {package_of(root, m): {} for m in modules}
    for a, b in edges:
        pa, pb = package_of(root, a), package_of(root, b)
        if pa != pb:
            graph.setdefault(pa, {}).setdefault(pb, []).append(f"{a} -> {b}")
    return graph


def package_circles(root: Path, by_name: dict[str, str] | None = None) -> list[str]:
    """Circles of packages (``a <-> b``), each import between two of them shown by one of its modules."""
    graph = package_graph(root, by_name)
    out = []
    for circle in IMPORTS.circles({p: dict.fromkeys(t, [0]) for p, t in graph.items()}):
        why = [f"{a} -> {b} ({min(ws)})" for a in circle for b, ws in sorted(graph[a].items()) if b in circle]
        out.append(" <-> ".join(circle) + ": " + "; ".join(why))
    return out


def floors(text: str) -> dict[str, int]:
    """``{package or top-level module: floor}`` from the floors table (``| 3 | `nlid/data/` ... |``)."""
    out = {}
    for line in text.splitlines():
        row = re.match(r"^\|\s*(\d+)\s*\|([^|]*)\|", line)
        if row:
            for path in re.findall(r"`(nlid/[^`]*)`", row.group(2)):
                out[path.rstrip("/").removesuffix(".py").replace("/", ".").removesuffix(".__init__")] = int(row[1])
    return out


def floor_violations(root: Path, by_name: dict[str, str] | None = None) -> list[str]:
    """Imports from a package to one on its own floor or above (imports by name too)."""
    floor = floors((root / ARCHITECTURE).read_text())
    out = []
    for a, targets in sorted(package_graph(root, by_name).items()):
        for b, why in sorted(targets.items()):
            if a in floor and b in floor and floor[a] <= floor[b]:
                out.append(f"{a} (floor {floor[a]}) -> {b} (floor {floor[b]}): {sorted(why)[0]}")
    return out


def undocumented(root: Path) -> list[str]:
    """Packages of nlid/ that the architecture page does not name, and top-level ones missing from its floors."""
    text = (root / ARCHITECTURE).read_text()
    floor = floors(text)
    out = []
    for init in sorted((root / "nlid").rglob("__init__.py")):
        folder = init.parent.relative_to(root).as_posix()
        if folder != "nlid" and f"`{folder}/`" not in text:
            out.append(f"{folder}/ is not on {ARCHITECTURE}")
    for path in sorted((root / "nlid").iterdir()):
        top = (path / "__init__.py").is_file() or path.suffix == ".py"
        if top and _module_name(root, path) not in floor:
            out.append(f"{path.relative_to(root).as_posix()} has no floor on {ARCHITECTURE}")
    return out


def top_level_modules(root: Path) -> list[str]:
    """Modules at the top of nlid/ that are not the facades or the errors."""
    return sorted(p.name for p in (root / "nlid").glob("*.py") if p.name not in TOP_LEVEL)


def _read(path: Path) -> tuple[set[str], dict[str, tuple[str, str]], list[str]]:
    """What a module defines, imports (``local: (module, name)``, relative resolved later) and exports."""
    defined: set[str] = set()
    imported: dict[str, tuple[str, str]] = {}
    exported: list[str] = []

    def visit(body: list[ast.stmt]) -> None:
        for node in body:
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                defined.add(node.name)
            elif isinstance(node, (ast.Assign, ast.AnnAssign)):
                targets = node.targets if isinstance(node, ast.Assign) else [node.target]
                for t in targets:
                    defined.update(n.id for n in ast.walk(t) if isinstance(n, ast.Name))
                    if isinstance(t, ast.Name) and isinstance(node.value, (ast.List, ast.Tuple, ast.Dict)):
                        if t.id == "__all__":
                            exported.extend(e.value for e in node.value.elts if isinstance(e, ast.Constant))
                        elif t.id == "_LAZY" and isinstance(node.value, ast.Dict):
                            for k, v in zip(node.value.keys, node.value.values, strict=True):
                                if isinstance(k, ast.Constant) and isinstance(v, ast.Constant):
                                    exported.append(k.value)
                                    imported[k.value] = ("=" + v.value, k.value)
            elif isinstance(node, ast.ImportFrom):
                for a in node.names:
                    imported[a.asname or a.name] = ("." * node.level + (node.module or ""), a.name)
            elif isinstance(node, (ast.If, ast.Try)):
                visit(node.body)
                visit(node.orelse)
                for h in getattr(node, "handlers", []):
                    visit(h.body)

    visit(ast.parse(path.read_text()).body)
    return defined, imported, exported


def second_paths(root: Path, facades: set[str] | None = None, exempt: dict[str, str] | None = None) -> list[str]:
    """Names a module exports (``__all__``, ``_LAZY``) that it neither defines nor holds as its package's face.

    A name's home is the module that defines it; besides it, only the ``__init__`` of a package that holds
    that module and the facades may list it. Any other module listing it (a sibling, another package, a
    module kept under an old name) is a second import path.
    """
    facades = FACADES if facades is None else facades
    exempt = SECOND_PATHS if exempt is None else exempt
    paths = IMPORTS.module_names(root / "nlid")
    read = _cached("read", root, lambda: {name: _read(path) for name, path in paths.items()})

    def absolute(importer: str, spec: str) -> str:
        if spec.startswith("="):
            return spec[1:]
        level = len(spec) - len(spec.lstrip("."))
        if not level:
            return spec
        base = importer if paths[importer].name == "__init__.py" else importer.rpartition(".")[0]
        anchor = base.split(".")[: len(base.split(".")) - (level - 1)]
        return ".".join(anchor + ([spec.lstrip(".")] if spec.lstrip(".") else []))

    def home(module: str, name: str, seen: frozenset = frozenset()) -> str:
        if module not in read or (module, name) in seen or name in read[module][0]:
            return module
        if name not in read[module][1]:
            return module
        source, original = read[module][1][name]
        source = absolute(module, source)
        if f"{source}.{original}" in read or not source.startswith("nlid"):
            return module  # a module handed on by name is the module; another library's name is not ours
        return home(source, original, seen | {(module, name)})

    out = []
    for module, (_, _, exported) in sorted(read.items()):
        if module in facades or module in exempt:
            continue
        for name in exported:
            where = home(module, name)
            face = paths[module].name == "__init__.py" and where.startswith(module + ".")
            if where != module and not face:
                out.append(f"{module}.{name}: a second path to {where}.{name}")
    return out


def private_imports_by_name(root: Path) -> list[str]:
    """Imports by name (``importlib.import_module("nlid.x._y")``) of a private module of another package."""
    out = []
    for rel, importer, line, target in imports_by_name(root):
        parts = target.split(".")
        for k, part in enumerate(parts):
            if _is_private(part) and package_of(root, ".".join(parts[:k])) != package_of(root, importer):
                out.append(f"{rel}:{line}: {'.'.join(parts[: k + 1])}")
                break
    return out


def test_nlid_top_level_holds_only_the_facades_and_the_errors():
    assert not top_level_modules(ROOT), "give these a package: " + ", ".join(top_level_modules(ROOT))


def test_no_import_circle_between_packages():
    """Two packages never import each other, directly or through others (imports by name count)."""
    assert not package_circles(ROOT), "\n".join(package_circles(ROOT))
    assert all((ROOT / rel).is_file() for rel in BY_NAME), "an exemption names a module that is gone"
    assert all(any(rel == r for r, *_ in imports_by_name(ROOT)) for rel in BY_NAME), "an exemption is not needed"


def test_packages_import_only_the_floors_below():
    """The floors of docs/architecture.md are the layering: up is never imported."""
    assert not floor_violations(ROOT), "\n".join(floor_violations(ROOT))


def test_every_package_is_on_the_architecture_page():
    assert not undocumented(ROOT), "\n".join(undocumented(ROOT))


def test_every_public_name_has_one_import_path():
    assert not second_paths(ROOT), "\n".join(second_paths(ROOT))
    modules = IMPORTS.module_names(ROOT / "nlid")
    assert all(m in modules for m in SECOND_PATHS), "an exemption names a module that is gone"
    for module in SECOND_PATHS:  # an exemption that no longer hands on a name goes
        assert second_paths(ROOT, exempt={}) != second_paths(ROOT, exempt={module: ""}), module


def test_no_private_module_is_imported_by_name_across_packages():
    assert not private_imports_by_name(ROOT), "\n".join(private_imports_by_name(ROOT))


# ---------------------------------------------------------------------------- the house rules fail on a violation
HOUSE = {
    "nlid/__init__.py": "",
    "nlid/errors.py": "",
    "nlid/base/__init__.py": "",
    "nlid/base/frozen.py": "class FrozenDict: pass\n__all__ = ['FrozenDict']\n",
    "nlid/data/__init__.py": "",
    "nlid/data/record.py": "from ..base.frozen import FrozenDict\nclass Record: pass\n__all__ = ['Record']\n",
    "nlid/study/__init__.py": "_LAZY = {'run': 'nlid.study.run'}\n",
    "nlid/study/run.py": "from ..data.record import Record\ndef run(): pass\n__all__ = ['run']\n",
    ARCHITECTURE: "| Floor | Packages |\n|---|---|\n| 3 | `nlid/study/` |\n| 2 | `nlid/data/` |\n"
    "| 1 | `nlid/base/`, `nlid/errors.py` |\n| 4 | `nlid/__init__.py` |\n",
    "plugins/nlid_p/__init__.py": "",
}


def test_the_package_rules_catch_a_circle_a_floor_and_a_page(tmp_path):
    root = _tree(tmp_path, HOUSE)
    assert package_circles(root) == [] and floor_violations(root) == [] and undocumented(root) == []
    by_name = "def f():\n    import importlib\n    importlib.import_module('nlid.data.record')\n"
    _tree(root, {"nlid/base/frozen.py": by_name})
    assert package_circles(root, by_name={}) == [
        "nlid.base <-> nlid.data: nlid.base -> nlid.data (nlid.base.frozen -> nlid.data.record); "
        "nlid.data -> nlid.base (nlid.data.record -> nlid.base.frozen)"
    ]
    assert package_circles(root, by_name={"nlid/base/frozen.py": "why"}) == []
    assert floor_violations(root, by_name={}) == [
        "nlid.base (floor 1) -> nlid.data (floor 2): nlid.base.frozen -> nlid.data.record"
    ]
    _tree(root, {"nlid/scoring/__init__.py": "", "nlid/scoring/rules/__init__.py": "", "nlid/tools.py": ""})
    assert undocumented(root) == [
        "nlid/scoring/ is not on docs/architecture.md",
        "nlid/scoring/rules/ is not on docs/architecture.md",
        "nlid/scoring has no floor on docs/architecture.md",
        "nlid/tools.py has no floor on docs/architecture.md",
    ]
    assert top_level_modules(root) == ["tools.py"]


def test_the_one_path_rule_catches_a_second_path(tmp_path):
    root = _tree(tmp_path, HOUSE)
    assert second_paths(root, facades={"nlid"}, exempt={}) == []
    _tree(
        root,
        {
            "nlid/study/__init__.py": "_LAZY = {'Record': 'nlid.data.record', 'run': 'nlid.study.run'}\n",
            "nlid/study/run.py": "from ..data.record import Record\ndef run(): pass\n__all__ = ['run', 'Record']\n",
            "nlid/data/__init__.py": "from .record import Record\n__all__ = ['Record']\n",  # its own face: fine
            "nlid/record.py": "from .data.record import *\nfrom .data.record import Record\n__all__ = ['Record']\n",
        },
    )
    assert second_paths(root, facades={"nlid"}, exempt={}) == [
        "nlid.record.Record: a second path to nlid.data.record.Record",
        "nlid.study.Record: a second path to nlid.data.record.Record",
        "nlid.study.run.Record: a second path to nlid.data.record.Record",
    ]
    assert second_paths(root, facades={"nlid", "nlid.study"}, exempt={"nlid.record": "why"}) == [
        "nlid.study.run.Record: a second path to nlid.data.record.Record"
    ]


def test_the_private_rule_catches_an_import_by_name(tmp_path):
    root = _tree(
        tmp_path,
        {
            **HOUSE,
            "nlid/base/_kernels.py": "",
            "nlid/study/run.py": "import importlib\nk = importlib.import_module('nlid.base._kernels')\n",
            "nlid/base/frozen.py": "import importlib\nk = importlib.import_module('nlid.base._kernels')\n",
        },
    )
    assert private_imports_by_name(root) == ["nlid/study/run.py:2: nlid.base._kernels"]


# ---------------------------------------------------------------------------- the tests mirror the package tree
#: The test modules at the root of ``tests/``: the suites named by concern, which test the project as a whole.
#: Every other test module sits in the folder of the package it tests (``tests/<package>/``).
CONCERN_SUITES = {
    "test_pins.py": "the numbers pinned before issue 12 (CI and a hook run the pins by path)",
    "test_pins_spine.py": "the numbers pinned before issue 22",
    "test_pinning.py": "the pins' comparison with measured tolerances (tests/pinning.py)",
    "test_codebase.py": "the rules on the code base (this module)",
    "test_docs.py": "the documentation against the code",
    "test_docs_edges.py": "the documentation's edge cases",
    "test_readme.py": "README's commands and numbers",
    "test_howto.py": "docs/howto.md's code blocks",
    "test_examples.py": "the scripts in examples/",
    "test_packaging.py": "the built distribution",
    "test_hostile.py": "hostile input at the command line (issue 18)",
    "test_hostile_round2.py": "hostile input, second round",
    "test_hostile_round3.py": "hostile input, third round",
    "test_properties.py": "hostile input, property-based (hypothesis) over every reader of user input (issue 18)",
    "test_reliability.py": "hostile input through the Python API, every package (issue 18)",
}
#: Test folders not named after the package of ``nlid/`` they test, and what they hold.
TEST_FOLDERS = {
    "plugins": "the identifiers of plugins/",
    "bench": "nlid/benchmarking/ (nlid bench)",
    "dataio": "nlid/data/ (tests/data/ holds the pin files)",
    "data": "the pin files, no test module",
}


def misplaced_tests(root: Path, concern: dict[str, str] = CONCERN_SUITES) -> list[str]:
    """Test modules that break the mirror of the package tree, each with what to do.

    A root-level ``tests/test_*.py`` that is not a named concern suite; a test folder named after no package
    of ``nlid/`` (and not in :data:`TEST_FOLDERS`); a test module in ``tests/data/``; two test modules with
    the same name (the test folders have no ``__init__.py``, so pytest needs every basename unique).
    """
    tests, out = root / "tests", []
    for path in sorted(tests.glob("test_*.py")):
        if path.name not in concern:
            out.append(f"tests/{path.name}: move it to tests/<package>/, or name it in CONCERN_SUITES with its concern")
    seen: dict[str, Path] = {}
    for path in sorted(tests.rglob("test_*.py")):
        rel = path.relative_to(tests)
        if any(part.startswith((".", "_")) for part in rel.parts):
            continue
        if path.name in seen:
            out.append(f"tests/{rel}: the same name as tests/{seen[path.name].relative_to(tests)}")
        seen.setdefault(path.name, path)
        folder = rel.parts[0] if len(rel.parts) > 1 else None
        if folder == "data" or (folder and folder not in TEST_FOLDERS and not (root / "nlid" / folder).is_dir()):
            out.append(f"tests/{rel}: tests/{folder}/ is named after no package of nlid/")
    return out


def test_the_tests_mirror_the_package_tree():
    assert not misplaced_tests(ROOT), "\n".join(misplaced_tests(ROOT))
    assert all((ROOT / "tests" / name).is_file() for name in CONCERN_SUITES), "a concern suite is gone"


def test_the_mirror_rule_catches_a_root_module_a_stray_folder_and_a_twin(tmp_path):
    root = _tree(
        tmp_path,
        {
            **CLEAN,
            "nlid/model/__init__.py": "",
            "tests/test_codebase.py": "",
            "tests/test_new.py": "",
            "tests/model/test_terms.py": "",
            "tests/dataio/test_record.py": "",
            "tests/stuff/test_terms.py": "",
            "tests/data/test_pins_data.py": "",
        },
    )
    assert misplaced_tests(root) == [
        "tests/test_new.py: move it to tests/<package>/, or name it in CONCERN_SUITES with its concern",
        "tests/data/test_pins_data.py: tests/data/ is named after no package of nlid/",
        "tests/stuff/test_terms.py: the same name as tests/model/test_terms.py",
        "tests/stuff/test_terms.py: tests/stuff/ is named after no package of nlid/",
    ]
    assert misplaced_tests(root, {**CONCERN_SUITES, "test_new.py": "why"})[0].startswith("tests/data/")
