"""Sphinx configuration of nlid's documentation (built in CI with warnings as errors: ``.ci/run``).

Sphinx rather than MkDocs because nlid's docstrings are numpydoc reStructuredText
with Sphinx roles (``:func:``, ``:class:``, ``:mod:``) and reST tables: Sphinx
with numpydoc renders them as written and resolves the cross-references, while
the narrative pages stay Markdown through MyST.

Build: ``python -m sphinx -W --keep-going -b html docs docs/_build/html``.
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "plugins")]

import nlid  # noqa: E402

project = "nlid"
author = "the nlid authors"
copyright = "nlid authors, MIT licence"  # noqa: A001
release = version = nlid.__version__

extensions = [
    "myst_parser",
    "numpydoc",
    "sphinx.ext.autodoc",
    "sphinx.ext.intersphinx",
    "sphinx.ext.mathjax",
]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build"]
myst_enable_extensions = ["colon_fence", "dollarmath"]
myst_heading_anchors = 3

autodoc_member_order = "bysource"
autodoc_typehints = "none"  # numpydoc sections carry the types
autodoc_default_options = {"members": True, "undoc-members": False, "show-inheritance": False}
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False

# The docs are built offline (CI has PyPI, not the web): no intersphinx inventories are fetched.
intersphinx_mapping: dict = {}

html_theme = "alabaster"
html_title = f"nlid {release}"
html_theme_options = {"description": "nonlinear stiffness and friction from measured force and motion"}
