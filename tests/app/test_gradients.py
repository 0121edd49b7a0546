"""torchirid.app.figures.gradients: the Fig. 4 atlas as data, figure, PNG and npz, called directly."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch

import torchirid
from torchirid.app import figures

LAMBDAS, RATIOS, ANGLES, CELLS = [244.0, 500.0], [0.3, 0.7], 6, 5
STRIPS = ("reference", "piecewise", "paper_sub")


class _RecordingBar:
    """A progress(done, total) callback that records what gradient_atlas reports."""

    def __init__(self):
        self.calls = []

    def __call__(self, done, total):
        self.calls.append((done, total))


@pytest.fixture(scope="module")
def bar():
    return _RecordingBar()


@pytest.fixture(scope="module")
def atlas(bar):
    return figures.gradient_atlas(LAMBDAS, RATIOS, cells=CELLS, angles=ANGLES, progress=bar)


def test_shapes_and_ranges(atlas):
    L, R, A, C = len(LAMBDAS), len(RATIOS), ANGLES, figures.gradients.CURVE_ANGLES
    for key in STRIPS:
        assert atlas.xyz[key].shape == atlas.srgb[key].shape == (L, R, A, 3), key
    assert atlas.xyz["thin_film"].shape == atlas.srgb["thin_film"].shape == (L, A, 3)
    for key, rgb in atlas.srgb.items():
        assert np.isfinite(rgb).all() and (rgb >= 0).all() and (rgb <= 1).all(), key
        assert (rgb[..., -1, :] > 0.99).all(), key  # grazing incidence: R = 1, white
    assert atlas.reflectance_bragg.shape == (L, R, C, 3)
    assert atlas.reflectance_thin_film.shape == (L, C, 3)
    for refl in (atlas.reflectance_bragg, atlas.reflectance_thin_film):
        assert np.isfinite(refl).all() and (refl >= 0).all() and (refl <= 1 + 1e-9).all()
    np.testing.assert_allclose(atlas.theta_deg, np.linspace(0.0, 90.0, A))
    np.testing.assert_allclose(atlas.cos_theta, np.cos(np.radians(atlas.theta_deg)), atol=1e-15)
    np.testing.assert_allclose(atlas.d1_nm, [[73.2, 170.8], [150.0, 350.0]])
    np.testing.assert_allclose(atlas.d1_nm + atlas.d2_nm, [[244.0] * 2, [500.0] * 2])
    np.testing.assert_array_equal(atlas.curve_wavelength_nm, [599.0, 556.0, 442.0])


@pytest.mark.filterwarnings(r"ignore:bragg_xyz\(method=.*fewer than:RuntimeWarning")  # the figure's grid
def test_strips_match_library(atlas):
    cos = torch.as_tensor(atlas.cos_theta)
    # Λ = 500 nm, d1/Λ = 0.3: the longest optical path of the grid, which sets the "spectral"
    # method's sample count for the whole batch, so a call on this mirror alone matches exactly
    d1, d2 = float(atlas.d1_nm[1, 0]), float(atlas.d2_nm[1, 0])
    for key, _, kwargs in figures.GRADIENT_METHODS:
        xyz = torchirid.bragg_xyz(cos, 1.0, 1.5, d1, d2, CELLS, **kwargs)
        np.testing.assert_allclose(atlas.xyz[key][1, 0], xyz.numpy(), rtol=1e-10, atol=1e-12)
    # the curves: the mirror's reflectance at the CMF peaks, at one curve angle
    cos_c = float(np.cos(np.radians(atlas.curve_theta_deg[300])))
    R = torchirid.bragg_reflectance(torch.tensor([599.0, 556.0, 442.0], dtype=torch.float64), cos_c,
                                    1.0, 1.5, d1, d2, CELLS)
    np.testing.assert_allclose(atlas.reflectance_bragg[1, 0, 300], R.numpy(), rtol=1e-12, atol=1e-14)


def test_params_and_progress(atlas, bar):
    params = json.loads(json.dumps(atlas.params))  # JSON-ready
    assert (params["n1"], params["n2"], params["cells"]) == (1.0, 1.5, CELLS)
    assert params["lambdas_nm"] == LAMBDAS and params["ratios"] == RATIOS and params["angle_count"] == ANGLES
    assert params["torchirid_version"] == torchirid.__version__
    n = len(figures.GRADIENT_ATLAS_STEPS)
    assert bar.calls == [(k, n) for k in range(1, n + 1)]  # progress(done, total), the last done == total


def test_plot(atlas):
    fig = figures.plot_gradient_atlas(atlas)
    rows, cols = len(LAMBDAS), len(RATIOS)
    # per row: the thin film's curves and strip, then per ratio its curves and three strips
    assert len(fig.axes) == rows * (2 + cols * (1 + len(STRIPS)))
    width, height = fig.get_size_inches()
    assert width > height > 0


def test_save_png_and_npz(atlas, tmp_path):
    png = figures.save_gradient_atlas_png(atlas, tmp_path / "atlas.png", dpi=40)
    npz = figures.save_gradient_atlas_npz(atlas, tmp_path / "atlas.npz")
    assert png == tmp_path / "atlas.png" and npz == tmp_path / "atlas.npz"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["atlas.npz", "atlas.png"]  # no temporary files left
    with np.load(npz, allow_pickle=False) as z:
        data = {k: z[k] for k in z.files}
    assert set(data) == set(atlas.arrays())
    for key in STRIPS + ("thin_film",):
        np.testing.assert_array_equal(data[f"srgb_{key}"], atlas.srgb[key])
        np.testing.assert_array_equal(data[f"xyz_{key}"], atlas.xyz[key])
    assert data["reflectance_bragg"].dtype == np.float32
    assert json.loads(str(data["params"])) == atlas.params


def test_save_into_missing_directory_raises(atlas, tmp_path):
    with pytest.raises(OSError):
        figures.save_gradient_atlas_npz(atlas, tmp_path / "missing" / "atlas.npz")
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize(
    "kwargs, name",
    [
        (dict(periods=[-5.0]), "periods"),
        (dict(periods=[]), "periods"),
        (dict(ratios=[0.0]), "ratios"),
        (dict(ratios=[0.5, 1.2]), "ratios"),
        (dict(n1=2.0), "n1"),
        (dict(cells=0), "cells"),
        (dict(angles=1), "angles"),
        (dict(polarization="circular"), "polarization"),
    ],
)
def test_bad_arguments_raise(kwargs, name):
    args = dict(periods=[300.0], ratios=[0.5], angles=3) | kwargs
    with pytest.raises(ValueError, match=name):
        figures.gradient_atlas(**args)
