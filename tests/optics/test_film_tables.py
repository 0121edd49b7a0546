"""Tests of torchirid.optics.film_tables (Hirayama 2000 §5: tabulated k_r, k_t).

References: the ``tmm`` package at the table nodes (oracles.tmm_RT_grid with the indices from
oracles.material_nk), a bilinear interpolation written here in numpy from tmm corner values,
the closed-form quarter-wave reflectance, energy conservation (bilinear interpolation keeps
k_r + k_t = 1 for a lossless stack), second-order convergence for a smooth stack.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from oracles import HIRAYAMA_TABLE1, hirayama_stack, tmm_RT, tmm_RT_grid
from torchirid.lut import LUT
from torchirid.optics.film_stack import FilmStack, film_reflectance
from torchirid.presets import hirayama_stacks
from torchirid.optics.film_tables import (
    BUILDER,
    STACK_NAMES,
    interpolation_error,
    film_reflectance_lut,
    lookup_film_reflectance,
)

F64 = torch.float64


def t64(x):
    return torch.as_tensor(x, dtype=F64)


@pytest.fixture(scope="module")
def teapot_lut():
    return film_reflectance_lut(hirayama_stacks()["teapot"], angles=17, wavelengths=21,
                             wavelength_range=(400.0, 700.0))


def test_nodes_equal_tmm(teapot_lut):
    lut = teapot_lut
    c = lut.axes["cos_theta"].numpy()
    wl = lut.axes["wavelength"].numpy()
    assert c[0] == 0.0 and c[-1] == 1.0 and wl[0] == 400.0 and wl[-1] == 700.0
    ia, iw = np.array([1, 5, 9, 16]), np.array([0, 7, 13, 20])
    idx, d = hirayama_stack(HIRAYAMA_TABLE1[0], wl[iw][None, :])
    R, T = tmm_RT_grid(wl[iw][None, :], c[ia][:, None], idx, d, "unpolarized")
    v = lut.values.numpy()[np.ix_(ia, iw)]
    np.testing.assert_allclose(v[..., 0], R, atol=1e-10)
    assert (v[..., 1] == 0).all() and T.max() > 0  # k_t of the opaque Al base: nothing comes back out
    assert lut.values.shape == (17, 21, 2)


def test_lookup_is_bilinear_between_tmm_corners(teapot_lut):
    lut = teapot_lut
    c_ax, w_ax = lut.axes["cos_theta"].numpy(), lut.axes["wavelength"].numpy()
    g = np.random.default_rng(5)
    for _ in range(4):
        i, j = g.integers(1, 15), g.integers(0, 19)
        u, s = g.random(), g.random()
        c = c_ax[i] + u * (c_ax[i + 1] - c_ax[i])
        w = w_ax[j] + s * (w_ax[j + 1] - w_ax[j])
        corners = np.zeros((2, 2))
        for a in range(2):
            for b in range(2):
                idx, d = hirayama_stack(HIRAYAMA_TABLE1[0], w_ax[j + b])
                corners[a, b] = tmm_RT(w_ax[j + b], c_ax[i + a], [complex(x) for x in idx], d, "unpolarized")[0]
        ref = ((1 - u) * (1 - s) * corners[0, 0] + (1 - u) * s * corners[0, 1]
               + u * (1 - s) * corners[1, 0] + u * s * corners[1, 1])
        k_r, k_t = lookup_film_reflectance(lut, t64(w), t64(c))
        assert abs(float(k_r) - ref) < 1e-10 and float(k_t) == 0.0


def test_quarter_wave_closed_form_and_energy():
    s = FilmStack([(1.3785, 550.0 / 4 / 1.3785)], 1.52)  # a constant index: the closed form is exact
    lut = film_reflectance_lut(s, angles=9, wavelengths=9, wavelength_range=(400.0, 700.0))
    k_r, k_t = lookup_film_reflectance(lut, t64(550.0), 1.0)  # a node: exact
    assert abs(float(k_r) - ((1.52 - 1.3785**2) / (1.52 + 1.3785**2)) ** 2) < 1e-14
    g = torch.Generator().manual_seed(0)
    lam = 400 + 300 * torch.rand(500, generator=g, dtype=F64)
    c = torch.rand(500, generator=g, dtype=F64)
    k_r, k_t = lookup_film_reflectance(lut, lam, c)
    np.testing.assert_allclose((k_r + k_t).numpy(), 1.0, atol=1e-14)  # bilinear keeps the sum


def test_theta_axis():
    s = hirayama_stacks()["sphere"]
    lut = film_reflectance_lut(s, angles=31, wavelengths=31, wavelength_range=(400.0, 700.0), angle_axis="theta")
    th = lut.axes["theta"]
    assert lut.axis_names == ("theta", "wavelength") and lut.units["theta"] == "rad"
    assert float(th[-1]) == pytest.approx(math.pi / 2) and float(th[0]) == 0.0
    assert torch.allclose(lut.values[-1, :, 0], torch.ones(31, dtype=F64), atol=1e-12)  # exact grazing
    lam = lut.axes["wavelength"][[3, 17]]
    for i in (0, 7, 30):
        c = torch.cos(th[i]) if i < 30 else t64(0.0)
        k_r, _ = lookup_film_reflectance(lut, lam, c)
        k_ref, _ = film_reflectance(lam, c, s)
        np.testing.assert_allclose(k_r.numpy(), k_ref.numpy(), atol=1e-12)


def test_convergence_is_second_order_for_a_smooth_stack():
    s = FilmStack([("dielectric B", 150.0)], "SiO2")
    rows = interpolation_error(s, [(9, 11), (17, 21), (33, 41)], points=4000, repeats=1)
    errs = [r["max_dkr"] for r in rows]
    means = [r["mean_dkr"] for r in rows]
    assert errs[0] > errs[1] > errs[2] > 0
    # h² → ratio ≈ 4 once resolved (measured: max 2.9, 3.5; mean 3.9, 3.9)
    assert errs[1] / errs[2] > 3.2 and means[0] / means[1] > 3.6 and means[1] / means[2] > 3.6
    for r in rows:
        assert r["mean_dkr"] <= r["max_dkr"] and r["mean_dkt"] <= r["max_dkt"]
        assert r["build_s"] > 0 and r["lookup_ns"] > 0 and r["exact_ns"] > 0
        assert abs(r["max_dkr"] - r["max_dkt"]) < 1e-12  # lossless: Δk_t = −Δk_r


def test_grazing_resonances_are_the_hard_part():
    # Hirayama's teapot: near grazing the 1 µm films have sub-nm resonances, so a 1 nm table
    # is much worse there than at cos θ ≥ 0.2
    s = hirayama_stacks()["teapot"]
    all_ = interpolation_error(s, [(128, 301)], points=4000, repeats=1, wavelength_range=(400.0, 700.0))[0]
    away = interpolation_error(s, [(128, 301)], points=4000, repeats=1, wavelength_range=(400.0, 700.0),
                               cos_range=(0.2, 1.0))[0]
    assert away["max_dkr"] < 0.02 < all_["max_dkr"]


def test_save_load_round_trip(tmp_path, teapot_lut):
    p = teapot_lut.write(tmp_path / "teapot.npz")
    back = LUT.read(p, builder=BUILDER)
    assert back.hash == teapot_lut.hash
    assert back.parameters["stack"]["materials"] == ["air", "dielectric A", "Ag", "dielectric A", "Al"]
    assert back.parameters["stack"]["thicknesses_nm"] == [1000.0, 5.0, 1000.0]
    a = lookup_film_reflectance(back, t64([455.0, 611.0]), t64([0.3, 0.7]))
    b = lookup_film_reflectance(teapot_lut, t64([455.0, 611.0]), t64([0.3, 0.7]))
    assert torch.equal(a[0], b[0])


def test_float32_table_and_broadcasting():
    s = hirayama_stacks()["cylinder"]
    lut = film_reflectance_lut(s, angles=16, wavelengths=40, wavelength_range=(400.0, 700.0), dtype=torch.float32)
    assert lut.dtype == torch.float32
    k_r, k_t = lookup_film_reflectance(lut, torch.linspace(400, 700, 7)[None, :], torch.tensor([[0.1], [0.5], [1.0]]))
    assert k_r.shape == (3, 7) and k_r.dtype == torch.float32 and bool(((k_r >= 0) & (k_r <= 1)).all())
    lut64 = film_reflectance_lut(s, angles=16, wavelengths=40, wavelength_range=(400.0, 700.0))
    assert float((lut.values.double() - lut64.values).abs().max()) < 1e-6


def test_gradients():
    s = hirayama_stacks()["fig8_def_aluminum_silver"]
    for axis in ("cos_theta", "theta"):
        lut = film_reflectance_lut(s, angles=12, wavelengths=15, wavelength_range=(400.0, 700.0), angle_axis=axis)
        lam = t64([431.7, 612.9]).requires_grad_()
        c = t64([0.33, 0.77]).requires_grad_()
        torch.autograd.gradcheck(lambda w, cc: lookup_film_reflectance(lut, w, cc)[0], (lam, c))
        c1 = t64([1.0, 0.0]).requires_grad_()  # normal and grazing incidence: finite
        (g,) = torch.autograd.grad(lookup_film_reflectance(lut, t64(500.0), c1)[0].sum(), c1)
        assert bool(torch.isfinite(g).all())


def test_bad_inputs(teapot_lut):
    s = hirayama_stacks()["teapot"]
    with pytest.raises(ValueError, match="angle_axis must be one of"):
        film_reflectance_lut(s, angle_axis="phi")
    with pytest.raises(ValueError, match="angles must be an integer >= 2"):
        film_reflectance_lut(s, angles=1)
    with pytest.raises(ValueError, match="wavelengths must be an integer >= 2"):
        film_reflectance_lut(s, wavelengths=2.5)
    with pytest.raises(ValueError, match=r"not covered by the stack's materials.*\[250, 1450\]"):
        film_reflectance_lut(hirayama_stacks()["cylinder"], wavelength_range=(200.0, 700.0))
    with pytest.raises(ValueError, match=r"wavelength_range must be a pair \(low, high\) in nm with 1 <= low < high <= 1e\+06"):
        film_reflectance_lut(s, wavelength_range=(700.0, 400.0))
    with pytest.raises(ValueError, match="stack must be a FilmStack"):
        film_reflectance_lut("teapot")
    other = LUT(torch.zeros(2, 2), {"x": torch.tensor([0.0, 1.0])}, builder="other")
    with pytest.raises(ValueError, match="lut must be a table built by film_reflectance_lut"):
        lookup_film_reflectance(other, 500.0, 0.5)
    with pytest.raises(ValueError, match="cos_theta must lie in"):
        lookup_film_reflectance(teapot_lut, 500.0, -0.1)
    with pytest.raises(ValueError, match=r"table's range \[400, 700\] nm"):
        lookup_film_reflectance(teapot_lut, t64([500.0, 750.0]), 0.5)
    with pytest.raises(ValueError, match="cos_range"):
        interpolation_error(s, [(4, 4)], cos_range=(0.5, 0.2))
    k_r, _ = lookup_film_reflectance(teapot_lut, t64([math.nan, 500.0]), 0.5)  # NaN propagates
    assert torch.isnan(k_r[0]) and torch.isfinite(k_r[1])


def test_stack_names_match_hirayama_stacks():
    """The CLI's fixed ``--stack`` choices are exactly the presets of hirayama_stacks()."""
    assert STACK_NAMES == tuple(sorted(hirayama_stacks()))
