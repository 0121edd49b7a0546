"""Tests of torchirid.ibl.methods: ``thin_film_xyz(method=)`` and its registry.

The registry's keys are the function suffixes; each method returns what its function returns for
the same film (options passed through); the smooth default agrees with the colour of the exact
Airy spectrum integrated against the CMFs (an independent path: optics.thin_film_reflectance,
color.spectrum_to_xyz), and the fast rough method with the quadrature reference.
"""

from __future__ import annotations

import pytest
import torch

from torchirid.color import delta_e_2000, spectrum_to_xyz, xyz_to_lab
from torchirid.ibl import THIN_FILM_XYZ_METHODS, thin_film_xyz
from torchirid.optics import thin_film_reflectance

F64 = torch.float64
COS = torch.tensor([1.0, 0.7, 0.3], dtype=F64)


def test_the_registry_keys_are_the_function_suffixes():
    assert set(THIN_FILM_XYZ_METHODS) == {"fourier", "uniform", "fitted"}
    for method, fn in THIN_FILM_XYZ_METHODS.items():
        assert fn.__name__ == f"thin_film_xyz_{method}"


@pytest.mark.parametrize("method, options", [
    ("fourier", {}), ("fourier", dict(sensitivity="exact", polarization="s", n_incident=1.2)),
    ("uniform", dict(bins=256, nodes=16)), ("fitted", {}), ("fitted", dict(terms=3, illuminant="E")),
])
def test_each_method_is_its_function(method, options):
    fn = THIN_FILM_XYZ_METHODS[method]
    rough = method != "fourier"
    film = (1.38, torch.tensor([250.0, 400.0, 610.0], dtype=F64), 1.52)
    got = thin_film_xyz(COS, *film, alpha=0.15 if rough else None, method=method, **options)
    want = fn(COS, 0.15, *film, **options) if rough else fn(COS, *film, **options)
    assert got.shape == (3, 3)
    torch.testing.assert_close(got, want, rtol=0, atol=0)


@pytest.mark.parametrize("thickness", [150.0, 300.0, 600.0])
def test_the_smooth_default_is_the_colour_of_the_airy_spectrum(thickness):
    lam = torch.linspace(360.0, 830.0, 4701, dtype=F64)
    ref = spectrum_to_xyz(thin_film_reflectance(lam, COS[:, None], 1.33, thickness, 1.0), lam)
    got = thin_film_xyz(COS, 1.33, thickness, 1.0)  # method="fourier"
    torch.testing.assert_close(got, ref, rtol=0, atol=1e-3)  # measured ≤ 4e-4 (Y ≈ 0.3–0.5)


def test_the_fitted_rough_film_is_close_to_the_quadrature_reference():
    c = torch.tensor([1.0, 0.6], dtype=F64)
    ref = thin_film_xyz(c, 1.33, 300.0, 1.5, alpha=0.2, method="uniform")
    fit = thin_film_xyz(c, 1.33, 300.0, 1.5, alpha=0.2, method="fitted")
    assert float(delta_e_2000(xyz_to_lab(fit), xyz_to_lab(ref)).max()) < 1.0  # measured 0.01–0.12


@pytest.mark.parametrize("kwargs, match", [
    (dict(method="spectral"), "method must be one of"),
    (dict(method="uniform"), "alpha"),
    (dict(method="fitted"), "alpha"),
    (dict(alpha=0.2), "takes no alpha"),
])
def test_bad_method_or_alpha_raise(kwargs, match):
    with pytest.raises(ValueError, match=match):
        thin_film_xyz(COS, 1.33, 300.0, 1.0, **kwargs)


def test_sensitivity_has_one_default_and_the_tables_follow_the_quadrature():
    """Every thin-film colour function defaults to ``sensitivity="lut"`` (the shipped tables), within
    ΔE2000 0.01 of the quadrature (``"exact"``) on a sweep of films."""
    import inspect

    import torchirid.ibl as ibl
    from torchirid.color import delta_e_2000, xyz_to_lab

    defaults = {name: inspect.signature(getattr(ibl, name)).parameters["sensitivity"].default
                for name in ibl.__all__ if callable(getattr(ibl, name))
                and "sensitivity" in inspect.signature(getattr(ibl, name)).parameters}
    assert len(defaults) >= 5 and set(defaults.values()) == {"lut"}, defaults
    g = torch.Generator().manual_seed(3)
    c = 0.2 + 0.8 * torch.rand(64, generator=g, dtype=torch.float64)
    d = 50.0 + 1500.0 * torch.rand(64, generator=g, dtype=torch.float64)
    for method in ("fourier", "fitted"):
        kw = {} if method == "fourier" else {"alpha": 0.2}
        lut = ibl.thin_film_xyz(c, 1.35, d, 1.5, method=method, **kw)
        exact = ibl.thin_film_xyz(c, 1.35, d, 1.5, method=method, sensitivity="exact", **kw)
        assert float(delta_e_2000(xyz_to_lab(lut), xyz_to_lab(exact)).max()) < 0.01, method
