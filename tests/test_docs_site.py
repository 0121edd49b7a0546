"""The documentation site builds (issue 26): Sphinx with autodoc over every public name, nitpicky
cross-references, offline. The gallery is not executed here.

Until every docstring renders cleanly, the build's warnings are held to a ratchet: a warning
that is not in tests/docs_warnings_baseline.txt fails (a broken new docstring or reference);
fixing one lets its line be deleted from the baseline, which then only shrinks."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BASELINE = Path(__file__).with_name("docs_warnings_baseline.txt")

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
    r = subprocess.run([sys.executable, "-m", "sphinx", "-q", "-n", "-E", "-b", "html", "-w", str(warnings),
                        str(ROOT / "docs"), str(out / "html")], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
    return out / "html", [normalise(x) for x in warnings.read_text().splitlines() if "WARNING" in x or "ERROR" in x]


def test_the_site_builds_with_no_new_warning(build):
    _, warnings = build
    known = set(BASELINE.read_text(encoding="utf-8").splitlines())
    new = sorted(set(warnings) - known)
    assert not new, "new documentation warnings (fix the docstring or reference):\n" + "\n".join(new)


def test_every_public_name_has_a_page_entry(build):
    html, _ = build
    import torchirid

    missing = []
    for pkg in ("optics", "microfacet", "layered", "spectral", "color", "ibl", "estimation", "fitting", "realtime",
                "scale", "materials", "lut", "export"):
        page = (html / "api" / f"{pkg}.html").read_text(encoding="utf-8")
        module = getattr(torchirid, pkg, None) or __import__(f"torchirid.{pkg}", fromlist=["x"])
        for name in module.__all__:
            if not re.search(rf'id="torchirid\.[\w.]*\b{re.escape(name)}"', page):
                missing.append(f"torchirid.{pkg}.{name}")
    assert not missing, missing
