"""List the import circles among nlid's modules (issue 22); ``tests/test_codebase.py`` applies the same rule.

A circle is a set of modules that import each other, directly or through others (a strongly connected
component of the import graph with more than one module). What counts as an import:

* every ``import`` and ``from ... import`` statement, those inside function bodies too (a deferred
  import hides a circle, it does not remove it), except those under ``if TYPE_CHECKING:``
  (annotations only);
* a package's ``__init__`` importing its own submodules: a submodule that imports its package's
  namespace back (``from . import name``, ``from nlid.study import run_study``) then closes a circle;
* ``from P import name`` imports ``P`` (its namespace is read), and ``P.name`` too when that is a
  module: ``from . import columns`` in ``nlid/study/worker.py`` is an import of ``nlid.study`` and of
  ``nlid.study.columns``.

``import a.b.c`` imports ``a.b.c`` (the parent packages it initialises on the way are not counted:
they have started initialising before any of their submodules runs). A name loaded lazily through
:func:`importlib.import_module` (``nlid.__getattr__``) is not an import statement and is not counted.

Usage::

    python benchmarks/import_circles.py            # circles among nlid's modules and each plugin's
    python benchmarks/import_circles.py --edges    # also the imports that make each circle
    python benchmarks/import_circles.py --type-checking   # count imports for annotations too
    python benchmarks/import_circles.py --package plugins/nlid_nsi   # one package

Exit status 1 when there is a circle.
"""

from __future__ import annotations

import argparse
import ast
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def module_names(package: Path) -> dict[str, Path]:
    """Dotted name -> file of every module of the package (``nlid.x`` for ``nlid/x/__init__.py``)."""
    out = {}
    for path in sorted(package.rglob("*.py")):
        parts = list(path.relative_to(package.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        out[".".join(parts)] = path
    return out


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _imports(tree: ast.AST, type_checking: bool = False):
    """Every import node of a module, anywhere in it, except under ``if TYPE_CHECKING:`` (unless asked)."""
    stack = [tree]
    while stack:
        node = stack.pop()
        if not type_checking and isinstance(node, ast.If) and _is_type_checking(node.test):
            stack.extend(node.orelse)
            continue
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            yield node
        stack.extend(ast.iter_child_nodes(node))


def resolved_imports(package: Path, type_checking: bool = False):
    """Every import of the package's modules, resolved: ``(importer, line, module, name)``.

    ``module`` is the absolute dotted module an import statement names (relative imports resolved);
    ``name`` is the imported name of ``from module import name`` and ``None`` for ``import module``.
    """
    own = module_names(package)
    for importer, path in own.items():
        is_package = path.name == "__init__.py"
        base = importer if is_package else importer.rpartition(".")[0]
        for node in _imports(ast.parse(path.read_text(), str(path)), type_checking):
            if isinstance(node, ast.Import):
                for alias in node.names:
                    yield importer, node.lineno, alias.name, None
                continue
            if node.level:
                anchor = base.split(".")
                anchor = anchor[: len(anchor) - (node.level - 1)]
                mod = ".".join(anchor + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            for alias in node.names:
                yield importer, node.lineno, mod, alias.name


def import_graph(package: Path, type_checking: bool = False) -> dict[str, dict[str, list[int]]]:
    """Module -> {imported module: [lines]} among the package's modules (see the module docstring)."""
    modules = module_names(package)
    graph: dict[str, dict[str, list[int]]] = {name: {} for name in modules}
    for importer, line, mod, name in resolved_imports(package, type_checking):
        targets = [mod]
        if name is not None and f"{mod}.{name}" in modules:
            targets.append(f"{mod}.{name}")  # from package import submodule: both
        for target in targets:
            while target and target not in modules:  # import a.b.c of a non-module: its nearest module
                target = target.rpartition(".")[0]
            if not target or target == importer:
                continue
            lines = graph[importer].setdefault(target, [])
            if line not in lines:
                lines.append(line)
    return graph


def circles(graph: dict[str, dict[str, list[int]]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    on_stack: set[str] = set()
    stack: list[str] = []
    out: list[list[str]] = []
    counter = [0]

    def visit(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for v in sorted(graph):
        if v not in index:
            visit(v)
    return sorted(out)


def packages(root: Path = ROOT) -> list[Path]:
    """nlid's package and each plugin package under ``plugins/``."""
    plugins = root / "plugins"
    found = sorted(p for p in plugins.iterdir() if (p / "__init__.py").is_file()) if plugins.is_dir() else []
    return [root / "nlid", *found]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--package", action="append", help="package folder (repeatable; default: nlid/ and each plugin package)"
    )
    parser.add_argument("--edges", action="store_true", help="also print the imports inside each circle")
    parser.add_argument("--type-checking", action="store_true", help="count imports under `if TYPE_CHECKING:` too")
    args = parser.parse_args(argv)
    found = []
    for package in [Path(p) for p in args.package] if args.package else packages():
        graph = import_graph(package, args.type_checking)
        for comp in circles(graph):
            found.append(comp)
            print(" <-> ".join(comp))
            if args.edges:
                members = set(comp)
                for a in comp:
                    for b, lines in sorted(graph[a].items()):
                        if b in members:
                            print(f"    {a} -> {b} (line {', '.join(map(str, sorted(lines)))})")
    print(f"{len(found)} circle(s)")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
