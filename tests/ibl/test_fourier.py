import math

import pytest
import torch

from torchirid import thin_film_reflectance
from torchirid.color import spectrum_to_xyz
from torchirid.ibl import (
    fourier_sensitivity,
    thin_film_xyz_fourier,
)
from torchirid.ibl.fourier import thin_film_fourier_terms
from torchirid.ibl.sensitivity import fourier_sensitivity_exact, prefiltered_fourier_sensitivity

F64 = torch.float64
OBSERVERS = ("CIE 1931 2", "Stiles & Burch 1959 10")


CASES = [  # cos θ, film index, thickness, base
    (1.0, 1.33, 300.0, 1.0),
    (0.5, 1.5, 500.0, complex(0.2, 3.0)),
    (0.2, 2.0, 150.0, 1.5),
    (0.05, 1.2, 800.0, complex(0.2, 3.0)),
]


@pytest.mark.parametrize("case", CASES)
def test_series_converges_to_spectral_integration(case):
    c, nf, d, ns = case
    wl = torch.arange(360.0, 830.001, 0.25, dtype=F64)
    c = torch.tensor(c, dtype=F64)
    ref = spectrum_to_xyz(thin_film_reflectance(wl, c, nf, d, ns), wl)
    res = [(thin_film_xyz_fourier(c, nf, d, ns, terms=M, sensitivity="exact") - ref).abs().max().item()
           for M in (1, 2, 4, 40)]
    assert res[3] < 5e-7, res  # the reference's own 0.25 nm trapezoid error
    assert res[0] >= res[1] >= res[2] >= res[3] or res[2] < 1e-5, res
    lut = thin_film_xyz_fourier(c, nf, d, ns, terms=40)
    assert (lut - ref).abs().max() < 1e-4


def test_terms_match_paper_for_dielectric_film():
    C0, a, K, D = thin_film_fourier_terms(torch.tensor([0.3, 1.0], dtype=F64), 1.5, 400.0, complex(0.2, 3.0))
    assert K.imag.abs().max() < 1e-15  # real r12: K = R* − √(T12 T21)
    assert C0.shape == (2, 2) and D.shape == (2,)
    cos2 = math.sqrt(1 - (1 - 0.3**2) / 1.5**2)
    assert abs(D[0].item() - 2 * 1.5 * 400 * cos2) < 1e-9
    assert (a.abs() < 1).all()


def test_broadcast_dtype_gradient_and_thin_limit():
    c = torch.linspace(0.0, 1.0, 5, dtype=F64)[:, None, None].requires_grad_()
    d = torch.tensor([0.0, 250.0, 900.0], dtype=F64)[None, :, None].requires_grad_()
    nf = torch.tensor([1.3, 1.9], dtype=F64).requires_grad_()
    xyz = thin_film_xyz_fourier(c, nf, d, complex(0.2, 3.0), terms=3)
    assert xyz.shape == (5, 3, 2, 3) and xyz.dtype == F64
    xyz.sum().backward()
    assert all(torch.isfinite(t.grad).all() for t in (c, d, nf))
    # d = 0: the bare outer/base Fresnel colour, for any M when summed to convergence
    from torchirid.optics.fresnel import fresnel_reflectance
    c0 = torch.tensor([0.2, 0.8], dtype=F64)
    bare = fresnel_reflectance(c0, 1.0, 1.5)[:, None] * fourier_sensitivity_exact(torch.tensor(0.0, dtype=F64)).real
    assert torch.allclose(thin_film_xyz_fourier(c0, 1.8, 0.0, 1.5, terms=60), bare, atol=1e-9)
    x32 = thin_film_xyz_fourier(torch.rand(7), 1.5, 500.0, 1.5)
    assert x32.dtype == torch.float32 and torch.isfinite(x32).all()


def test_infinitely_thick_film_is_the_incoherent_limit():
    """thickness = ∞: Ŝ(±∞) = 0, so the colour is C0 · white, the incoherent sum of the two interfaces."""
    assert torch.equal(fourier_sensitivity_exact(torch.tensor([math.inf, -math.inf], dtype=F64)),
                       torch.zeros(2, 3, dtype=torch.complex128))
    mu = torch.tensor([math.inf, 800.0], dtype=F64)
    pre = prefiltered_fourier_sensitivity(mu, 50.0**2)
    assert torch.equal(pre[0], torch.zeros(3, dtype=torch.complex128))
    assert torch.allclose(pre[1], prefiltered_fourier_sensitivity(mu[1], 50.0**2), rtol=1e-12, atol=1e-15)
    c = torch.tensor([1.0, 0.6, 0.1], dtype=F64)
    n1, n2, n3 = 1.0, 1.33, 1.5
    s = n1 * torch.sqrt(1 - c * c)
    q1, q2, q3 = n1 * c, torch.sqrt(n2**2 - s * s), torch.sqrt(n3**2 - s * s)
    r12s, r23s = (q1 - q2) / (q1 + q2), (q2 - q3) / (q2 + q3)
    r12p = (n2**2 * q1 - n1**2 * q2) / (n2**2 * q1 + n1**2 * q2)
    r23p = (n3**2 * q2 - n2**2 * q3) / (n3**2 * q2 + n2**2 * q3)

    def incoherent(r12, r23):  # R12 + T12² R23 / (1 − R12 R23), lossless
        a, b = r12**2, r23**2
        return a + (1 - a) ** 2 * b / (1 - a * b)

    white = fourier_sensitivity_exact(torch.tensor(0.0, dtype=F64)).real
    ref = 0.5 * (incoherent(r12s, r23s) + incoherent(r12p, r23p))[:, None] * white
    for mode in ("exact", "lut"):
        xyz = thin_film_xyz_fourier(c, n2, math.inf, n3, terms=4, sensitivity=mode)
        assert torch.allclose(xyz, ref, rtol=1e-12, atol=1e-15), (mode, xyz, ref)


def test_bad_input():
    c = torch.tensor(0.5, dtype=F64)
    with pytest.raises(ValueError, match="terms"):
        thin_film_xyz_fourier(c, 1.5, 100.0, 1.5, terms=-1)
    with pytest.raises(ValueError, match="sensitivity"):
        thin_film_xyz_fourier(c, 1.5, 100.0, 1.5, sensitivity="gauss")
    with pytest.raises(ValueError, match="n_film"):
        thin_film_xyz_fourier(c, 0.9, 100.0, 1.5)
    with pytest.raises(ValueError, match="thickness"):
        thin_film_xyz_fourier(c, 1.5, -1.0, 1.5)
    with pytest.raises(ValueError, match="cos_theta"):
        thin_film_xyz_fourier(torch.tensor(1.5), 1.5, 1.0, 1.5)
    with pytest.raises(ValueError, match="observer"):
        fourier_sensitivity(torch.tensor(0.0), observer="nope")
    with pytest.raises(ValueError, match="polarization"):
        thin_film_xyz_fourier(c, 1.5, 100.0, 1.5, polarization="x")

