"""The envelope method: fringe-averaged Bragg spectrum on a uniform ω grid, integrated exactly."""

import math

import numpy as np
import pytest
import torch

import torchirid as ti
from tensors import F64, t64
from torchirid.color import delta_e_2000, xyz_to_lab
from torchirid.spectral import bragg_xyz_envelope
from torchirid.spectral.envelope import envelope_weights, fringe_averaged_reflectance


def test_fringe_average_equals_the_mean_of_exact_spectra_over_cells():
    """In the pass bands the model is Yeh's R averaged over its fringe phase NKΛ: the mean of the
    exact (tmm-validated) reflectance over N = 200 … 4199 cells converges to it (independent)."""
    lam = torch.linspace(400, 760, 37, dtype=F64)
    c = t64([1.0, 0.6, 0.2])[:, None]
    for pol in ("s", "p"):
        model = fringe_averaged_reflectance(lam, c, 1.0, 1.5, 130.0, 240.0, 20, polarization=pol)
        cells = torch.arange(200, 4200)[:, None, None]
        mean = ti.bragg_reflectance(lam, c, 1.0, 1.5, 130.0, 240.0, cells, polarization=pol).mean(0)
        # pass bands only (inside the gaps the model is the finite-N R, N = 20, not a mean)
        x = ti.optics.bragg_dispersion(lam, c, 1.0, 1.5, 130.0, 240.0, polarization=pol)
        passband = x.abs() < 0.98
        assert passband.sum() > 50
        assert (model - mean)[passband].abs().max() <= 1e-3  # measured 5e-4 (s), 1.7e-4 (p)


def test_inside_gaps_the_model_is_the_finite_n_reflectance():
    lam = t64([600.0])  # quarter-wave stack for 600 nm: the gap centre
    for N in (3, 10, 20):
        model = fringe_averaged_reflectance(lam, 1.0, 1.0, 1.5, 150.0, 100.0, N)
        exact = ti.bragg_reflectance(lam, 1.0, 1.0, 1.5, 150.0, 100.0, N)
        assert torch.allclose(model, exact, rtol=0, atol=1e-12)


def test_hat_weights_integrate_piecewise_linear_functions_exactly():
    """Y column sums to 1 (white), and f(ω) = ω (linear: exact for the hats) matches a fine
    independent quadrature with the colour pipeline's trapezoid weights in λ."""
    W = envelope_weights(48)
    assert abs(float(W[:, 1].sum()) - 1) <= 1e-9
    lam_fine = torch.linspace(380, 780, 400001, dtype=F64)
    wf = ti.color.xyz_weights(lam_fine)
    omega = torch.linspace(2 * math.pi / 780, 2 * math.pi / 380, 48, dtype=F64)
    exact = (2 * math.pi / lam_fine) @ wf
    assert torch.allclose(omega @ W, exact, rtol=0, atol=2e-6)
    with pytest.raises(ValueError, match="samples"):
        envelope_weights(1)


def test_converges_to_a_fine_integration_of_its_own_model():
    c = torch.cos(torch.deg2rad(t64([0.0, 30.0, 60.0, 85.0])))[:, None]
    d1 = t64([60.0, 250.0, 500.0])
    xyz = bragg_xyz_envelope(c, 1.0, 1.5, d1, 700.0 - d1, 20, samples=4096)
    lam = torch.linspace(380, 780, 200001, dtype=F64)
    R = fringe_averaged_reflectance(lam, c[..., None], 1.0, 1.5, d1[:, None], (700.0 - d1)[:, None], 20)
    fine = R @ ti.color.xyz_weights(lam)
    assert (xyz - fine).abs().max() <= 2e-4


@pytest.mark.filterwarnings(r"ignore:bragg_xyz\(method=.*fewer than:RuntimeWarning")  # paper grids, out-of-domain colours included
def test_accuracy_against_the_converged_spectral_colour():
    """Fourneau Fig. 4 setting (n2 = 1.5, N = 20) at Λ = 500 nm, 9 × 30 colours, K = 64:
    measured median 0.17, p95 0.9 ΔE2000 (sampled K = 128 in λ: 0.35 / 1.45)."""
    c = torch.cos(torch.deg2rad(torch.linspace(0, 87, 30, dtype=F64)))
    d1 = (torch.arange(1, 10, dtype=F64) * 50.0)[:, None]
    ref = xyz_to_lab(ti.bragg_xyz(c, 1.0, 1.5, d1, 500.0 - d1, 20))
    env = delta_e_2000(xyz_to_lab(ti.bragg_xyz(c, 1.0, 1.5, d1, 500.0 - d1, 20, method="envelope")), ref).numpy()
    smp = delta_e_2000(xyz_to_lab(ti.bragg_xyz(c, 1.0, 1.5, d1, 500.0 - d1, 20, method="sampled", samples=128)),
                       ref).numpy()
    assert np.median(env) <= 0.3 and np.percentile(env, 95) <= 1.5
    assert np.percentile(env, 95) < np.percentile(smp, 95)  # twice the samples, less accurate


def test_grazing_shapes_dtype_and_float32():
    c = t64([0.0, 0.5, 1.0])
    xyz = ti.bragg_xyz(c, 1.0, 1.5, 125.0, 375.0, 20, method="envelope")
    assert xyz.shape == (3, 3) and xyz.dtype == F64
    assert abs(float(xyz[0, 1]) - 1.0) <= 1e-9  # grazing: the perfect reflector
    N = torch.tensor([10, 40])[:, None]
    assert ti.bragg_xyz(c, 1.0, 1.5, 125.0, 375.0, N, method="envelope").shape == (2, 3, 3)
    x32 = ti.bragg_xyz(c.float(), 1.0, 1.5, 125.0, 375.0, 20, method="envelope")
    assert x32.dtype == torch.float32 and torch.isfinite(x32).all()
    assert (x32.double() - xyz).abs().max() <= 1e-5


def test_scope_errors():
    c = t64([0.5])
    with pytest.raises(ValueError, match="n_incident"):
        ti.bragg_xyz(c, 1.0, 1.5, 125.0, 375.0, 20, method="envelope", n_incident=1.33)
    with pytest.raises(ValueError, match="propagating"):
        ti.bragg_xyz(t64([0.1]), 1.6, 1.2, 125.0, 375.0, 20, method="envelope")
    with pytest.raises(ValueError, match="real"):
        ti.bragg_xyz(c, 1.0, torch.tensor(1.5 + 0.1j), 125.0, 375.0, 20, method="envelope")
    with pytest.raises(ValueError, match="samples"):
        ti.bragg_xyz(c, 1.0, 1.5, 125.0, 375.0, 20, method="envelope", samples=1)
    with pytest.raises(ValueError, match="cos_theta"):
        ti.bragg_xyz(t64([1.5]), 1.0, 1.5, 125.0, 375.0, 20, method="envelope")
    with pytest.raises(ValueError, match="observer"):
        ti.bragg_xyz(c, 1.0, 1.5, 125.0, 375.0, 20, method="envelope", observer="CIE 2031")
    # the public weights are a copy: changing them leaves the method's cached weights alone
    W = envelope_weights(64)
    before = ti.bragg_xyz(c, 1.0, 1.5, 125.0, 375.0, 20, method="envelope")
    W.zero_()
    assert torch.equal(ti.bragg_xyz(c, 1.0, 1.5, 125.0, 375.0, 20, method="envelope"), before)


@pytest.mark.filterwarnings(r"ignore:bragg_xyz\(method=.*fewer than:RuntimeWarning")  # paper grids, out-of-domain colours included
def test_gradcheck_and_finite_gradients_at_hard_cases():
    c = t64([0.3, 0.8]).requires_grad_()
    n2 = t64(1.6).requires_grad_()
    d1 = t64(130.0).requires_grad_()
    assert torch.autograd.gradcheck(lambda c, n2, d1: bragg_xyz_envelope(c, 1.0, n2, d1, 300.0, 20, samples=32),
                                    (c, n2, d1))
    # grazing, normal incidence, a closed p gap at Brewster's angle, nodes on gap edges
    brewster = math.cos(math.atan(1.5))
    hard = t64([0.0, 1e-9, brewster, 1.0]).requires_grad_()
    d = t64(150.0).requires_grad_()
    out = bragg_xyz_envelope(hard, 1.0, 1.5, d, 100.0, 20)
    (gc, gd) = torch.autograd.grad(out.sum(), (hard, d))
    assert torch.isfinite(gc).all() and torch.isfinite(gd)
