"""Test plugins as an installed distribution: modules and a ``*.dist-info`` declaring their entry points.

To ``importlib.metadata`` (and so to nlid's registry and to child processes, which get the parent's
``sys.path``) a folder holding these, once on ``sys.path``, is an installed distribution.
"""

from __future__ import annotations

import textwrap
from collections.abc import Mapping
from pathlib import Path


def write_distribution(folder: Path, name: str, modules: Mapping[str, str], entry_points: Mapping[str, str]) -> None:
    """Write ``modules`` (name -> source) and ``NAME-0.1.dist-info`` with ``nlid.identifiers`` ``entry_points``."""
    for module, source in modules.items():
        (folder / f"{module}.py").write_text(textwrap.dedent(source))
    info = folder / f"{name.replace('-', '_')}-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: 0.1\n")
    lines = "".join(f"{entry} = {module}\n" for entry, module in entry_points.items())
    (info / "entry_points.txt").write_text("[nlid.identifiers]\n" + lines)
