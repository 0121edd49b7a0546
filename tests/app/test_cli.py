"""The ``torchirid`` command: files written, shapes, parameters passed through, errors."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

import torchirid
from torchirid.app.cli import main

GRID = ["--angles", "5", "--wavelengths", "400", "700", "31"]


def f64(x):
    return torch.as_tensor(x, dtype=torch.float64)


def _load(path: Path):
    with np.load(path, allow_pickle=False) as z:
        return {k: z[k] for k in z.files}


def _run(tmp_path: Path, *extra: str, name: str = "spectrum"):
    rc = main(["spectrum", "--out", str(tmp_path), "--name", name, *GRID, *extra])
    assert rc == 0
    npz, png = tmp_path / f"{name}.npz", tmp_path / f"{name}.png"
    assert npz.is_file() and npz.stat().st_size > 0
    assert png.is_file() and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    return _load(npz)


def _check_arrays(data) -> dict:
    R = data["reflectance"]
    assert R.shape == (5, 31)
    assert np.isfinite(R).all()
    # R in [0, 1], up to rounding (a few ulps) in the physics
    assert (R >= 0).all() and (R <= 1 + 4 * np.finfo(R.dtype).eps).all()
    assert data["wavelength_nm"].shape == (31,)
    np.testing.assert_allclose(data["wavelength_nm"][[0, -1]], [400.0, 700.0])
    np.testing.assert_allclose(data["theta_deg"], [0.0, 22.5, 45.0, 67.5, 90.0])
    np.testing.assert_allclose(
        data["cos_theta"],
        np.cos(np.radians(data["theta_deg"])),
        rtol=4 * np.finfo(data["cos_theta"].dtype).eps,
        atol=1e-15,
    )
    assert (data["cos_theta"] >= 0).all()
    params = json.loads(str(data["params"]))
    assert params["torchirid_version"]
    return params


def test_bragg_default(tmp_path, capsys):
    rc = main(["spectrum", "--out", str(tmp_path), *GRID])
    assert rc == 0
    printed = capsys.readouterr().out.split()
    assert printed == [str(tmp_path / "spectrum.npz"), str(tmp_path / "spectrum.png")]
    data = _load(tmp_path / "spectrum.npz")
    params = _check_arrays(data)
    assert params["kind"] == "bragg"
    geometry = (params["n1"], params["n2"], params["d1_nm"], params["d2_nm"], params["cells"])
    assert geometry == (1.0, 1.5, 125.0, 375.0, 20)
    assert params["n_incident"] == params["n1"]  # --n-incident defaults to n1
    assert params["polarization"] == "unpolarized"
    # a 20-cell mirror has stop bands: somewhere in the visible it reflects almost everything
    assert data["reflectance"].max() > 0.99


def test_bragg_matches_library(tmp_path):
    data = _run(tmp_path, "--n2", "1.6", "--d1", "100", "--d2", "150", "--cells", "7", "--n-incident", "1.2")
    params = _check_arrays(data)
    assert params["n_incident"] == 1.2 and params["cells"] == 7
    expected = torchirid.bragg_reflectance(
        f64(data["wavelength_nm"]), f64(data["cos_theta"])[:, None],
        f64(1.0), f64(1.6), f64(100.0), f64(150.0), 7, n_incident=f64(1.2), polarization="unpolarized",
    )
    np.testing.assert_allclose(data["reflectance"], expected.numpy(), rtol=1e-12, atol=1e-14)


def test_thin_film(tmp_path):
    data = _run(tmp_path, "--kind", "thin-film", "--n-film", "1.33", "--thickness", "300", name="film")
    params = _check_arrays(data)
    assert params["kind"] == "thin-film"
    film = (params["n_film"], params["thickness_nm"], params["n_substrate"], params["n_incident"])
    assert film == (1.33, 300.0, 1.0, 1.0)
    expected = torchirid.thin_film_reflectance(
        f64(data["wavelength_nm"]), f64(data["cos_theta"])[:, None],
        f64(1.33), f64(300.0), f64(1.0), n_incident=f64(1.0), polarization="unpolarized",
    )
    np.testing.assert_allclose(data["reflectance"], expected.numpy(), rtol=1e-12, atol=1e-14)
    # free-standing film at normal incidence: the Airy formula in closed form
    lam = data["wavelength_nm"]
    r = (1 - 1.33) / (1 + 1.33)
    phase = 4 * np.pi * 1.33 * 300.0 / lam
    airy = 2 * r**2 * (1 - np.cos(phase)) / (1 + r**4 - 2 * r**2 * np.cos(phase))
    np.testing.assert_allclose(data["reflectance"][0], airy, rtol=1e-10, atol=1e-14)
    # grazing incidence reflects everything
    np.testing.assert_allclose(data["reflectance"][-1], 1.0, atol=1e-6)


def test_thin_film_complex_substrate(tmp_path):
    data = _run(tmp_path, "--kind", "thin-film", "--n-substrate", "0.2+3.5j")
    params = _check_arrays(data)
    assert params["n_substrate"] == [0.2, 3.5]
    # a metal-like substrate reflects more than the free-standing film does at normal incidence
    bare = _run(tmp_path, "--kind", "thin-film", name="bare")
    assert data["reflectance"][0].mean() > bare["reflectance"][0].mean()


def test_polarization_is_passed_through(tmp_path):
    s = _run(tmp_path, "--polarization", "s", name="s")["reflectance"]
    p = _run(tmp_path, "--polarization", "p", name="p")["reflectance"]
    u = _run(tmp_path, name="u")["reflectance"]
    np.testing.assert_allclose(u, 0.5 * (s + p), rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(s[0], p[0], rtol=1e-10, atol=1e-14)  # normal incidence: s = p
    assert np.abs(s[1:-1] - p[1:-1]).max() > 1e-3  # oblique: they differ


def test_float32(tmp_path):
    film = ["--kind", "thin-film", "--n-film", "1.33", "--thickness", "300"]
    data = _run(tmp_path, "--dtype", "float32", *film, name="f32")
    _check_arrays(data)
    assert data["reflectance"].dtype == np.float32
    ref = _run(tmp_path, *film, name="f64")["reflectance"]
    assert ref.dtype == np.float64
    assert np.abs(data["reflectance"] - ref).max() < 1e-4
    bragg = _run(tmp_path, "--dtype", "float32", name="bragg32")
    _check_arrays(bragg)  # finite and in [0, 1]
    assert bragg["reflectance"].dtype == np.float32


@pytest.mark.parametrize(
    "extra",
    [
        ["--kind", "thin-film", "--thickness", "-10"],
        ["--d1", "-1"],
        ["--cells", "0"],
        ["--n2", "1.5-0.1j"],  # negative extinction coefficient
        ["--wavelengths", "700", "400", "31"],
        ["--wavelengths", "400", "700", "0"],
        ["--angles", "0"],
        ["--polarization", "circular"],
        ["--n1", "glass"],
    ],
)
def test_bad_arguments_exit_2(tmp_path, capsys, extra):
    with pytest.raises(SystemExit) as exc:
        main(["spectrum", "--out", str(tmp_path), "--angles", "3", "--wavelengths", "400", "700", "5", *extra])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "error:" in err
    assert "Traceback" not in err
    assert not (tmp_path / "spectrum.npz").exists()


def test_negative_thickness_names_parameter(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["spectrum", "--kind", "thin-film", "--thickness", "-5", "--out", str(tmp_path)])
    assert exc.value.code == 2
    assert "thickness" in capsys.readouterr().err


def test_help(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--help"])
    assert exc.value.code == 0
    assert "spectrum" in capsys.readouterr().out
    with pytest.raises(SystemExit) as exc:
        main(["spectrum", "--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    for word in ("--wavelengths", "--angles", "nm", "degrees", "--n-incident", "--thickness"):
        assert word in out


def test_no_command_exits_2(capsys):
    with pytest.raises(SystemExit) as exc:
        main([])
    assert exc.value.code == 2


def test_python_dash_m(tmp_path):
    src = str(Path(torchirid.__file__).resolve().parents[1])
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([src, os.environ.get("PYTHONPATH", "")]), MPLBACKEND="Agg")
    proc = subprocess.run(
        [sys.executable, "-m", "torchirid", "spectrum", "--out", str(tmp_path), "--angles", "2",
         "--wavelengths", "500", "600", "3"],
        capture_output=True, text=True, env=env, timeout=300,
    )
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "spectrum.npz").is_file() and (tmp_path / "spectrum.png").is_file()
    assert str(tmp_path / "spectrum.png") in proc.stdout


# ------------------------------------------------------------------ torchirid gradients

TINY = ["--lambdas", "244", "500", "--ratios", "0.3", "0.7", "--angles", "8"]


def _gradients(tmp_path: Path, *extra: str, name: str = "atlas"):
    rc = main(["gradients", "--out", str(tmp_path), "--name", name, *TINY, *extra])
    assert rc == 0
    png, npz = tmp_path / f"{name}.png", tmp_path / f"{name}.npz"
    assert png.is_file() and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert npz.is_file() and npz.stat().st_size > 0
    return _load(npz)


def test_gradients_tiny_grid(tmp_path, capsys):
    data = _gradients(tmp_path)
    assert capsys.readouterr().out.split() == [str(tmp_path / "atlas.png"), str(tmp_path / "atlas.npz")]
    for key in ("srgb_reference", "srgb_piecewise", "srgb_paper_sub"):
        assert data[key].shape == (2, 2, 8, 3), key
    assert data["srgb_thin_film"].shape == (2, 8, 3)
    for key in ("srgb_reference", "srgb_piecewise", "srgb_paper_sub", "srgb_thin_film"):
        strip = data[key]
        assert np.isfinite(strip).all() and (strip >= 0).all() and (strip <= 1).all(), key
        # grazing incidence: R = 1 at every wavelength, so every strip ends white
        assert (strip[..., -1, :] > 0.99).all(), key
    np.testing.assert_allclose(data["theta_deg"], np.linspace(0, 90, 8))
    np.testing.assert_allclose(data["lambdas_nm"], [244.0, 500.0])
    np.testing.assert_allclose(data["ratios"], [0.3, 0.7])
    np.testing.assert_allclose(data["d1_nm"], [[73.2, 170.8], [150.0, 350.0]])
    np.testing.assert_allclose(data["d1_nm"] + data["d2_nm"], [[244.0] * 2, [500.0] * 2])
    np.testing.assert_allclose(data["curve_wavelength_nm"], [599.0, 556.0, 442.0])
    R = data["reflectance_bragg"]
    assert R.shape == (2, 2, data["curve_theta_deg"].size, 3)
    assert data["reflectance_thin_film"].shape == (2, data["curve_theta_deg"].size, 3)
    assert np.isfinite(R).all() and (R >= 0).all() and (R <= 1 + 1e-6).all()
    params = json.loads(str(data["params"]))
    assert (params["n1"], params["n2"], params["cells"]) == (1.0, 1.5, 20)
    assert params["lambdas_nm"] == [244.0, 500.0] and params["ratios"] == [0.3, 0.7]
    assert params["strips"]["paper_sub"] == {"label": "paper sub. s=3", "method": "piecewise",
                                             "subdivisions": 3, "weights": "paper"}
    assert params["torchirid_version"]


def test_gradients_strips_match_library(tmp_path):
    data = _gradients(tmp_path, "--cells", "7")
    cos = f64(data["cos_theta"])
    d1, d2 = f64(data["d1_nm"][1, 0]), f64(data["d2_nm"][1, 0])  # Λ = 500 nm, d1/Λ = 0.3
    expected = {
        "reference": torchirid.bragg_xyz(cos, 1.0, 1.5, d1, d2, 7, method="spectral"),
        "piecewise": torchirid.bragg_xyz(cos, 1.0, 1.5, d1, d2, 7, method="piecewise", subdivisions=8),
        "paper_sub": torchirid.bragg_xyz(cos, 1.0, 1.5, d1, d2, 7, method="piecewise", subdivisions=3,
                                         weights="paper"),
    }
    for key, xyz in expected.items():
        np.testing.assert_allclose(data[f"xyz_{key}"][1, 0], xyz.numpy(), rtol=1e-10, atol=1e-12)
        srgb = np.clip(torchirid.xyz_to_srgb(xyz).numpy(), 0, 1)
        np.testing.assert_allclose(data[f"srgb_{key}"][1, 0], srgb, rtol=1e-10, atol=1e-12)
    # the thin-film column: a 244 nm slab of n = 1.5 in air, on a dense spectrum
    wl = torch.linspace(380.0, 780.0, 2001, dtype=torch.float64)
    film = torchirid.spectrum_to_xyz(torchirid.thin_film_reflectance(wl, cos[:, None], 1.5, 244.0, 1.0), wl)
    np.testing.assert_allclose(data["xyz_thin_film"][0], film.numpy(), rtol=1e-10, atol=1e-12)
    # the curves at the CMF peaks
    R = torchirid.bragg_reflectance(f64([599.0, 556.0, 442.0]), f64(np.cos(np.radians(data["curve_theta_deg"][100]))),
                                    1.0, 1.5, d1, d2, 7)
    np.testing.assert_allclose(data["reflectance_bragg"][1, 0, 100], R.numpy(), rtol=1e-5, atol=1e-6)
    # the approximations are approximations: close to the reference, not equal to it
    assert 0 < np.abs(data["srgb_piecewise"] - data["srgb_reference"]).max() < 0.5


def test_gradients_help(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["gradients", "--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    for word in ("--lambdas", "--ratios", "--angles", "--cells", "--n2", "--dpi", "599", "Fig. 4"):
        assert word in out
    with pytest.raises(SystemExit):
        main(["--help"])
    assert "gradients" in capsys.readouterr().out


@pytest.mark.parametrize(
    "extra",
    [
        ["--angles", "0"],
        ["--angles", "1"],
        ["--ratios", "0"],
        ["--ratios", "0.5", "1.2"],
        ["--lambdas", "-5"],
        ["--lambdas", "nan"],
        ["--cells", "0"],
        ["--n2", "glass"],
        ["--n1", "2"],  # n1 > n2: total internal reflection, outside the piecewise model
        ["--dpi", "0"],
        ["--name", "a/b"],
    ],
)
def test_gradients_bad_arguments_exit_2(tmp_path, capsys, extra):
    with pytest.raises(SystemExit) as exc:
        main(["gradients", "--out", str(tmp_path), *TINY, *extra])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "error:" in err and "Traceback" not in err
    assert not any(tmp_path.iterdir())
