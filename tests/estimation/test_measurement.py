import math

import numpy as np
import pytest
import torch

import torchirid
from torchirid.estimation.measurement import (
    airy_terms,
    band_nodes,
    band_reflectance,
    band_reflectance_fast,
    band_terms,
    reflectance_from_terms,
)
from torchirid.estimation.dispersion import zns_index

F64 = torch.float64
tmm = pytest.importorskip("tmm")


@pytest.mark.parametrize("pol", ["s", "p"])
@pytest.mark.parametrize("nf,d,deg", [(1.37, 400.0, 10.0), (1.37, 600.0, 50.0), (2.37, 500.0, 30.0)])
def test_airy_closed_form_vs_tmm(pol, nf, d, deg):
    lam = torch.linspace(400, 720, 17, dtype=F64)
    c = math.cos(math.radians(deg))
    R = reflectance_from_terms(*airy_terms(lam, c, nf, 1.64, polarization=pol), d)
    ref = [tmm.coh_tmm(pol, [1.0, nf, 1.64], [np.inf, d, np.inf], math.radians(deg), float(l))["R"] for l in lam]
    assert np.allclose(R.numpy(), ref, atol=1e-13)


def test_unpolarized_is_mean():
    lam = torch.linspace(400, 720, 9, dtype=F64)
    t = lambda pol: reflectance_from_terms(*airy_terms(lam, 0.7, 1.37, 1.64, polarization=pol), 500.0)
    assert torch.allclose(t("unpolarized"), (t("s") + t("p")) / 2, atol=1e-15)


@pytest.mark.parametrize("passband", ["box", "gaussian"])
def test_band_average_vs_dense_integral(passband):
    # independent: a dense trapezoid of thin_film_reflectance against the passband weight
    w, lam_b, c, d = 4.0, 512.0, math.cos(math.radians(20)), 900.0
    x = torch.linspace(-3 * w, 3 * w, 20001, dtype=F64)
    if passband == "box":
        wt = ((x.abs() <= w / 2)).to(F64)
        x = torch.linspace(-w / 2, w / 2, 20001, dtype=F64)
        wt = torch.ones_like(x)
    else:
        sigma = w / (2 * math.sqrt(2 * math.log(2)))
        wt = torch.exp(-0.5 * (x / sigma) ** 2)
    R = torchirid.thin_film_reflectance(lam_b + x, c, 2.0, d, 1.64, polarization="s")
    ref = torch.trapezoid(R * wt, x) / torch.trapezoid(wt, x)
    got = band_reflectance(torch.tensor(lam_b, dtype=F64), c, 2.0, d, 1.64, passband=passband, nodes=12,
                           polarization="s")
    assert abs(float(got - ref)) < 1e-9
    point = torchirid.thin_film_reflectance(torch.tensor(lam_b, dtype=F64), c, 2.0, d, 1.64, polarization="s")
    assert abs(float(point - ref)) > 1e-4  # the band average matters at this thickness


def test_zero_bandwidth_is_point_sampling_and_callable_index():
    lam = torch.linspace(400, 720, 11, dtype=F64)
    a = band_reflectance(lam, 0.9, zns_index, 500.0, 1.64, bandwidth=0.0, polarization="s")
    b = torchirid.thin_film_reflectance(lam, 0.9, zns_index(lam), 500.0, 1.64, polarization="s")
    assert torch.allclose(a, b, atol=1e-15)


@pytest.mark.parametrize("nf,d,tol", [(1.37, 400.0, 2e-5), (1.37, 660.0, 3e-5), (zns_index, 550.0, 3e-4)])
def test_fast_band_model_vs_quadrature(nf, d, tol):
    lam = torch.arange(400.0, 721.0, 4.0, dtype=F64)
    for deg in (10.0, 50.0):
        c = math.cos(math.radians(deg))
        ref = band_reflectance(lam, c, nf, d, 1.64, nodes=8, polarization="s")
        fast = band_reflectance_fast(band_terms(lam, c, nf, 1.64, polarization="s"), d)
        point = band_reflectance(lam, c, nf, d, 1.64, bandwidth=0.0, polarization="s")
        assert (fast - ref).abs().max() < tol
        assert (fast - ref).abs().max() < 0.35 * (point - ref).abs().max()  # the O(σ²) term does its job


def test_fast_band_model_gradcheck():
    lam = torch.tensor([450.0, 600.0], dtype=F64)
    terms = band_terms(lam, 0.8, 1.9, 1.64, polarization="s")
    d = torch.tensor([333.0], dtype=F64, requires_grad=True)
    assert torch.autograd.gradcheck(lambda t: band_reflectance_fast(terms, t), (d,))


def test_band_nodes_and_errors():
    for pb in ("box", "gaussian"):
        off, w = band_nodes(4.0, 5, pb)
        assert abs(float(w.sum()) - 1) < 1e-14 and abs(float((w * off).sum())) < 1e-14
    with pytest.raises(ValueError, match="passband"):
        band_nodes(4.0, 3, "triangle")
    with pytest.raises(ValueError, match="nodes"):
        band_nodes(4.0, 0)
    with pytest.raises(ValueError, match="bandwidth"):
        band_nodes(-1.0)
    with pytest.raises(ValueError, match="polarization"):
        band_reflectance(torch.tensor(500.0), 1.0, 1.4, 100.0, 1.6, polarization="x")


def test_float32_and_broadcast():
    lam = torch.arange(400.0, 721.0, 4.0)
    R = band_reflectance(lam, torch.tensor([[0.9], [0.7]]), 1.37, torch.tensor([[300.0], [400.0]]), 1.64,
                         polarization="s")
    assert R.shape == (2, 81) and R.dtype == torch.float32 and bool(torch.isfinite(R).all())
    R64 = band_reflectance(lam.double(), torch.tensor([[0.9], [0.7]], dtype=F64), 1.37,
                           torch.tensor([[300.0], [400.0]], dtype=F64), 1.64, polarization="s")
    assert (R.double() - R64).abs().max() < 1e-5


from hypothesis import given, settings, strategies as st  # noqa: E402


@settings(max_examples=25, deadline=None)
@given(n=st.floats(1.2, 2.6), d=st.floats(20.0, 900.0), deg=st.floats(0.0, 60.0), lam=st.floats(420.0, 700.0))
def test_fast_band_model_property(n, d, deg, lam):
    c = math.cos(math.radians(deg))
    w = torch.tensor([lam], dtype=F64)
    ref = band_reflectance(w, c, n, d, 1.64, nodes=10, polarization="s")
    fast = band_reflectance_fast(band_terms(w, c, n, 1.64, polarization="s"), d)
    assert abs(float(fast - ref)) < 1e-4
