"""List the import circles among nlid's modules (issue 22).

A circle is a set of modules that import each other, directly or through others (a strongly connected
component of the import graph with more than one module). Every import counts, those inside function
bodies too, except imports under ``if TYPE_CHECKING:`` (annotations only) and a package's
``__init__`` importing its own submodules (a package re-exporting what it holds).

Usage::

    python benchmarks/import_circles.py            # circles among nlid's modules
    python benchmarks/import_circles.py --edges    # also the imports that make each circle
    python benchmarks/import_circles.py --type-checking   # count imports for annotations too

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


def import_graph(package: Path, type_checking: bool = False) -> dict[str, dict[str, list[int]]]:
    """Module -> {imported module: [lines]} among the package's modules."""
    modules = module_names(package)
    graph: dict[str, dict[str, list[int]]] = {name: {} for name in modules}
    for name, path in modules.items():
        is_package = path.name == "__init__.py"
        base = name if is_package else name.rpartition(".")[0]
        for node in _imports(ast.parse(path.read_text(), str(path)), type_checking):
            targets = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            else:
                if node.level:
                    anchor = base.split(".")
                    anchor = anchor[: len(anchor) - (node.level - 1)]
                    mod = ".".join(anchor + ([node.module] if node.module else []))
                else:
                    mod = node.module or ""
                for alias in node.names:
                    sub = f"{mod}.{alias.name}"
                    targets.append(sub if sub in modules else mod)
            for target in targets:
                while target and target not in modules:  # import a.b.c of a non-module: its nearest module
                    target = target.rpartition(".")[0]
                if not target or target == name:
                    continue
                if is_package and target.startswith(name + "."):
                    continue  # a package's __init__ importing its own submodules
                lines = graph[name].setdefault(target, [])
                if node.lineno not in lines:
                    lines.append(node.lineno)
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


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--package", default=str(ROOT / "nlid"), help="package folder (default: nlid/)")
    parser.add_argument("--edges", action="store_true", help="also print the imports inside each circle")
    parser.add_argument("--type-checking", action="store_true", help="count imports under `if TYPE_CHECKING:` too")
    args = parser.parse_args(argv)
    graph = import_graph(Path(args.package), args.type_checking)
    found = circles(graph)
    for comp in found:
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
