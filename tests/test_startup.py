"""Start-up: ``import torchirid`` and the first colour (spectrum → XYZ → L*a*b* → ΔE2000) load
none of the heavy packages, and importing any subpackage loads none of them either.

colour-science imports ``colour.plotting`` (matplotlib) and scipy unconditionally; kornia is
~0.15 s. The library reads its CIE tables from ``data/cie_tables.npz`` and imports kornia only
for sRGB, so none of them is needed before a user asks for something that uses it. Each check
runs in a fresh interpreter. No timings here: the start-up time is measured by
``benchmarks/startup.py`` (docs/performance.md).
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

HEAVY = ("matplotlib", "scipy", "kornia", "colour", "pandas", "tqdm")
SUBPACKAGES = ("color", "optics", "microfacet", "materials", "lut", "layered", "spectral", "ibl",
               "estimation", "fitting", "realtime", "export")

FIRST_COLOUR = """
    import torch
    import torchirid
    from torchirid.color import delta_e_2000, spectrum_to_xyz, xyz_to_lab
    wavelength = torch.linspace(380.0, 780.0, 81, dtype=torch.float64)
    r1 = 0.5 + 0.4 * torch.sin(wavelength / 40.0)
    r2 = 0.5 + 0.4 * torch.cos(wavelength / 40.0)
    de = delta_e_2000(xyz_to_lab(spectrum_to_xyz(r1, wavelength)), xyz_to_lab(spectrum_to_xyz(r2, wavelength)))
"""


def _run(code: str) -> dict:
    """Run ``code`` in a fresh interpreter; it prints one JSON line last, returned here."""
    env = dict(os.environ, OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
    proc = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True,
                          env=env, timeout=300)
    assert proc.returncode == 0, f"subprocess failed:\n{proc.stdout}\n{proc.stderr}"
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_first_colour_imports_no_heavy_package():
    out = _run(f"""
        import json, sys
        import torch
        by_torch = [m for m in {HEAVY!r} if m in sys.modules]  # torch itself imports tqdm
        {textwrap.indent(textwrap.dedent(FIRST_COLOUR), "        ").strip()}
        print(json.dumps({{"de": de.item(), "by_torch": by_torch,
                          "after": [m for m in {HEAVY!r} if m in sys.modules]}}))
    """)
    assert 0.0 < out["de"] < 100.0
    assert set(out["after"]) <= set(out["by_torch"]), f"imported by the first colour: {out['after']}"
    assert "matplotlib" not in out["after"]


def test_colour_tables_need_no_colour_science():
    """With colour-science, scipy, matplotlib and kornia blocked (import raises ImportError, as if
    not installed), every registered observer and illuminant and the first colour still work:
    the tables come from the shipped file."""
    out = _run(f"""
        import json, sys
        for name in ("colour", "scipy", "matplotlib", "kornia", "pandas"):
            sys.modules[name] = None
        {textwrap.indent(textwrap.dedent(FIRST_COLOUR), "        ").strip()}
        from torchirid.color import ILLUMINANTS, OBSERVERS, cmfs, illuminant_spd, white_point_xyz
        rows = {{o: cmfs(o)[0].numel() for o in OBSERVERS}}
        rows.update({{n: illuminant_spd(n)[0].numel() for n in ILLUMINANTS}})
        rows["S&B RGB"] = cmfs("Stiles & Burch 1959 10", space="RGB")[0].numel()
        white = white_point_xyz("D65").tolist()
        print(json.dumps({{"de": de.item(), "rows": rows, "white": white}}))
    """)
    assert 0.0 < out["de"] < 100.0
    assert out["rows"]["CIE 1931 2"] == 471 and out["rows"]["D65"] == 97 and out["rows"]["S&B RGB"] == 89
    assert [round(v, 5) for v in out["white"]] == [0.95047, 1.0, 1.08883]


def test_subpackage_imports_load_no_heavy_package():
    """Importing every subpackage of the library loads none of matplotlib, scipy, kornia, colour,
    pandas (nor tqdm beyond what torch imports)."""
    out = _run(f"""
        import importlib, json, sys
        import torch
        by_torch = [m for m in {HEAVY!r} if m in sys.modules]
        for s in {SUBPACKAGES!r}:
            importlib.import_module("torchirid." + s)
        print(json.dumps({{"by_torch": by_torch, "after": [m for m in {HEAVY!r} if m in sys.modules]}}))
    """)
    assert set(out["after"]) <= set(out["by_torch"]), f"imported by a subpackage: {out['after']}"


def test_application_packages_are_an_extra():
    """matplotlib and tqdm are the application's (`app` extra), not the library's requirements;
    the `dev` extra (what `bash run.sh` and `bash run.sh test` install) holds all of `app`."""
    tomllib = pytest.importorskip("tomllib")  # Python >= 3.11
    project = tomllib.loads((Path(__file__).resolve().parents[1] / "pyproject.toml").read_text("utf-8"))["project"]

    def names(reqs):
        return {re.split(r"[\s<>=!~\[;]", r, maxsplit=1)[0].lower() for r in reqs}

    extras = project["optional-dependencies"]
    assert not names(project["dependencies"]) & {"matplotlib", "tqdm"}
    assert names(extras["app"]) == {"matplotlib", "tqdm"}
    assert set(extras["app"]) <= set(extras["dev"])
