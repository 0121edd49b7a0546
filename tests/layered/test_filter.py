"""The transmission filter F_α (Fourneau et al. 2024 eq. 24–29, Appendix C): closed form and
quadrature (its table, torchirid.layered.filter_lut: test_filter_lut.py).

References are independent of the code under test: eq. 29 integrated in ψ by mpmath.quad
(30 digits, split at the lobe), Appendix C's ∫F dθd = G1 by a tanh-sinh rule
(tests/layered/_quad.py) split at the kink and around the peak.
"""

from __future__ import annotations

import math

import mpmath
import numpy as np
import pytest
import torch

from torchirid.layered.filter import filter_quadrature, transmission_filter
from torchirid.layered.filter_lut import transmission_filter_lut
from torchirid.layered.structure import RoughBraggLayer

from _quad import tanh_sinh

F64 = torch.float64
HALF_PI = math.pi / 2


def t64(x):
    return torch.as_tensor(x, dtype=F64)


def g1_ref(theta_i, alpha):
    """Smith G1 of eq. 19 (numpy, tan form)."""
    return 2.0 / (1.0 + np.sqrt(1.0 + alpha**2 * np.tan(theta_i) ** 2))


def filter_mpmath(theta_i, theta_d, alpha, dps=30):
    """Eq. 29 by adaptive quadrature in ψ (eq. 24 and 26 verbatim, D̃ of eq. 18)."""
    with mpmath.workdps(dps):
        ti, td, a = mpmath.mpf(theta_i), mpmath.mpf(theta_d), mpmath.mpf(alpha)
        ci, si, cd, sd = mpmath.cos(ti), mpmath.sin(ti), mpmath.cos(td), mpmath.sin(td)
        g1 = 2 / (1 + mpmath.sqrt(1 + a**2 * (si / ci) ** 2))
        if ti + td >= mpmath.pi / 2 and si * sd > 0:
            psi_max = mpmath.acos(-1 / (mpmath.tan(ti) * mpmath.tan(td)))  # eq. 26
        else:
            psi_max = mpmath.pi

        def d_tilde(psi):
            cos_m = ci * cd + si * sd * mpmath.cos(psi)  # eq. 24
            tan2 = (1 - cos_m**2) / cos_m**2 if cos_m != 0 else mpmath.inf
            if tan2 == mpmath.inf:
                return a**2 / mpmath.pi
            return a**2 / (mpmath.pi * cos_m**4 * (a**2 + tan2) ** 2)  # eq. 18 without χ+

        width = a / max(si * sd, mpmath.mpf(10) ** -20)  # lobe width in ψ
        pts = sorted({mpmath.mpf(0), psi_max} | {p for p in (width / 8, width, 8 * width) if p < psi_max})
        integral = mpmath.quad(d_tilde, pts)
        return float(2 * g1**2 * cd / ci * integral * sd)


# --------------------------------------------------------------------------------------
# closed form vs adaptive quadrature of eq. 29
# --------------------------------------------------------------------------------------
def _points(alpha, rng):
    pts = [(0.0, 0.3 * alpha), (0.0, HALF_PI), (0.3, 0.0), (1.2, HALF_PI), (0.4, 0.4)]
    for ti in (0.2, 0.7, math.pi / 4, 1.1, 1.5):  # on and next to the kink θd = π/2 − θi
        k = HALF_PI - ti
        pts += [(ti, k), (ti, k + 1e-12), (ti, k - 1e-12), (ti, k + 1e-6), (ti, k - 1e-6), (ti, k + 1e-3)]
    for _ in range(8):
        ti = rng.uniform(0, math.radians(89.5))
        pts += [(ti, rng.uniform(0, HALF_PI)), (ti, float(np.clip(ti + alpha * rng.normal(), 0, HALF_PI)))]
    return [(ti, min(max(td, 0.0), HALF_PI)) for ti, td in pts]


@pytest.mark.parametrize("alpha", [0.005, 0.025, 0.1, 0.4, 1.0, 1.7])
def test_closed_form_matches_adaptive_quadrature(alpha):
    rng = np.random.default_rng(int(alpha * 1000))
    pts = _points(alpha, rng)
    ti = t64([p[0] for p in pts])
    td = t64([p[1] for p in pts])
    got = transmission_filter(ti, td, alpha).numpy()
    ref = np.array([filter_mpmath(a, b, alpha) for a, b in pts])
    rel = np.abs(got - ref) / np.maximum(np.abs(ref), 1e-300)
    small = np.abs(ref) < 1e-14  # F = 0 at θd = 0, π/2 (to rounding)
    assert np.all(np.abs(got[small]) < 1e-14)
    assert rel[~small].max() < 1e-10  # bar: 1e-6; measured ~1e-15


def test_alpha_one_normal_incidence_is_sin_2theta():
    # α = 1: D̃ = 1/π, G1(0) = 1, ψ range π  →  F(0, θd) = sin 2θd exactly
    td = torch.linspace(0, HALF_PI, 101, dtype=F64)
    torch.testing.assert_close(transmission_filter(0.0, td, 1.0), torch.sin(2 * td), rtol=0, atol=1e-15)


def test_continuous_through_alpha_one():
    ti, td = t64([0.3, 1.0, 1.2]), t64([0.9, 0.7, 1.5])
    lo = transmission_filter(ti, td, 1.0 - 1e-9)
    hi = transmission_filter(ti, td, 1.0 + 1e-9)
    torch.testing.assert_close(lo, hi, rtol=1e-7, atol=0)


def test_kink_is_a_one_sided_square_root():
    # left of the kink F is smooth; right of it F drops like √δ (infinite right derivative)
    ti = t64(0.6)
    k = HALF_PI - 0.6
    f0 = transmission_filter(ti, t64(k), 0.4)
    right = [float(f0 - transmission_filter(ti, t64(k + d), 0.4)) for d in (1e-8, 4e-8)]
    slope = float((f0 - transmission_filter(ti, t64(k - 1e-8), 0.4)) / 1e-8)  # smooth part, from the left
    # f0 − F(k + δ) = −slope·δ + C√δ: the √ part doubles when δ is multiplied by 4
    ratio = (right[1] + slope * 4e-8) / (right[0] + slope * 1e-8)
    assert abs(ratio - 2.0) < 1e-3


# --------------------------------------------------------------------------------------
# Appendix C: ∫ F dθd = G1
# --------------------------------------------------------------------------------------
def _integrate_filter(theta_i, alpha, g=None):
    """∫₀^{π/2} g(θd) F dθd by tanh-sinh, split at the kink and around the peak (batched)."""
    theta_i = np.asarray(theta_i, dtype=np.float64)
    alpha = np.asarray(alpha, dtype=np.float64)
    c = np.sqrt(theta_i**2 + alpha**2 / 3)
    cuts = [np.zeros_like(c), np.full_like(c, HALF_PI), HALF_PI - theta_i]
    for k in (-32, -8, -2, -0.5, 0.5, 2, 8, 32):
        cuts.append(np.clip(c + k * alpha, 0, HALF_PI))
    edges = np.sort(np.stack(cuts), axis=0)  # (n_edges, B)
    ti_t, a_t = t64(theta_i), t64(alpha)

    def f(x):  # x (n_nodes, n_edges - 1, B)
        val = transmission_filter(ti_t, t64(x), a_t).numpy()
        return val if g is None else val * g(x)

    return tanh_sinh(f, edges)


def test_appendix_c_integral_is_g1():
    rng = np.random.default_rng(7)
    alpha = np.concatenate([[0.01, 0.01, 0.025, 0.1, 0.4, 1.0, 1.0, 0.4],
                            np.exp(rng.uniform(math.log(0.01), 0.0, 150))])
    theta_i = np.concatenate([np.radians([0, 89.5, 45, 0.05, 89.5, 0, 89.5, 45]),
                              rng.uniform(0, math.radians(89.5), 150)])
    value, err = _integrate_filter(theta_i, alpha)
    assert err.max() < 1e-10  # the reference itself converged
    rel = np.abs(value - g1_ref(theta_i, alpha)) / g1_ref(theta_i, alpha)
    assert rel.max() < 1e-6  # bar of the issue; measured ~1e-12


# --------------------------------------------------------------------------------------
# the quadrature rule
# --------------------------------------------------------------------------------------
ALPHAS = [0.01, 0.025, 0.1, 0.4, 1.0, 2.0]


def test_quadrature_integrates_one_to_g1():
    ti = torch.linspace(0, math.radians(89.5), 120, dtype=F64)
    c = torch.cos(ti)
    for alpha in ALPHAS:
        # near normal incidence the rule is that of θi = min(1e-3, α/300) (gradient safety)
        g1 = t64(g1_ref(np.maximum(ti.numpy(), min(1e-3, alpha / 300)), alpha))
        for nodes, tol in ((64, 2e-6), (128, 1e-10)):
            _, w = filter_quadrature(c, alpha, nodes=nodes, normalize=False)
            assert float(((w.sum(-1) - g1) / g1).abs().max()) < tol, (alpha, nodes)
        cos_d, w = filter_quadrature(c, alpha, nodes=16)
        torch.testing.assert_close(w.sum(-1), g1, rtol=1e-12, atol=0)  # normalised: exact
        assert bool((w >= 0).all()) and bool(((cos_d >= 0) & (cos_d <= 1)).all())


def test_quadrature_smooth_function():
    theta_i = np.radians([0.0, 3.0, 30.0, 45.0, 70.0, 89.0])
    for alpha in (0.01, 0.1, 0.5):

        def g(x):
            return np.cos(3 * x) + x**2

        ref, err = _integrate_filter(theta_i, np.full_like(theta_i, alpha), g)
        assert err.max() < 1e-11
        cos_d, w = filter_quadrature(t64(np.cos(theta_i)), alpha, nodes=64)
        got = (w * t64(g(torch.acos(cos_d).numpy()))).sum(-1).numpy()
        assert np.max(np.abs(got - ref) / np.abs(ref)) < 2e-6, alpha


# Nodes needed for a Bragg transmittance 1 − R(θd) (n = 1 | 1.5, d = 110 | 75 nm, λ 450/550/650 nm,
# θi ∈ {0, 30°, 60°}), max |error| of Σ w (1 − R) against tanh-sinh on 1200 sub-intervals:
#
#   cells  α      K=64     K=128    K=256    K=512    K=1024
#   10     0.025  1.5e-3   3.2e-4   9.4e-5   5.8e-6   5.2e-8
#   10     0.1    1.0e-2   1.6e-3   4.7e-4   6.1e-6   1.3e-7
#   10     0.4    6.4e-3   1.8e-3   3.1e-4   3.4e-6   5.1e-8
#   50     0.1    3.8e-2   1.4e-2   5.0e-3   1.6e-3   3.8e-4
#   200    0.1    6.0e-2   4.6e-2   2.2e-2   9.5e-3   8.9e-4
#   1000   0.1    7.9e-2   4.5e-2   4.4e-2   2.1e-2   8.4e-3
#
# (measured with θi ∈ {0, 20, 45, 70, 85}°, 7 wavelengths 400–700 nm; the fringes and band edges of
# R set the count: roughly K ≳ 10 × cells for 1e-3.) The test below checks the 10-cell row.
@pytest.mark.parametrize("alpha", [0.025, 0.1, 0.4])
def test_quadrature_bragg_transmittance(alpha):
    layer = RoughBraggLayer(1.0, 1.5, 110.0, 75.0, 10, alpha)
    lam = t64([450.0, 550.0, 650.0])
    theta_i = np.radians([0.0, 30.0, 60.0])

    def g(x):  # (n_nodes, n_edges - 1, B) → (..., W)
        cos = torch.cos(t64(x)).clamp(0, 1).unsqueeze(-1)
        return (1 - layer.reflectance(lam, cos)).numpy()

    edges_extra = np.linspace(0, HALF_PI, 401)

    def f(x):
        val = transmission_filter(t64(theta_i), t64(x), alpha).numpy()
        return val[..., None] * g(x)

    cuts = np.sort(np.concatenate([np.repeat(edges_extra[:, None], 3, 1), (HALF_PI - theta_i)[None]]), 0)
    ref, err = tanh_sinh(f, cuts, level=5)
    assert err.max() < 1e-9
    errors = {}
    for nodes in (64, 512):
        cos_d, w = filter_quadrature(t64(np.cos(theta_i)), alpha, nodes=nodes)
        t = 1 - layer.reflectance(lam, cos_d.unsqueeze(-1))  # (B, K, W)
        errors[nodes] = np.abs((w.unsqueeze(-1) * t).sum(-2).numpy() - ref).max()
    assert errors[512] < 2e-5 and errors[64] < 3e-2


def test_quadrature_shapes_and_edges():
    cos_d, w = filter_quadrature(t64([[1.0], [0.5], [0.0]]), t64([0.1, 0.3]), nodes=24)
    assert cos_d.shape == (3, 2, 24) and w.shape == (3, 2, 24)
    assert float(w[2].abs().max()) == 0.0  # grazing: G1 = 0, exactly
    odd_c, odd_w = filter_quadrature(0.7, 0.2, nodes=7)
    assert odd_c.shape == (7,)


# --------------------------------------------------------------------------------------
# gradients, validation, float32
# --------------------------------------------------------------------------------------
def test_gradcheck_interior():
    ti = t64([0.2, 0.9, 1.3]).requires_grad_()
    td = t64([0.25, 0.5, 0.9]).requires_grad_()
    for a in (0.15, 1.6):
        alpha = t64([a, a, a]).requires_grad_()
        assert torch.autograd.gradcheck(transmission_filter, (ti, td, alpha))
    c = t64([0.3, 0.8]).requires_grad_()
    alpha = t64(0.2).requires_grad_()
    assert torch.autograd.gradcheck(lambda c_, a_: filter_quadrature(c_, a_, nodes=12)[1], (c, alpha))
    assert torch.autograd.gradcheck(lambda c_, a_: filter_quadrature(c_, a_, nodes=12)[0], (c, alpha))


def test_finite_gradients_at_hard_points():
    ti = t64([0.0, 0.0, 0.4, 0.4, 0.4, 0.7, 1.5]).requires_grad_()
    td = t64([0.0, 0.3, 0.0, HALF_PI, HALF_PI - 0.4, HALF_PI - 0.7, HALF_PI]).requires_grad_()
    for a in (0.05, 1.0, 2.0):
        alpha = t64(a).requires_grad_()
        gi, gd, ga = torch.autograd.grad(transmission_filter(ti, td, alpha).sum(), (ti, td, alpha))
        assert bool(torch.isfinite(gi).all() & torch.isfinite(gd).all() & torch.isfinite(ga))
    # on the kink the gradient in θd is the left derivative
    k = HALF_PI - 0.7
    td_k = t64(k).requires_grad_()
    (g,) = torch.autograd.grad(transmission_filter(t64(0.7), td_k, 0.3), td_k)
    h = 1e-6
    left = (transmission_filter(t64(0.7), t64(k), 0.3) - transmission_filter(t64(0.7), t64(k - h), 0.3)) / h
    assert abs(float(g - left)) < 1e-4 * abs(float(left))
    # normal incidence through the cosine: Σ w g is even in θi (smooth in cos θi); its gradient
    # at cos θi = 1 is finite and equals the one-sided difference quotient
    def moment(c_):
        cos_d, w = filter_quadrature(c_, 0.2, nodes=64)
        return (w * cos_d**2).sum(-1)

    c = t64(1.0).requires_grad_()
    (gc,) = torch.autograd.grad(moment(c), c)
    h = 1e-4  # parabola through 4 points below 1 (the rule is capped at θi = α/300 above)
    x = -h * np.arange(1, 5)
    m = [float(moment(t64(1.0 + xk))) for xk in x]
    slope = np.polyfit(x, m, 2)[1]
    assert math.isfinite(float(gc)) and abs(float(gc) - slope) < 1e-4 * abs(slope)


@pytest.mark.parametrize(
    "args, name",
    [((-0.1, 0.3, 0.1), "theta_i"), ((1.6, 0.3, 0.1), "theta_i"), ((0.3, -1e-3, 0.1), "theta_d"),
     ((0.3, 1.58, 0.1), "theta_d"), ((0.3, 0.3, 0.0), "alpha"), ((0.3, 0.3, -1.0), "alpha")],
)
def test_filter_rejects_bad_input(args, name):
    with pytest.raises(ValueError, match=name):
        transmission_filter(*args)


def test_other_functions_reject_bad_input():
    with pytest.raises(ValueError, match="cos_theta_i"):
        filter_quadrature(1.2, 0.1)
    with pytest.raises(ValueError, match="alpha"):
        filter_quadrature(0.5, 0.0)
    for bad in (1, 2.5, True):
        with pytest.raises(ValueError, match="nodes"):
            filter_quadrature(0.5, 0.1, nodes=bad)
    for kwargs, name in (({"alpha": 0.0}, "alpha"), ({"alpha": float("nan")}, "alpha"),
                         ({"alpha": 0.1, "theta_i_step_deg": 0}, "theta_i_step_deg"),
                         ({"alpha": 0.1, "u_nodes": 1}, "u_nodes"), ({"alpha": 0.1, "rtol": 0}, "rtol"),
                         ({"alpha": 0.1, "dtype": torch.int32}, "dtype")):
        with pytest.raises(ValueError, match=name):
            transmission_filter_lut(**kwargs)


def test_nan_propagates_and_broadcasting():
    out = transmission_filter(t64([0.3, float("nan")]), t64([0.3, 0.3]), 0.1)
    assert torch.isfinite(out[0]) and torch.isnan(out[1])
    out = transmission_filter(t64(0.3).expand(2, 1, 1), t64([0.1, 0.2, 0.3]).reshape(3, 1), t64([0.1, 0.5]))
    assert out.shape == (2, 3, 2)


def test_float32_finite_and_accurate():
    ti = torch.linspace(0, HALF_PI, 91, dtype=F64)[:, None]
    td = torch.linspace(0, HALF_PI, 181, dtype=F64)[None, :]
    ti32, td32 = ti.float(), td.float()
    for alpha in (1e-3, 0.01, 0.1, 1.0, 3.0):
        got = transmission_filter(ti32, td32, alpha)
        assert got.dtype == torch.float32 and bool(torch.isfinite(got).all()) and bool((got >= 0).all())
        # against float64 at the same (rounded) inputs: the kink's √ would amplify input rounding
        ref = transmission_filter(ti32.double().clamp(max=HALF_PI), td32.double().clamp(max=HALF_PI),
                                  torch.tensor(alpha, dtype=torch.float32).double())
        assert float((got.double() - ref).abs().max()) < 1e-5 * float(ref.max())


def test_product_weight_rows_follow_the_chunk_knob(monkeypatch):
    """The product-integration weights of the transmissivity table are evaluated in blocks of
    rows (2·cells filter values per row) of torchirid.options(chunk_size=...), at least 64 rows;
    None: all rows at once. Rows are independent: the same weights."""
    import torchirid as ti
    from torchirid.layered import filter as filter_module

    rows = []
    real = filter_module._filter

    def spy(t, *args):
        rows.append(t.shape[0])
        return real(t, *args)

    monkeypatch.setattr(filter_module, "_filter", spy)
    c = torch.linspace(0.001, 1.0, 300, dtype=torch.float64)
    alpha = torch.tensor(0.1, dtype=torch.float64)
    results = {}
    for chunk in (None, 64 * 128, 1):
        rows.clear()
        with ti.options(chunk_size=chunk):
            results[chunk] = filter_module._hat_weights(torch.acos(c), alpha, 64, cos_i=c)
        assert sum(rows) == 300
        assert rows[0] == {None: 300, 64 * 128: 64, 1: 1}[chunk]  # (chunk_size 1: blocks of one row)
    torch.testing.assert_close(results[64 * 128], results[None], rtol=0, atol=0)
    torch.testing.assert_close(results[1], results[None], rtol=1e-15, atol=0)
