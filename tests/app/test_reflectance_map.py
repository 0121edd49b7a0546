"""torchirid.app.figures.reflectance_maps: reflectance maps R(θ, λ) as data, figure, PNG and npz, called directly."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch

import torchirid
from torchirid.app import figures

GRID = dict(wavelengths=(400.0, 700.0, 7), angles=4)


def test_bragg_map_matches_library():
    m = figures.bragg_reflectance_map(1.0, 1.6, 100.0, 150.0, 7, n_incident=1.2, **GRID)
    assert m.reflectance.shape == (4, 7) and m.reflectance.dtype == np.float64
    np.testing.assert_allclose(m.theta_deg, [0.0, 30.0, 60.0, 90.0])
    np.testing.assert_allclose(m.wavelength_nm[[0, -1]], [400.0, 700.0])
    f64 = torch.float64
    expected = torchirid.bragg_reflectance(torch.as_tensor(m.wavelength_nm), torch.as_tensor(m.cos_theta)[:, None],
                                           1.0, 1.6, 100.0, 150.0, 7, n_incident=torch.tensor(1.2, dtype=f64))
    np.testing.assert_allclose(m.reflectance, expected.numpy(), rtol=1e-12, atol=1e-14)
    assert m.params["kind"] == "bragg" and m.params["n_incident"] == 1.2 and m.params["cells"] == 7
    assert "N=7" in m.title


def test_thin_film_map_float32_complex_substrate():
    m = figures.thin_film_reflectance_map(1.33, 300.0, 0.2 + 3.5j, dtype="float32", **GRID)
    assert m.reflectance.shape == (4, 7) and m.reflectance.dtype == np.float32
    assert m.cos_theta.dtype == np.float32
    assert np.isfinite(m.reflectance).all() and (m.reflectance >= 0).all() and (m.reflectance <= 1 + 1e-6).all()
    assert m.params["n_substrate"] == [0.2, 3.5] and m.params["dtype"] == "float32"
    json.dumps(m.params)  # JSON-ready


def test_save_png_and_npz(tmp_path):
    m = figures.thin_film_reflectance_map(1.5, 375.0, 1.0, **GRID)
    assert len(figures.plot_reflectance_map(m).axes) == 3  # map, its colour bar, spectra
    png = figures.save_reflectance_map_png(m, tmp_path / "r.png", dpi=30)
    npz = figures.save_reflectance_map_npz(m, tmp_path / "r.npz")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.npz", "r.png"]
    with np.load(npz, allow_pickle=False) as z:
        np.testing.assert_array_equal(z["reflectance"], m.reflectance)
        assert json.loads(str(z["params"])) == m.params


@pytest.mark.parametrize(
    "kwargs, name",
    [
        (dict(wavelengths=(700.0, 400.0, 7)), "wavelengths"),
        (dict(wavelengths=(400.0, 700.0, 0)), "wavelengths"),
        (dict(angles=0), "angles"),
        (dict(dtype="float16"), "dtype"),
        (dict(thickness=-5.0), "thickness"),
    ],
)
def test_bad_arguments_raise(kwargs, name):
    args = dict(n_film=1.5, thickness=300.0, n_substrate=1.0, **GRID) | kwargs
    with pytest.raises(ValueError, match=name):
        figures.thin_film_reflectance_map(**args)


def test_default_spectrum_figure_labels_whole_degrees_and_antialiases():
    """Issue 22.8: the default grid (was 90 angles: 30.3°, 59.7°) has every degree, the line spectra
    are labelled 0°, 30°, 60°, 80°, and the map is an antialiased image (pcolormesh aliased fringes)."""
    from matplotlib.image import AxesImage

    from torchirid.app.cli import build_parser

    args = build_parser().parse_args(["spectrum"])
    assert args.angles == 91
    rmap = figures.thin_film_reflectance_map(1.33, 3000.0, 1.5, wavelengths=(380.0, 780.0, 41), angles=args.angles)
    fig = figures.plot_reflectance_map(rmap)
    ax_map, _, ax_lines = fig.axes[0], fig.axes[1], [a for a in fig.axes if a.get_legend() is not None][0]
    labels = [t.get_text() for t in ax_lines.get_legend().get_texts()]
    assert labels == ["θ = 0°", "θ = 30°", "θ = 60°", "θ = 80°"]
    images = [a for a in ax_map.get_children() if isinstance(a, AxesImage)]
    assert images and images[0].get_interpolation() == "antialiased"
