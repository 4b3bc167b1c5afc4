"""The digest of the code a study's outputs come from (reports and figures are redrawn when it changes)."""

from __future__ import annotations

import hashlib
from pathlib import Path

from ... import __version__

__all__ = ["code_digest"]


def code_digest(plugins: tuple[str, ...] = ()) -> str:
    """A digest of the code the outputs come from: nlid's, the identifier plugins' and matplotlib's.

    nlid's version and sources, the sources of the plugin packages named in ``plugins`` (top-level
    module names: their figure declarations and advice appear in the report) and matplotlib's version. A
    change of any of them (an upgrade, or an edit in a source checkout) makes every report and figure
    stale.
    """
    import sys
    from importlib.metadata import PackageNotFoundError, version

    h = hashlib.sha256(__version__.encode())
    roots = [Path(__file__).resolve().parents[2]]  # the nlid package
    for top in plugins:
        origin = getattr(sys.modules.get(top), "__file__", None)
        if origin:
            roots.append(Path(origin).parent if Path(origin).name == "__init__.py" else Path(origin))
    for root in roots:
        for path in sorted(root.rglob("*.py")) if root.is_dir() else [root]:
            h.update(path.name.encode())
            h.update(path.read_bytes())
    try:
        h.update(version("matplotlib").encode())
    except PackageNotFoundError:  # pragma: no cover - matplotlib is a dependency
        pass
    return h.hexdigest()
