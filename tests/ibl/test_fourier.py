import math

import numpy as np
import pytest
import torch

from torchirid import thin_film_reflectance
from torchirid.color import spectrum_to_xyz, white_point_xyz
from torchirid.ibl import (
    fourier_sensitivity_lut,
    prefiltered_sensitivity_lut,
    fourier_sensitivity,
    shipped_fourier_sensitivity_lut,
    thin_film_xyz_fourier,
)
from torchirid.ibl.fourier import (
    fourier_sensitivity_exact,
    prefiltered_fourier_sensitivity,
    thin_film_fourier_terms,
)

F64 = torch.float64
OBSERVERS = ("CIE 1931 2", "Stiles & Burch 1959 10")


@pytest.mark.parametrize("observer", OBSERVERS)
def test_sensitivity_zero_is_white(observer):
    s = fourier_sensitivity_exact(torch.tensor(0.0, dtype=F64), observer=observer)
    assert s.imag.abs().max() < 1e-15
    assert abs(s[1].real.item() - 1.0) < 1e-12
    wl = torch.arange(300.0, 900.0, 0.5, dtype=F64)  # ∫ 1 · S x̄ on a fine grid = the white
    ref = spectrum_to_xyz(torch.ones_like(wl), wl, observer=observer)
    # up to the reference's half-cell ramp at the observer's first node (1.4e-5 on Stiles & Burch's 5 nm grid)
    assert torch.allclose(s.real, ref, atol=2e-5)
    assert torch.allclose(fourier_sensitivity(torch.tensor(0.0, dtype=F64), observer=observer).real, s.real,
                          atol=1e-12)


def test_sensitivity_equals_spectral_integral():
    # Ŝ(D) = ∫ w(λ) e^{−2πiD/λ} dλ, checked against spectrum_to_xyz of cos and sin
    wl = torch.arange(360.0, 830.001, 0.1, dtype=F64)
    D = 3000.0
    re = spectrum_to_xyz(torch.cos(2 * math.pi * D / wl), wl)
    im = spectrum_to_xyz(-torch.sin(2 * math.pi * D / wl), wl)
    s = fourier_sensitivity_exact(torch.tensor(D, dtype=F64))
    assert torch.allclose(s, torch.complex(re, im), atol=2e-6)


@pytest.mark.parametrize("observer", OBSERVERS)
def test_lut_matches_exact(observer):
    D = torch.linspace(-19999.0, 19999.0, 777, dtype=F64) + 0.37
    err = (fourier_sensitivity(D, observer=observer) - fourier_sensitivity_exact(D, observer=observer)).abs()
    assert err.max() < 1e-5
    beyond = fourier_sensitivity(torch.tensor([20001.0, -3e4], dtype=F64), observer=observer)
    assert beyond.abs().max() == 0
    s32 = fourier_sensitivity(D.float(), observer=observer)
    assert s32.dtype == torch.complex64 and (s32 - fourier_sensitivity_exact(D, observer=observer)).abs().max() < 1e-4


def test_magnitude_phase_beats_real_imag():
    lut = fourier_sensitivity_lut(d_max=3000.0, step=5.0)
    D = lut.axes["D"]
    s = torch.polar(lut.values[..., 0], lut.values[..., 1])
    mid = D[:-1] + 2.5
    exact = fourier_sensitivity_exact(mid)
    ri = torch.complex(0.5 * (s.real[1:] + s.real[:-1]), 0.5 * (s.imag[1:] + s.imag[:-1]))
    mp = torch.polar(0.5 * (lut.values[1:, :, 0] + lut.values[:-1, :, 0]),
                     0.5 * (lut.values[1:, :, 1] + lut.values[:-1, :, 1]))
    assert (mp - exact).abs().max() * 20 < (ri - exact).abs().max()


def test_prefiltered_is_gaussian_average():
    mu, sigma = 2500.0, 120.0
    x, w = np.polynomial.hermite_e.hermegauss(80)  # E over N(0,1)
    D = torch.tensor(mu + sigma * x, dtype=F64)
    avg = (fourier_sensitivity_exact(D) * torch.tensor(w / w.sum(), dtype=F64)[:, None]).sum(0)
    got = prefiltered_fourier_sensitivity(torch.tensor(mu, dtype=F64), sigma**2)
    assert (got - avg).abs().max() < 1e-10
    zero = prefiltered_fourier_sensitivity(torch.tensor([mu], dtype=F64), 0.0)
    assert torch.allclose(zero, fourier_sensitivity_exact(torch.tensor([mu], dtype=F64)), atol=1e-14)
    lut = prefiltered_sensitivity_lut(d_max=3000.0, sigma_max=200.0, sigma_nodes=21)
    from torchirid.ibl.fourier import lookup_prefiltered_sensitivity

    assert (lookup_prefiltered_sensitivity(torch.tensor(mu, dtype=F64), sigma**2, lut=lut) - got).abs().max() < 1e-4
    with pytest.raises(ValueError, match="sigma2"):
        prefiltered_fourier_sensitivity(torch.tensor(0.0), -1.0)


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


def test_prefiltered_lut_accuracy_bound():
    """The default 2-D table (demodulated real/imag on w = 1 − exp(−2π²σ²/700²)) against the exact eq. 18.

    Measured 4.7e-4 on 30,000 points (docs/performance.md); the old σ-uniform magnitude/phase
    layout erred by 1.5e-2 at σ ≈ 12 nm. Here 4,000 random points, a quarter with σ < 30 nm.
    """
    from torchirid.ibl.fourier import lookup_prefiltered_sensitivity, shipped_prefiltered_sensitivity_lut

    lut = shipped_prefiltered_sensitivity_lut()
    assert max(lut.parameters["max_interp_error"]) < 6e-4
    g = torch.Generator().manual_seed(7)
    n = 4000
    mu = (torch.rand(n, generator=g, dtype=F64) * 2 - 1) * 20000.0  # both signs: μ < 0 is the conjugate
    sig = torch.rand(n, generator=g, dtype=F64) * 1000.0
    sig[: n // 4] *= 0.03
    sig[n // 4: n // 2] *= 0.4
    exact = prefiltered_fourier_sensitivity(mu, sig**2)
    got = lookup_prefiltered_sensitivity(mu, sig**2)
    err = (got - exact).abs().amax(-1)
    assert float(err.max()) < 6e-4
    assert float(err[: n // 4].max()) < 6e-4  # the small-σ corner that used to err by 1.5e-2
    # at σ = 0 only the μ interpolation (10 nm step) is left: measured 2.2e-5
    m0 = torch.linspace(0.0, 19990.0, 1001, dtype=F64) + 3.3
    assert float((lookup_prefiltered_sensitivity(m0, 0.0) - fourier_sensitivity_exact(m0)).abs().max()) < 1e-4
    # beyond the table: 0; σ above 1000 nm: clamped (|Ŝ| < 1e-20 there)
    far = lookup_prefiltered_sensitivity(torch.tensor([25000.0, 100.0], dtype=F64), torch.tensor([0.0, 2000.0**2], dtype=F64))
    assert float(far.abs().max()) < 1e-15
    # gradients are finite at σ² = 0 (the w axis is taken from σ², no square root)
    m = torch.tensor([500.0, 1500.0], dtype=F64, requires_grad=True)
    s2 = torch.zeros(2, dtype=F64, requires_grad=True)
    lookup_prefiltered_sensitivity(m, s2).abs().sum().backward()
    assert bool(torch.isfinite(m.grad).all()) and bool(torch.isfinite(s2.grad).all())
    with pytest.raises(ValueError, match="lut"):
        lookup_prefiltered_sensitivity(m, s2, lut=shipped_fourier_sensitivity_lut())
    with pytest.raises(ValueError, match="sigma_nodes"):
        prefiltered_sensitivity_lut(sigma_nodes=2)


def test_shipped_prefiltered_table_is_a_fresh_build_in_float32():
    """data/prefiltered_sensitivity/cie_1931_2_d65.npz (luts/build_prefiltered_sensitivity.py) is
    the default build with its values rounded to float32 (documented: within 1e-7), and
    shipped_prefiltered_sensitivity_lut reads it instead of building."""
    import warnings

    from torchirid.ibl import fourier
    from torchirid.ibl.fourier import (PREFILTERED_SENSITIVITY_BUILDER, PREFILTERED_SHIPPED,
                                       prefiltered_sensitivity_path, shipped_prefiltered_sensitivity_lut)
    from torchirid.lut import LUT

    path = prefiltered_sensitivity_path()
    assert path.is_file(), f"missing shipped table {path}: run luts/build_prefiltered_sensitivity.py"
    shipped = LUT.load(path, builder=PREFILTERED_SENSITIVITY_BUILDER)
    fresh = prefiltered_sensitivity_lut()
    assert shipped.dtype == torch.float32 and shipped.parameters == fresh.parameters
    assert {k: fresh.parameters[k] for k in PREFILTERED_SHIPPED} == PREFILTERED_SHIPPED
    for name in ("mu", "w"):
        assert torch.equal(shipped.axes[name], fresh.axes[name].float())
    # round to nearest: |float32(v) − v| ≤ 2⁻²⁴ |v|
    torch.testing.assert_close(shipped.values.double(), fresh.values, rtol=2.0**-24, atol=1e-30)
    assert float((shipped.values.double() - fresh.values).abs().max()) < 1e-7
    fourier._prefiltered_cached.cache_clear()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the shipped file is used, without a warning
        lut = shipped_prefiltered_sensitivity_lut()
    assert lut.dtype == F64 and torch.equal(lut.values, shipped.values.double())


def test_stale_or_corrupt_shipped_prefiltered_table_falls_back_to_a_build(tmp_path, monkeypatch):
    from torchirid.ibl import fourier

    small = prefiltered_sensitivity_lut(d_max=500.0, sigma_max=100.0, sigma_nodes=3)  # not the shipped grid
    small.save(tmp_path / "stale.npz")
    (tmp_path / "junk.npz").write_bytes(b"junk")
    monkeypatch.setattr(fourier, "prefiltered_sensitivity_lut", lambda o, i, **kw: small)  # (a fast "build")
    for name in ("stale", "junk"):
        monkeypatch.setattr(fourier, "prefiltered_sensitivity_path", lambda o, i, name=name: tmp_path / f"{name}.npz")
        fourier._prefiltered_cached.cache_clear()
        with pytest.warns(RuntimeWarning, match="ignoring the shipped table"):
            assert fourier.shipped_prefiltered_sensitivity_lut() is small
    fourier._prefiltered_cached.cache_clear()
