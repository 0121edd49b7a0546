"""Sphinx configuration of the torchirid documentation site (``bash run.sh docs``)."""

from __future__ import annotations

import os
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
sys.path.insert(0, str(DOCS.parent / "src"))
sys.path.insert(0, str(DOCS / "_ext"))

import torchirid  # noqa: E402

project = "torchirid"
author = "the torchirid developers"
copyright = "2026, the torchirid developers"
release = version = torchirid.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "sphinx.ext.intersphinx",
    "sphinx.ext.autosummary",
    "myst_parser",
    "torchirid_xref",  # docs/_ext: references by any alias of a documented object
]
autosummary_generate = False

# the API reference: Google-style docstrings, members in the order of each package's __all__
autodoc_member_order = "bysource"
autodoc_typehints = "none"  # the docstrings state types, shapes and units
autodoc_default_options = {"members": True, "undoc-members": True, "imported-members": True}  # every name of __all__
napoleon_google_docstring = True
napoleon_numpy_docstring = False
napoleon_use_rtype = False
napoleon_use_ivar = True  # "Attributes:" as fields: dataclass fields are not described twice
nitpicky = True

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
myst_enable_extensions = ["dollarmath"]
myst_heading_anchors = 3
exclude_patterns = ["_build", "figures/README.md"]

html_theme = "pydata_sphinx_theme"
html_title = f"torchirid {version}"
html_theme_options = {"navigation_with_keys": False, "show_toc_level": 2}
html_static_path: list[str] = []

# offline: the inventories are the small local ones of docs/_intersphinx (make_inventories.py)
sys.path.insert(0, str(DOCS / "_intersphinx"))
from make_inventories import INVENTORIES  # noqa: E402

intersphinx_mapping = {name: (url, str(DOCS / "_intersphinx" / f"{name}.inv")) for name, (url, _) in INVENTORIES.items()}
