"""Tests of torchirid.optics.he_torrance: the rough-interface pieces of He et al. 1991 that
Hirayama 2000 §4.2 builds on (tests/optics/test_rough_surface.py tests them with a film stack).

References: mpmath closed forms at 30 digits — the roughness factor g and e^{-g}, He's shadowing
(eq. 24–25), the effective roughness as the root of eq. 80 (bisection), the directional-diffuse
term with its D series (eq. 78) summed term by term and F from ``tmm``; reciprocity and σ → 0.
"""

from __future__ import annotations

import math

import mpmath
import pytest
import torch

from oracles import tmm_RT
from tensors import t64
from torchirid.optics import he_torrance as ht

TAU = 300.0


@pytest.fixture(autouse=True, scope="module")
def _one_thread():
    """Many small tensor ops: one thread avoids oversubscribing the shared 2-core machine."""
    before = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(before)


@pytest.mark.parametrize("lam, ci, co, sigma, n", [(550.0, 1.0, 1.0, 25.0, 1.0), (400.0, 0.3, 0.9, 50.0, 1.4),
                                                   (780.0, 0.0, 0.5, 5.0, 2.0)])
def test_roughness_factor_and_attenuation_vs_mpmath(lam, ci, co, sigma, n):
    mpmath.mp.dps = 30
    g_ref = (2 * mpmath.pi * sigma * n * (mpmath.mpf(ci) + co) / lam) ** 2
    g = ht.roughness_factor(t64(lam), ci, co, sigma, n_incident=n)
    assert abs(float(g) - float(g_ref)) <= 1e-14 * max(1.0, float(g_ref))
    e = ht.coherent_attenuation(t64(lam), ci, sigma, n_incident=n)
    e_ref = mpmath.exp(-(4 * mpmath.pi * sigma * n * mpmath.mpf(ci) / lam) ** 2)
    assert abs(float(e) - float(e_ref)) <= 1e-15


def _S_ref(c, sigma, tau):
    c = mpmath.mpf(c)
    a = tau * c / (2 * sigma * mpmath.sqrt(1 - c * c))
    lam = (mpmath.exp(-a * a) / (mpmath.sqrt(mpmath.pi) * a) - mpmath.erfc(a)) / 2
    return (1 - mpmath.erfc(a) / 2) / (lam + 1)


@pytest.mark.parametrize("theta_deg", [30.0, 60.0, 80.0, 89.0, 89.99])
@pytest.mark.parametrize("sigma, tau", [(50.0, 300.0), (25.0, 100.0), (100.0, 100.0)])
def test_shadowing_vs_mpmath(theta_deg, sigma, tau):
    mpmath.mp.dps = 30
    c = math.cos(math.radians(theta_deg))
    S = ht.he_shadowing(t64(c), sigma, tau)
    assert abs(float(S) - float(_S_ref(c, sigma, tau))) <= 1e-13


def test_shadowing_limits():
    c = t64([0.0, 1e-12, 0.5, 1.0])
    S = ht.he_shadowing(c, 50.0, 300.0)
    assert S[0] == 0.0 and S[-1] == 1.0
    assert 0 < S[1] < 1e-6
    assert torch.all(ht.he_shadowing(c[1:], 0.0, 300.0) == 1.0)  # smooth: nothing shadowed


@pytest.mark.parametrize("ti, tr", [(85.0, 85.0), (70.0, 89.0), (10.0, 20.0), (88.0, 30.0)])
def test_effective_roughness_solves_eq80(ti, tr):
    mpmath.mp.dps = 30
    s0, tau = 50.0, 300.0

    def K(t):
        tan = mpmath.tan(mpmath.radians(t))
        return tan * mpmath.erfc(tau / (2 * s0 * tan))

    f0 = (K(ti) + K(tr)) / mpmath.sqrt(8 * mpmath.pi)
    lo, hi = mpmath.mpf(0), mpmath.mpf(10)  # bisection: x e^{x²/2} is increasing
    for _ in range(120):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if mid * mpmath.exp(mid * mid / 2) < f0 else (lo, mid)
    x = (lo + hi) / 2
    ref = s0 / mpmath.sqrt(1 + x * x)
    got = ht.effective_roughness(t64(math.cos(math.radians(ti))), t64(math.cos(math.radians(tr))), s0, tau)
    assert abs(float(got) - float(ref)) <= 1e-11 * s0


def _rho_dd_ref(lam, ci, co, cphi, sigma, tau, n_sub):
    """He eq. 76–84 (no shadowing, σ₀ itself), term by term in mpmath; F from tmm."""
    mpmath.mp.dps = 30
    ci, co, cphi = mpmath.mpf(ci), mpmath.mpf(co), mpmath.mpf(cphi)
    si, so = mpmath.sqrt(1 - ci**2), mpmath.sqrt(1 - co**2)
    win = mpmath.matrix([si, 0, ci])
    wout = mpmath.matrix([so * cphi, so * mpmath.sqrt(1 - cphi**2), co])
    v = win + wout
    k = 2 * mpmath.pi / lam
    g = (2 * mpmath.pi * sigma * (ci + co) / lam) ** 2
    vxy2 = k**2 * (v[0] ** 2 + v[1] ** 2)
    D = mpmath.pi**2 * tau**2 / (4 * lam**2) * mpmath.nsum(
        lambda m: g**m * mpmath.exp(-g) / (mpmath.factorial(m) * m) * mpmath.exp(-vxy2 * tau**2 / (4 * m)), [1, mpmath.inf]
    )
    vv = v[0] ** 2 + v[1] ** 2 + v[2] ** 2
    G = (vv / v[2]) ** 2
    cos_b = float(mpmath.sqrt(vv / 4))
    F, _ = tmm_RT(lam, min(cos_b, 1.0), [1.0, n_sub], [], "unpolarized")
    return float(F * G * D / (mpmath.pi * ci * co))


@pytest.mark.parametrize("lam, ci, co, cphi, sigma", [
    (550.0, 1.0, 0.95, -1.0, 25.0),
    (400.0, 0.8, 0.6, -0.3, 50.0),
    (450.0, 0.9, 0.9, -1.0, 300.0),  # g ≈ 50: the series needs ~130 terms
    (700.0, 0.5, 0.7, 0.4, 10.0),
])
def test_directional_diffuse_vs_mpmath_series(lam, ci, co, cphi, sigma):
    n_sub = 1.2 + 6.9j
    got = ht.he_directional_diffuse(t64(lam), ci, co, cphi, sigma, TAU, n_sub, shadowing=False)
    ref = _rho_dd_ref(lam, ci, co, cphi, sigma, TAU, n_sub)
    assert got > 0
    assert abs(float(got) - ref) <= 1e-9 * ref


def test_directional_diffuse_is_symmetric_and_zero_when_smooth():
    lam = t64([420.0, 560.0, 690.0])[:, None]
    cl, cv, cp = t64([0.9, 0.4, 0.2]), t64([0.3, 0.8, 0.99]), t64([-0.8, 0.1, 0.6])
    a = ht.he_directional_diffuse(lam, cl, cv, cp, 40.0, TAU, 1 + 6j)
    b = ht.he_directional_diffuse(lam, cv, cl, cp, 40.0, TAU, 1 + 6j)
    torch.testing.assert_close(a, b, rtol=1e-13, atol=0)
    assert torch.all(ht.he_directional_diffuse(lam, cl, cv, cp, 0.0, TAU, 1 + 6j) == 0)
