"""Every script in ``training/`` and ``luts/`` runs end to end at a tiny size into a temporary folder
(issue 22.2: ``fit_angular_correction.py`` once died with a NameError after rewriting the shipped
JSON). Each run must exit 0, write what it says, and leave the shipped data and figures untouched.

A new script needs an entry in ``TINY`` (the test fails for a script without one)."""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPTS = sorted(p.relative_to(ROOT).as_posix() for d in ("training", "luts") for p in (ROOT / d).glob("*.py"))

#: script → (arguments at a tiny size, with {tmp} for the output folder; files it must write there)
TINY = {
    "luts/build_bragg_color_errors.py": (["--grids", "fig4", "--periods", "244", "--angles", "3", "--batch-angles", "2",
                                          "--rounds", "1", "--max-wait", "0", "--out", "{tmp}/errors.json"],
                                         ["errors.json"]),
    "luts/build_cie_tables.py": (["--out", "{tmp}/cie_tables.npz"], ["cie_tables.npz"]),
    "luts/build_cumulative_cmf.py": (["--observers", "CIE 1931 2", "--illuminants", "E", "--nodes", "64",
                                      "--out", "{tmp}"], ["cie_1931_2_e_380_780nm.npz"]),
    "luts/build_dfg.py": (["--resolution", "4", "--samples", "16", "--out", "{tmp}/dfg.npz"], ["dfg.npz"]),
    "luts/build_explorer_sky.py": (["--out", "{tmp}/sky.npz"], ["sky.npz"]),
    "luts/build_fourier_sensitivity.py": (["--observers", "CIE 1931 2", "--d-max", "200", "--out", "{tmp}"],
                                          ["cie_1931_2_d65.npz"]),
    "luts/build_prefiltered_sensitivity.py": (["--d-max", "200", "--out", "{tmp}"], ["cie_1931_2_d65.npz"]),
    "luts/build_shader_textures.py": (["--only", "thin_film_soap", "--samples", "200", "--validation", "200",
                                       "--iterations", "2", "--out", "{tmp}"], ["thin_film_soap.npz"]),
    "luts/build_light_mixture.py": (["--masking", "separable", "--theta-nodes", "4", "--alpha-nodes", "4",
                                     "--out", "{tmp}/mix.npz"], ["mix.npz"]),
    "training/fit_angular_correction.py": (["--cells", "10", "--samples", "8", "--angles", "7", "--n2-count", "3",
                                            "--extra-pairs", "1.33:2.0", "--eval-pairs", "2.0:1.5",
                                            "--invariance-cells", "10,20", "--json", "{tmp}/w.json",
                                            "--figure", "{tmp}/w.png", "--quiet"], ["w.json", "w.png"]),
    "training/match_scatterogram.py": (["--presets", "red", "--incidences", "0", "--resolution", "8",
                                        "--wavelengths", "9", "--starts", "1", "--short-iter", "2", "--max-iter", "3",
                                        "--notes", "{tmp}/notes.md"], ["notes.md"]),
}


def _snapshot() -> dict[str, str]:
    """SHA-256 of every shipped data file and committed figure."""
    out = {}
    for folder in (ROOT / "src" / "torchirid" / "data", ROOT / "docs" / "figures"):
        for p in sorted(folder.rglob("*")):
            if p.is_file():
                out[str(p.relative_to(ROOT))] = hashlib.sha256(p.read_bytes()).hexdigest()
    return out


def test_every_shipped_data_file_has_a_builder_script():
    """Every file in src/torchirid/data/ is written by a script in luts/ or training/: one of them
    names the file, or its folder (``data/<folder>/``)."""
    texts = {s: (ROOT / s).read_text() for s in SCRIPTS}
    data = ROOT / "src" / "torchirid" / "data"
    orphans = []
    for path in sorted(p for p in data.rglob("*") if p.is_file()):
        rel = path.relative_to(data)
        names = [f"data/{rel.as_posix()}", path.name] + ([f"data/{rel.parts[0]}"] if len(rel.parts) > 1 else [])
        if not any(name in text for text in texts.values() for name in names):
            orphans.append(rel.as_posix())
    assert not orphans, f"shipped data without a builder script in luts/ or training/: {orphans}"


def test_every_shipped_table_loader_has_its_build_script():
    """The naming rule of docs/conventions.md: ``shipped_<quantity>_lut()`` loads the copy that
    ``luts/build_<quantity>.py`` writes."""
    import importlib

    loaders = set()
    for package in ["torchirid"] + [f"torchirid.{name}" for name in ("optics", "layered", "spectral", "color", "ibl",
                                                                      "microfacet", "realtime", "fitting")]:
        module = importlib.import_module(package)
        loaders |= {name for name in module.__all__ if name.startswith("shipped_") and name.endswith("_lut")}
    assert loaders
    missing = [name for name in sorted(loaders)
               if not (ROOT / "luts" / f"build_{name[len('shipped_'):-len('_lut')]}.py").is_file()]
    assert not missing, f"no luts/build_<quantity>.py for {missing}"


def test_every_script_has_a_tiny_run():
    assert SCRIPTS, "no scripts found"
    missing = [s for s in SCRIPTS if s not in TINY]
    assert not missing, f"add a tiny-size run to TINY for {missing}"


@pytest.mark.slow
@pytest.mark.parametrize("script", SCRIPTS)
def test_script_runs_at_a_tiny_size(script, tmp_path):
    if script not in TINY:
        pytest.fail(f"no tiny-size run for {script}")
    args, outputs = TINY[script]
    before = _snapshot()
    # keep the caller's PYTHONPATH after src/ (packages installed with --target, as on the GPU machine)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")]),
               OMP_NUM_THREADS="1", MPLBACKEND="Agg")
    proc = subprocess.run([sys.executable, str(ROOT / script), *(a.format(tmp=tmp_path) for a in args)],
                          cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, f"{script} failed:\n{proc.stdout[-2000:]}\n{proc.stderr[-4000:]}"
    for name in outputs:
        assert (tmp_path / name).is_file() and (tmp_path / name).stat().st_size > 0, (script, name)
    assert not [p for p in tmp_path.rglob("*.tmp")], "a temporary file was left behind"
    assert _snapshot() == before, f"{script} changed shipped data or figures"
