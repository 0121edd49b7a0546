"""The Fourier-transformed sensitivity Ŝ (torchirid.ibl.sensitivity): exact, tabulated, prefiltered."""
import math

import numpy as np
import pytest
import torch

from torchirid.color import spectrum_to_xyz
from torchirid.ibl import (
    fourier_sensitivity_lut,
    prefiltered_sensitivity_lut,
    fourier_sensitivity,
    shipped_fourier_sensitivity_lut,
)
from torchirid.ibl.sensitivity import fourier_sensitivity_exact, prefiltered_fourier_sensitivity

F64 = torch.float64
OBSERVERS = ("CIE 1931 2", "Stiles & Burch 1959 10")


CASES = [  # cos θ, film index, thickness, base
    (1.0, 1.33, 300.0, 1.0),
    (0.5, 1.5, 500.0, complex(0.2, 3.0)),
    (0.2, 2.0, 150.0, 1.5),
    (0.05, 1.2, 800.0, complex(0.2, 3.0)),
]


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
    from torchirid.ibl.sensitivity import lookup_prefiltered_sensitivity

    assert (lookup_prefiltered_sensitivity(torch.tensor(mu, dtype=F64), sigma**2, lut=lut) - got).abs().max() < 1e-4
    with pytest.raises(ValueError, match="sigma2"):
        prefiltered_fourier_sensitivity(torch.tensor(0.0), -1.0)


def test_prefiltered_lut_accuracy_bound():
    """The default 2-D table (demodulated real/imag on w = 1 − exp(−2π²σ²/700²)) against the exact eq. 18.

    Measured 4.7e-4 on 30,000 points (docs/performance.md); the old σ-uniform magnitude/phase
    layout erred by 1.5e-2 at σ ≈ 12 nm. Here 4,000 random points, a quarter with σ < 30 nm.
    """
    from torchirid.ibl.sensitivity import lookup_prefiltered_sensitivity, shipped_prefiltered_sensitivity_lut

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

    from torchirid.ibl import sensitivity as fourier
    from torchirid.ibl.sensitivity import (
        PREFILTERED_SENSITIVITY_BUILDER,
        PREFILTERED_SHIPPED,
        prefiltered_sensitivity_path,
        shipped_prefiltered_sensitivity_lut,
    )
    from torchirid.lut import LUT

    path = prefiltered_sensitivity_path()
    assert path.is_file(), f"missing shipped table {path}: run luts/build_prefiltered_sensitivity.py"
    shipped = LUT.read(path, builder=PREFILTERED_SENSITIVITY_BUILDER)
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
    from torchirid.ibl import sensitivity as fourier

    small = prefiltered_sensitivity_lut(d_max=500.0, sigma_max=100.0, sigma_nodes=3)  # not the shipped grid
    small.write(tmp_path / "stale.npz")
    (tmp_path / "junk.npz").write_bytes(b"junk")
    monkeypatch.setattr(fourier, "prefiltered_sensitivity_lut", lambda o, i, **kw: small)  # (a fast "build")
    for name in ("stale", "junk"):
        monkeypatch.setattr(fourier, "prefiltered_sensitivity_path", lambda o, i, name=name: tmp_path / f"{name}.npz")
        fourier._prefiltered_cached.cache_clear()
        with pytest.warns(RuntimeWarning, match="ignoring the shipped table"):
            assert fourier.shipped_prefiltered_sensitivity_lut() is small
    fourier._prefiltered_cached.cache_clear()

