"""The documentation site builds (issue 26): Sphinx with autodoc over every public name, nitpicky
cross-references (``-n``), every warning an error (``-W``), offline — so a docstring that does not
render, or a reference to a name that is not documented, fails CI. The gallery's pages are built
without running the scripts (``plot_gallery=0``); each script runs here at a tiny size. The tests
of the built site are marked ``integration`` (Sphinx, npm's MathJax); the gallery scripts are not."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

pytest.importorskip("sphinx", reason="sphinx is not installed (the dev extra has it)")
pytest.importorskip("pydata_sphinx_theme", reason="pydata-sphinx-theme is not installed (the dev extra has it)")
pytest.importorskip("myst_parser", reason="myst-parser is not installed (the dev extra has it)")


def normalise(line: str) -> str:
    """A warning without the checkout's path and line numbers (they move with every edit)."""
    line = line.replace(str(ROOT) + "/", "")
    return re.sub(r":\d+:", ":", line).strip()


@pytest.fixture(scope="module")
def build(tmp_path_factory):
    out = tmp_path_factory.mktemp("site")
    warnings = out / "warnings.txt"
    r = subprocess.run([sys.executable, "-m", "sphinx", "-q", "-n", "-W", "--keep-going", "-E", "-b", "html",
                        "-D", "plot_gallery=0", "-w",
                        str(warnings),
                        str(ROOT / "docs"), str(out / "html")], capture_output=True, text=True, timeout=600)
    return out / "html", r, [normalise(x) for x in warnings.read_text().splitlines() if x.strip()]


@pytest.mark.integration  # the Sphinx build
def test_the_site_builds_without_a_warning(build):
    _, r, warnings = build
    assert not warnings, "documentation warnings (fix the docstring or the reference):\n" + "\n".join(warnings)
    assert r.returncode == 0, r.stderr[-3000:]


@pytest.mark.integration  # the Sphinx build
def test_every_public_name_has_a_page_entry(build):
    html, _, _ = build
    import torchirid

    missing = []
    for pkg in ("optics", "microfacet", "layered", "spectral", "color", "ibl", "estimation", "fitting", "design", "realtime",
                "scale", "materials", "lut", "export"):
        page = (html / "api" / f"{pkg}.html").read_text(encoding="utf-8")
        module = getattr(torchirid, pkg, None) or __import__(f"torchirid.{pkg}", fromlist=["x"])
        for name in module.__all__:
            if not re.search(rf'id="torchirid\.[\w.]*\b{re.escape(name)}"', page):
                missing.append(f"torchirid.{pkg}.{name}")
    assert not missing, missing


EXAMPLES = sorted((ROOT / "docs" / "examples").glob("plot_*.py"))


# every script in one child process (torch, matplotlib and the colour tables imported once, ~3 s
# of CPU saved per script), each in a fresh namespace as sphinx-gallery runs them; the child
# reports each script's traceback (or none) as JSON
_RUN_ALL = r"""
import json, runpy, sys, traceback
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
plt.show = lambda *a, **k: None
results = {}
for path in sys.argv[1:]:
    try:
        runpy.run_path(path, run_name="__main__")
        results[path] = None
    except BaseException:
        results[path] = traceback.format_exc()[-3000:]
    plt.close("all")
print("RESULTS" + json.dumps(results))
"""


@pytest.fixture(scope="module")
def gallery_runs(tmp_path_factory):
    import json
    import os

    env = dict(os.environ, TORCHIRID_GALLERY_TINY="1", MPLBACKEND="Agg")
    r = subprocess.run([sys.executable, "-c", _RUN_ALL, *map(str, EXAMPLES)], capture_output=True, text=True,
                       timeout=900, cwd=tmp_path_factory.mktemp("gallery"), env=env)
    line = next((x for x in r.stdout.splitlines() if x.startswith("RESULTS")), None)
    assert line is not None, f"the gallery runner failed (status {r.returncode}):\n{r.stderr[-3000:]}"
    return json.loads(line[len("RESULTS"):])


@pytest.mark.parametrize("script", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_gallery_script_runs_at_a_tiny_size(script, gallery_runs):
    error = gallery_runs[str(script)]
    assert error is None, error


@pytest.mark.integration  # the Sphinx build
def test_the_gallery_has_its_pages(build):
    html, _, _ = build
    for script in EXAMPLES:
        assert (html / "auto_examples" / f"{script.stem}.html").is_file(), script.stem


@pytest.mark.integration  # the Sphinx build
def test_equations_render_offline(build):
    """With MathJax vendored (``bash run.sh test``/``docs`` install npm's mathjax), every page with
    maths loads it from the site itself, and the fonts it needs are there: nothing fetched."""
    html, _, _ = build
    if not (ROOT / ".venv" / "node_modules" / "mathjax" / "es5" / "tex-chtml.js").is_file():
        pytest.skip("npm's mathjax is not installed (bash run.sh test installs it); the site uses MathJax's CDN")
    pages = [p.read_text(encoding="utf-8") for p in html.rglob("*.html")]
    assert not any("cdn.jsdelivr" in p or "mathjax@3" in p for p in pages)
    static = html / "_static" / "mathjax"
    assert (static / "tex-chtml.js").stat().st_size > 500_000
    assert any((static / "output" / "chtml" / "fonts" / "woff-v2").glob("*.woff"))
    api = (html / "api" / "spectral.html").read_text(encoding="utf-8")
    assert "_static/mathjax/tex-chtml.js" in api and r"\(" in api  # a page with inline maths
