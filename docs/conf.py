"""Sphinx configuration of the torchirid documentation site (``bash run.sh docs``)."""

from __future__ import annotations

import re
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
    "sphinx_gallery.gen_gallery",
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
autodoc_inherit_docstrings = False  # an undocumented forward() must not inherit torch's docstring


_PROSE: dict = {}


def _keep_prose(app, what, name, obj, options, lines):
    """Napoleon reads ``text: more`` on an attribute's or constant's first line as ``type:
    description``; torchirid's ``#:`` comments are prose: keep them as written (restored below,
    after napoleon has run)."""
    if what in ("data", "attribute", "property"):
        _PROSE[name] = list(lines)


def _restore_prose(app, what, name, obj, options, lines):
    if what in ("data", "attribute", "property") and name in _PROSE:
        lines[:] = _PROSE.pop(name)


_BARS = re.compile(r"(?<![\\|])\|(?=[^\s|])([^|`\n]*?[^\s|\\])\|(?!\|)")
_QUOTED = re.compile(r"(``.*?``|:\w+:`[^`]*`|`[^`]*`_?)")


def _absolute_values(app, what, name, obj, options, lines):
    """``|x|`` in torchirid's docstrings is an absolute value, never an RST substitution:
    escape the bars outside literals, roles and math. And a doctest indented under a paragraph
    line (``Example (what it shows):``) gets the blank line RST wants before it."""
    for i in range(len(lines) - 1, 0, -1):
        below, above = lines[i], lines[i - 1]
        if below.lstrip().startswith(">>>") and above.strip() and not above.lstrip().startswith(">>>") \
                and len(below) - len(below.lstrip()) > len(above) - len(above.lstrip()):
            lines.insert(i, "")
    for i, line in enumerate(lines):
        if "|" in line and not line.lstrip().startswith(("+", "|", "..")):
            parts = _QUOTED.split(line)
            lines[i] = "".join(part if j % 2 else _BARS.sub(r"\\|\1\\|", part) for j, part in enumerate(parts))


def _container_docs(app, what, name, obj, options, lines):
    """A constant without a ``#:`` comment must not show its type's docstring (dict's, tuple's)."""
    if what == "data" and lines and type(obj).__doc__ and lines[0].strip() == type(obj).__doc__.strip().splitlines()[0]:
        lines[:] = []


def setup(app):
    app.connect("autodoc-process-docstring", _container_docs, priority=300)
    app.connect("autodoc-process-docstring", _absolute_values, priority=700)
    app.connect("autodoc-process-docstring", _keep_prose, priority=400)  # before napoleon (500)
    app.connect("autodoc-process-docstring", _restore_prose, priority=600)  # after it

# the gallery: docs/examples/plot_*.py, executed at build time (each in seconds); the tests build
# the site with -D plot_gallery=0 and run the scripts themselves at a tiny size
sphinx_gallery_conf = {
    "examples_dirs": "examples",
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",
    "within_subsection_order": "FileNameSortKey",
    "download_all_examples": False,
    "image_scrapers": ("matplotlib",),
    "matplotlib_animations": False,
    "reference_url": {"torchirid": None},
    "doc_module": ("torchirid",),
    "backreferences_dir": None,
}

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
myst_enable_extensions = ["dollarmath"]
myst_heading_anchors = 3
# models.md is the equation map of the repository; the site shows it inside the guide's pages
# (docs/guide/*.md include its sections), not as a page of its own
exclude_patterns = ["_build", "figures/README.md", "examples/README.txt", "models.md"]

html_theme = "pydata_sphinx_theme"
html_title = f"torchirid {version}"
html_theme_options = {"navigation_with_keys": False, "show_toc_level": 2}
html_static_path: list[str] = []


def _vendored_mathjax() -> Path | None:
    """MathJax 3 from npm (``bash run.sh docs`` installs ``mathjax`` into .venv/node_modules, or
    $TORCHIRID_MATHJAX names its ``es5`` folder), staged into docs/_build/_mathjax: the site then
    renders its equations offline. Without it the pages load MathJax from its CDN when viewed."""
    import os
    import shutil

    source = Path(os.environ.get("TORCHIRID_MATHJAX", DOCS.parent / ".venv" / "node_modules" / "mathjax" / "es5"))
    if not (source / "tex-chtml.js").is_file():
        return None
    stage = DOCS / "_build" / "_mathjax"
    target = stage / "mathjax"
    # the component, its TeX extensions (autoloaded by macro) and the CHTML fonts: ~2.5 MB of 24
    for part in ("tex-chtml.js", "input/tex/extensions", "output/chtml/fonts/woff-v2", "ui", "a11y"):
        src, dst = source / part, target / part
        if src.is_dir() and not dst.is_dir():
            shutil.copytree(src, dst)
        elif src.is_file() and (not dst.is_file() or dst.stat().st_size != src.stat().st_size):
            dst.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dst)
    return stage


_MATHJAX = _vendored_mathjax()
if _MATHJAX is not None:
    html_static_path.append(str(_MATHJAX))
    mathjax_path = "mathjax/tex-chtml.js"  # relative to _static

# offline: the inventories are the small local ones of docs/_intersphinx (make_inventories.py)
sys.path.insert(0, str(DOCS / "_intersphinx"))
from make_inventories import INVENTORIES  # noqa: E402

intersphinx_mapping = {name: (url, str(DOCS / "_intersphinx" / f"{name}.inv")) for name, (url, _) in INVENTORIES.items()}
