"""single_reflection_brdf(..., base_interreflection=True): the base ↔ layers series 1/(1 − ρd R_d)."""

from __future__ import annotations

import math

import pytest
import torch

from torchirid.layered import LayeredBragg, RoughBraggLayer
from torchirid.layered.montecarlo import montecarlo_brdf
from torchirid.layered.base_interreflection import base_return_fraction
from torchirid.layered.single_reflection import single_reflection_brdf

F64 = torch.float64
LAM = torch.tensor([420.0, 500.0, 560.0, 650.0, 720.0], dtype=F64)


def _dir(theta_deg, phi=0.0):
    t = math.radians(theta_deg)
    return [math.sin(t) * math.cos(phi), math.sin(t) * math.sin(phi), math.cos(t)]


WI = torch.tensor([_dir(0.0), _dir(30.0), _dir(60.0), _dir(45.0)], dtype=F64)
WO = torch.tensor([_dir(10.0, 3.14), _dir(50.0, 1.0), _dir(20.0, 0.5), _dir(75.0, 2.0)], dtype=F64)


def _layer(n1=1.0, d=250.0, alpha=0.1):
    return RoughBraggLayer(n1, 1.5, d, d, 10, alpha)


@pytest.mark.parametrize("mode", ["filter", "microfacet"])
def test_one_layer_over_base_equals_full_transport(mode):
    # one layer in air over a Lambertian base: the series is exact (every multiple-reflection
    # path is a chain of base visits separated by one reflection from below)
    s = LayeredBragg([_layer()], base_albedo=0.5)
    mc, err = montecarlo_brdf(LAM, WI, WO, s, samples=40000, seed=3, transmission=mode)
    f = single_reflection_brdf(LAM, WI, WO, s, base_interreflection=True)
    f34 = single_reflection_brdf(LAM, WI, WO, s)
    z = ((f - mc) / err).abs()
    assert float(z.max()) < 4.5, z
    # eq. 34 alone is far off (the test can fail): it misses the base's interreflections
    assert float(((f34 - mc) / err).abs().max()) > 20.0


def test_default_is_eq34_and_black_base_unchanged():
    s = LayeredBragg([_layer()], base_albedo=0.5)
    f34 = single_reflection_brdf(LAM, WI, WO, s)
    assert torch.equal(f34, single_reflection_brdf(LAM, WI, WO, s, base_interreflection=False))
    black = LayeredBragg([_layer(1.35)], base_albedo=0.0)
    assert torch.equal(single_reflection_brdf(LAM, WI, WO, black),
                       single_reflection_brdf(LAM, WI, WO, black, base_interreflection=True))


def test_base_term_scaled_by_series():
    # only the base term changes, by exactly 1/(1 − ρd R_d); the layer terms stay eq. 34's
    rho = 0.5
    s = LayeredBragg([_layer(1.35), _layer(1.35, 300.0, 0.1)], base_albedo=rho)
    black = LayeredBragg(s.layers, base_albedo=0.0)
    rd = base_return_fraction(LAM, s)
    f_layers = single_reflection_brdf(LAM, WI, WO, black)
    base34 = single_reflection_brdf(LAM, WI, WO, s) - f_layers
    base = single_reflection_brdf(LAM, WI, WO, s, base_interreflection=True) - f_layers
    torch.testing.assert_close(base, base34 / (1.0 - rho * rd), rtol=1e-12, atol=1e-15)
    lut = single_reflection_brdf(LAM, WI, WO, s, reflectance="lut", base_interreflection=True)
    torch.testing.assert_close(lut, single_reflection_brdf(LAM, WI, WO, s, base_interreflection=True), rtol=2e-3, atol=1e-6)


@pytest.mark.slow
def test_return_fraction_quadrature_and_bounds():
    for s in (LayeredBragg([_layer()], 0.5), LayeredBragg([_layer(1.0, 494.0, 0.05)], 0.5),
              LayeredBragg([_layer(1.35)], 0.5), LayeredBragg([_layer()] * 2, 0.5)):
        rd = base_return_fraction(LAM, s)
        fine = base_return_fraction(LAM, s, mu_nodes=192, radius_nodes=96, azimuth_nodes=48)
        assert float((rd - fine).abs().max()) < 1e-3
        assert bool(((rd > 0) & (rd < 1)).all())


def test_return_fraction_closed_forms():
    # a layer that reflects nothing (R → 0: N = 1 cell of index contrast ~0) returns nothing
    # without a coating; under a coating the return is the coating's internal reflection seen
    # through the layer twice, τ = G1 (T = 1): 2∫ G1(μ)² F_in(μ) μ dμ, with F_in from the energy
    # balance of the interface: 2∫F_in μ dμ = 1 − (1 − 2∫F_out μ dμ)/n² (independent check)
    n = 1.35
    weak = RoughBraggLayer(1.0, 1.0 + 1e-6, 100.0, 100.0, 1, 0.1)
    assert float(base_return_fraction(LAM, LayeredBragg([weak], 0.5)).abs().max()) < 1e-9
    weak_c = RoughBraggLayer(n, n + 1e-6, 100.0, 100.0, 1, 0.1)
    rd = base_return_fraction(LAM, LayeredBragg([weak_c], 0.5))
    from torchirid.optics.fresnel import fresnel_reflectance

    from torchirid.microfacet.ggx import smith_g1

    x = torch.linspace(0.0, 1.0, 400001, dtype=F64)
    mean_out = float(torch.trapezoid(2.0 * fresnel_reflectance(x, 1.0, n) * x, x))
    mean_in = float(torch.trapezoid(2.0 * fresnel_reflectance(x, n, 1.0) * x, x))
    assert abs(mean_in - (1.0 - (1.0 - mean_out) / n**2)) < 1e-6
    expect = float(torch.trapezoid(2.0 * smith_g1(x, 0.1) ** 2 * fresnel_reflectance(x, n, 1.0) * x, x))
    torch.testing.assert_close(rd, torch.full_like(rd, expect), rtol=0, atol=2e-4)


def test_bad_input():
    s = LayeredBragg([_layer()], 0.5)
    with pytest.raises(ValueError, match="base_interreflection"):
        single_reflection_brdf(LAM, WI, WO, s, base_interreflection=1)
    with pytest.raises(ValueError, match="mu_nodes"):
        base_return_fraction(LAM, s, mu_nodes=0)
    with pytest.raises(ValueError, match="wavelength"):
        base_return_fraction(torch.ones(2, 2, dtype=F64), s)
