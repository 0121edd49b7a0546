"""``torchirid render-mitsuba``: a sphere of a torchirid material rendered by Mitsuba 3."""

import numpy as np
import pytest

from torchirid.app.cli import main

def _run(argv):
    try:
        return main(argv)
    except SystemExit as exc:
        return exc.code


mi = pytest.importorskip("mitsuba", reason="Mitsuba 3 is not installed (pip install 'torchirid[mitsuba]')")


def _llvm():
    from torchirid.mitsuba.scenes import find_libllvm

    find_libllvm()
    import drjit as dr

    return dr.has_backend(dr.JitBackend.LLVM)


def test_render_writes_exr_and_png_of_the_sphere(tmp_path, capsys):
    variant = "llvm_ad_spectral" if _llvm() else "scalar_spectral"
    rc = main(["render-mitsuba", "thin_film", "n_film=1.45", "thickness=310", "n_substrate=Au", "alpha=0.2",
               "--size", "16", "--spp", "4", "--variant", variant, "--out", str(tmp_path), "--quiet"])
    assert rc == 0
    out = capsys.readouterr().out
    assert "mitsuba_thin_film.exr" in out and "mitsuba_thin_film.png" in out
    image = np.array(mi.Bitmap(str(tmp_path / "mitsuba_thin_film.exr")))
    assert image.shape == (16, 16, 3) and np.isfinite(image).all()
    assert image[8, 8].sum() > 0  # the sphere is lit
    assert (tmp_path / "mitsuba_thin_film.png").stat().st_size > 100


def test_scalar_rgb_variant_renders_a_bragg_mirror(tmp_path):
    rc = main(["render-mitsuba", "bragg", "n1=1.5", "n2=2.3", "d1=95", "d2=60", "cells=10", "n_incident=1",
               "--size", "8", "--spp", "1", "--variant", "scalar_rgb", "--map", "indoor", "--out", str(tmp_path),
               "--name", "mirror", "--quiet"])
    assert rc == 0 and (tmp_path / "mirror.exr").is_file()


@pytest.mark.parametrize("argv,message", [
    (["thin_film", "n_film=1.33"], "thin_film: thickness is required"),
    (["thin_film", "n_film=1.33", "thickness=-5"], "thickness must be finite and >= 0"),
    (["bragg", "n1=1.5", "n2=1.9", "d1=90", "d2=70", "cells=2.5"], "cells must be an integer"),
    (["thin_film", "n_film=1.33", "thickness=300", "--map", "nowhere.exr"], "--map 'nowhere.exr'"),
    (["thin_film", "n_film=1.33", "thickness=300", "--variant", "cuda_nope"], "--variant 'cuda_nope'"),
])
def test_bad_arguments_are_one_line_and_exit_2(tmp_path, capsys, argv, message):
    rc = _run(["render-mitsuba", *argv, "--variant" if "--variant" not in argv else "--quiet",
               *(["scalar_rgb"] if "--variant" not in argv else []), "--out", str(tmp_path / "o")])
    assert rc == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
    assert not (tmp_path / "o").exists()
