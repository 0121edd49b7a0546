"""Tests of torchirid.optics.rough_surface (Hirayama 2000 §4.2 with He–Torrance 1991).

References (the He–Torrance pieces alone against mpmath: test_he_torrance.py): the ``tmm`` package
(transmittance into the last film) and an independent Airy sum written out here (one film on
a rough substrate); physics: σ → 0 is the smooth multilayer *exactly*, energy
k_r + ∫ k_d cos ≤ 1 by hemisphere quadrature, Kirchhoff's k_r + ∫k_d ≈ |F|² at normal
incidence, reciprocity of k_d, grazing, gradients (gradcheck), float32, validation.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

import torchirid
from oracles import HIRAYAMA_FIG8, HIRAYAMA_TABLE1, hirayama_stack, material_nk, tmm_RT
from tensors import C128, F64, t64, tc128
from torchirid.optics import rough_surface as rs

TAU = 300.0


@pytest.fixture(autouse=True, scope="module")
def _one_thread():
    """Many small tensor ops: one thread avoids oversubscribing the shared 2-core machine."""
    before = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(before)


def _stack(entry, wl):
    idx, d = hirayama_stack(entry, wl)
    n = np.stack([np.broadcast_to(np.asarray(i, dtype=complex), np.shape(wl)) for i in idx], -1)
    return tc128(n), t64(np.array(np.broadcast_to(np.asarray(d, dtype=float), np.shape(wl) + (len(d),))))


def _hemisphere(nt=48, nphi=48):
    x, w = np.polynomial.legendre.leggauss(nt)
    c = t64((x + 1) / 2)[:, None]
    wc = t64(w / 2)[:, None]
    phi = (torch.arange(nphi, dtype=F64) + 0.5) * 2 * math.pi / nphi
    return c, wc, torch.cos(phi)[None, :], 2 * math.pi / nphi


# ---------------------------------------------------------------------------------------
# the rough interface with a film stack (the He–Torrance pieces alone: test_he_torrance.py)
# ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("sigma", [5.0, 10.0, 25.0])
def test_kirchhoff_energy_split_at_normal_incidence(sigma):
    """Kirchhoff, small slopes: coherent |F|²e^{-g} + incoherent ≈ |F|²(1 − e^{-g}) at normal incidence."""
    c, wc, cphi, dphi = _hemisphere(64, 32)
    lam = t64(550.0)
    n = tc128([1.0, 1.0 + 6.6j])
    d = t64(np.zeros(0))
    kd = rs.rough_multilayer_diffuse(lam, 1.0, c, cphi, n, d, sigma, TAU, shadowing=False)
    Ed = float((kd * c * wc).sum() * dphi)
    F = float(torchirid.optics.fresnel_reflectance(t64(1.0), 1.0, 1 + 6.6j))
    g = float(rs.roughness_factor(lam, 1.0, 1.0, sigma))
    assert abs(Ed - F * (1 - math.exp(-g))) <= 0.03 * F * (1 - math.exp(-g))  # measured -1.5 %, -1.5 %, -1.8 %


# ---------------------------------------------------------------------------------------
# films on the rough surface
# ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("entry", HIRAYAMA_FIG8 + HIRAYAMA_TABLE1, ids=lambda e: e["name"])
def test_smooth_limit_is_multilayer_exactly(entry):
    wl = np.linspace(380.0, 780.0, 9)[:, None] * np.ones((1, 6))
    c = t64(np.cos(np.radians([0.0, 20.0, 45.0, 70.0, 89.0, 90.0])))
    n, d = _stack(entry, wl)
    R_smooth, _ = torchirid.multilayer(t64(wl), c, n, d)
    for shadowing in (True, False):
        kr = rs.rough_multilayer_reflectance(t64(wl), c, n, d, 0.0, TAU, shadowing=shadowing)
        torch.testing.assert_close(kr, R_smooth, rtol=0, atol=2e-15)  # (rough: division form; multilayer: fraction form)
        kd = rs.rough_multilayer_diffuse(t64(wl), c, c.flip(0), -0.5, n, d, 0.0, TAU, shadowing=shadowing)
        assert torch.all(kd == 0)
    # continuity: σ = 1e-3 nm differs by O(g) ~ 1e-9
    kr = rs.rough_multilayer_reflectance(t64(wl), c, n, d, 1e-3, TAU)
    assert torch.max(torch.abs(kr - R_smooth)) < 1e-8


def _airy_rough(lam, c, n0, n1, d, n2, sigma, pol):
    """One film on a rough substrate, written out independently (numpy, tmm sign convention):
    r = (r01 + r12 e^{-g/2} e^{2iφ}) / (1 + r01 r12 e^{-g/2} e^{2iφ}), g = (4π σ n1 cos θ1 / λ)²."""
    s = n0 * math.sqrt(1 - c * c)
    c0 = c
    c1 = np.sqrt(1 - (s / n1) ** 2 + 0j)
    c2 = np.sqrt(1 - (s / n2) ** 2 + 0j)
    if c2.imag < 0:
        c2 = -c2

    def r(na, ca, nb, cb):
        if pol == "s":
            return (na * ca - nb * cb) / (na * ca + nb * cb)
        return (nb * ca - na * cb) / (nb * ca + na * cb)

    r01, r12 = r(n0, c0, n1, c1), r(n1, c1, n2, c2)
    g = (4 * math.pi * sigma * (n1 * c1).real / lam) ** 2
    e = np.exp(2j * 2 * math.pi * n1 * c1 * d / lam)
    rr = (r01 + r12 * math.exp(-g / 2) * e) / (1 + r01 * r12 * math.exp(-g / 2) * e)
    return abs(rr) ** 2


@pytest.mark.parametrize("lam", [400.0, 532.0, 710.0])
@pytest.mark.parametrize("theta", [0.0, 35.0, 75.0])
def test_single_film_coherent_reflectance_vs_independent_airy(lam, theta):
    c = math.cos(math.radians(theta))
    n2 = complex(material_nk("Al", lam))
    for pol in ("s", "p"):
        got = rs.rough_multilayer_reflectance(t64(lam), t64(c), tc128([1.0, 1.4, n2]), t64([1000.0]), 30.0, TAU,
                                              polarization=pol, shadowing=False)
        ref = _airy_rough(lam, c, 1.0, 1.4, 1000.0, n2, 30.0, pol)
        assert abs(float(got) - ref) <= 1e-12


def test_bare_substrate_reflectance_closed_form():
    """L = 0: k_r = |F|² e^{-g} S(θ)² (He eq. 31 with shadowing)."""
    lam = t64([400.0, 550.0, 700.0])[:, None]
    c = t64([1.0, 0.6, 0.2])
    n_sub = complex(material_nk("Si", 550.0))
    kr = rs.rough_multilayer_reflectance(lam, c, tc128([1.0, n_sub]), t64(np.zeros(0)), 40.0, TAU)
    F = torchirid.optics.fresnel_reflectance(c, 1.0, n_sub)
    sig = rs.effective_roughness(c, c, 40.0, TAU)
    ref = F * torch.exp(-rs.roughness_factor(lam, c, c, sig)) * rs.he_shadowing(c, 40.0, TAU) ** 2
    torch.testing.assert_close(kr, ref, rtol=1e-13, atol=0)


@pytest.mark.parametrize("theta", [0.0, 40.0, 80.0])
def test_transmittance_to_last_film_vs_tmm(theta):
    """Removing the interface contrast (substrate = last film) leaves eq. 6's T into film L."""
    c = math.cos(math.radians(theta))
    lam = 560.0
    ag = complex(material_nk("Ag", lam))
    idx = [1.0, 1.4, ag, 1.4, 1.4]
    T = rs.stack_transmittance_to_last_film(t64(lam), t64(c), tc128(idx), t64([1000.0, 5.0, 1000.0]), 40.0, TAU)
    _, T_ref = tmm_RT(lam, c, idx[:-1], [1000.0, 5.0], "unpolarized")
    assert abs(float(T) - T_ref) <= 1e-12


@pytest.mark.parametrize("entry", HIRAYAMA_FIG8 + HIRAYAMA_TABLE1, ids=lambda e: e["name"])
def test_diffuse_reciprocity(entry):
    wl = np.array([410.0, 530.0, 650.0, 770.0])[:, None]
    n, d = _stack(entry, wl)
    cl = t64([0.95, 0.7, 0.4, 0.15])
    cv = t64([0.3, 0.85, 0.99, 0.5])
    cp = t64([-1.0, -0.4, 0.3, 0.9])
    a = rs.rough_multilayer_diffuse(t64(wl), cl, cv, cp, n, d, 50.0, TAU)
    b = rs.rough_multilayer_diffuse(t64(wl), cv, cl, cp, n, d, 50.0, TAU)
    assert torch.all(a > 0)
    torch.testing.assert_close(a, b, rtol=1e-12, atol=0)


@pytest.mark.parametrize("entry", HIRAYAMA_FIG8 + HIRAYAMA_TABLE1, ids=lambda e: e["name"])
def test_energy_specular_plus_diffuse_at_most_one(entry):
    """k_r(θ_l) + ∫ k_d cos θ_i dω_i ≤ 1 (hemisphere quadrature, converged to < 1e-6 at 48²)."""
    c, wc, cphi, dphi = _hemisphere()
    for lam in (380.0, 550.0, 780.0):
        n, d = _stack(entry, np.array(lam))
        for sigma in (25.0, 50.0):
            cl = t64([1.0, 0.7, 0.3, 0.05])[:, None, None]
            kr = rs.rough_multilayer_reflectance(t64(lam), cl[:, 0, 0], n, d, sigma, TAU)
            kd = rs.rough_multilayer_diffuse(t64(lam), cl, c, cphi, n, d, sigma, TAU)
            total = kr + (kd * c * wc).sum((-1, -2)) * dphi
            assert torch.all(total <= 1.0), (lam, sigma, total)
            assert torch.all(total >= kr)


def test_roughness_lowers_specular_and_adds_diffuse():
    entry = HIRAYAMA_FIG8[1]
    wl = np.linspace(400.0, 700.0, 7)
    n, d = _stack(entry, wl)
    kr = [rs.rough_multilayer_reflectance(t64(wl), 0.9, n, d, s, TAU) for s in (0.0, 25.0, 50.0)]
    assert torch.all(kr[1] < kr[0]) and torch.all(kr[2] < kr[1])


def test_grazing_and_normal_are_finite_with_gradients():
    n, d = _stack(HIRAYAMA_FIG8[0], np.array(550.0))
    sigma = t64(30.0).requires_grad_()
    dd = d.clone().requires_grad_()
    c = t64([0.0, 1e-300, 1.0])
    kr = rs.rough_multilayer_reflectance(t64(550.0), c, n, dd, sigma, TAU)
    kd = rs.rough_multilayer_diffuse(t64(550.0), c, c.flip(0), -1.0, n, dd, sigma, TAU)
    assert torch.all(torch.isfinite(kr)) and torch.all(torch.isfinite(kd))
    assert kr[0] == 1.0  # grazing on the flat top film: r01 = -1 (the film itself is not grazed)
    bare = rs.rough_multilayer_reflectance(t64(550.0), c, n[[0, -1]], d[:0], sigma, TAU)
    assert bare[0] == 0.0  # bare rough substrate at grazing: fully shadowed (He's S(90°) = 0)
    assert torch.all(kd[[0, 2]] == 0.0)  # one of the two directions grazing: no diffuse light
    (kr.sum() + kd.sum()).backward()
    assert torch.isfinite(sigma.grad) and torch.all(torch.isfinite(dd.grad))
    # σ = 0 (smooth limit) also has finite gradients
    s0 = t64(0.0).requires_grad_()
    (rs.rough_multilayer_reflectance(t64(550.0), c, n, d, s0, TAU).sum()
     + rs.rough_multilayer_diffuse(t64(550.0), 0.8, 0.7, -0.9, n, d, s0, TAU)).backward()
    assert torch.isfinite(s0.grad)


def test_gradcheck_sigma_tau_thickness():
    lam = t64([450.0, 620.0])
    n = tc128([1.0, 1.4, 0.06 + 3.6j, 1.4, 1.0 + 6.6j])

    def f(sigma, tau, d):
        kr = rs.rough_multilayer_reflectance(lam, 0.8, n, d, sigma, tau)
        kd = rs.rough_multilayer_diffuse(lam, 0.8, 0.6, -0.7, n, d, sigma, tau)
        return kr, kd

    args = (t64(30.0).requires_grad_(), t64(300.0).requires_grad_(), t64([400.0, 5.0, 300.0]).requires_grad_())
    assert torch.autograd.gradcheck(f, args, eps=1e-6, atol=1e-7, rtol=1e-5)

    def h(sigma, tau):  # shadowing + effective roughness active: 80° directions
        return rs.he_directional_diffuse(lam, 0.17, 0.3, -0.2, sigma, tau, 1 + 6j)

    assert torch.autograd.gradcheck(h, (t64(60.0).requires_grad_(), t64(200.0).requires_grad_()), eps=1e-6,
                                    atol=1e-8, rtol=1e-5)


def test_float32_matches_float64():
    wl = np.linspace(380.0, 780.0, 21)
    n, d = _stack(HIRAYAMA_FIG8[2], wl)
    c = torch.linspace(0.05, 1.0, 7, dtype=F64)[:, None]
    kr64 = rs.rough_multilayer_reflectance(t64(wl), c, n, d, 25.0, TAU)
    kd64 = rs.rough_multilayer_diffuse(t64(wl), c, 0.8, -0.9, n, d, 25.0, TAU)
    kr32 = rs.rough_multilayer_reflectance(t64(wl).float(), c.float(), n.to(torch.complex64), d.float(), 25.0, TAU)
    kd32 = rs.rough_multilayer_diffuse(t64(wl).float(), c.float(), 0.8, -0.9, n.to(torch.complex64), d.float(), 25.0, TAU)
    assert kr32.dtype == torch.float32 and kd32.dtype == torch.float32
    # measured over all Fig. 8 / Table 1 stacks, 81 λ × 21 angles, σ 25 and 50: 6.2e-6 and 3.6e-6
    assert torch.max(torch.abs(kr32.double() - kr64)) < 3e-5  # 1000 nm films: phases ~ 40 rad in float32
    assert torch.max(torch.abs(kd32.double() - kd64) / kd64.abs().max()) < 3e-5


def test_shapes_broadcast():
    lam = t64(np.linspace(400, 700, 5))  # (5,)
    c = t64([[0.3], [0.9]])  # (2, 1)
    n = tc128([1.0, 1.4, 1 + 6j])
    d = t64([[200.0], [300.0], [400.0]])[:, None, None]  # (3, 1, 1, L=1)
    kr = rs.rough_multilayer_reflectance(lam, c, n, d, t64([10.0, 20.0, 30.0, 40.0, 50.0]), TAU)
    assert kr.shape == (3, 2, 5)
    kd = rs.rough_multilayer_diffuse(lam, c, 0.7, t64([-1.0, 0.0, 1.0, 0.5, -0.5]), n, d, 20.0, TAU)
    assert kd.shape == (3, 2, 5)
    # NaN propagates
    assert torch.isnan(rs.rough_multilayer_reflectance(lam, t64(float("nan")), n, d[0, 0], 20.0, TAU)).all()


@pytest.mark.parametrize("polarization", ["unpolarized", "s", "p"])
def test_roughness_only_batches_are_not_mixed(polarization):
    """A batch that comes only from σ or τ gives each entry its own value (the rough seed's batch
    axis used to meet the polarization axis: entries were averaged together, one NaN spread to all)."""
    n = tc128([1.0, 1.45, 2.0 + 0.5j])
    d = t64([300.0])
    sig, tau = t64([25.0, 50.0, float("nan")]), t64([[300.0], [200.0]])
    kw = dict(polarization=polarization)
    calls = [
        lambda s_, t_: rs.rough_multilayer_reflectance(550.0, 0.8, n, d, s_, t_, **kw),
        lambda s_, t_: rs.stack_transmittance_to_last_film(550.0, 0.8, n, d, s_, t_, **kw),
        lambda s_, t_: rs.rough_multilayer_diffuse(550.0, 0.8, 0.6, -0.9, n, d, s_, t_, **kw),
    ]
    for f in calls:
        out = f(sig, tau)
        assert out.shape == (2, 3)
        assert torch.isnan(out[:, 2]).all()
        for i in range(2):
            for j in range(2):
                assert float(out[i, j]) == pytest.approx(float(f(sig[j], tau[i, 0])), rel=1e-12, abs=0)


@pytest.mark.parametrize("kwargs, match", [
    (dict(sigma=-1.0), "sigma"),
    (dict(tau=0.0), "tau"),
    (dict(cos_phi=1.5), "cos_phi"),
    (dict(cos_theta_i=1.2), "cos_theta_i"),
    (dict(indices=[1.0, 1.4 + 0.1j, 1 + 6j]), "rough interface"),
    (dict(indices=[1.0, 1.4, 1.5, 1 + 6j]), "len\\(thicknesses\\)"),
    (dict(polarization="x"), "polarization"),
])
def test_validation(kwargs, match):
    args = dict(wavelength=t64(500.0), cos_theta_i=0.5, cos_theta_o=0.5, cos_phi=-1.0, indices=[1.0, 1.4, 1 + 6j],
                thicknesses=[100.0], sigma=10.0, tau=TAU, polarization="unpolarized")
    args.update(kwargs)
    args["indices"] = tc128(args["indices"])
    args["thicknesses"] = t64(args["thicknesses"])
    pol = args.pop("polarization")
    with pytest.raises(ValueError, match=match):
        rs.rough_multilayer_diffuse(**args, polarization=pol)


def test_bare_substrate_diffuse_is_he_torrance():
    """L = 0: k_d is He's directional-diffuse BRDF in the incident medium itself (T = 1 both ways)."""
    lam = t64([400.0, 550.0, 700.0])[:, None]
    cl, cv, cp = t64([0.9, 0.5, 0.2]), t64([0.7, 0.95, 0.4]), t64([-1.0, -0.2, 0.5])
    n_sub = complex(material_nk("Cu", 550.0))
    kd = rs.rough_multilayer_diffuse(lam, cl, cv, cp, tc128([1.0, n_sub]), t64(np.zeros(0)), 35.0, TAU)
    ref = rs.he_directional_diffuse(lam, cl, cv, cp, 35.0, TAU, n_sub)
    torch.testing.assert_close(kd, ref, rtol=1e-14, atol=0)
    T = rs.stack_transmittance_to_last_film(lam, cl, tc128([1.0, n_sub]), t64(np.zeros(0)), 35.0, TAU)
    assert torch.all(T == 1.0)


def _T_down_one_film(lam, c, n1, d, n2, sigma, pol):
    """Independent (numpy, tmm conventions): flux of the downward wave at the bottom of one lossless
    film on a rough substrate, A = t01 e^{iφ} / (1 + r01 r12 e^{-g/2} e^{2iφ}), T = n1 cos θ1 / cos θ0 |A|²."""
    s = math.sqrt(1 - c * c)
    c1 = math.sqrt(1 - (s / n1) ** 2)
    c2 = np.sqrt(1 - (s / n2) ** 2 + 0j)
    if c2.imag < 0:
        c2 = -c2
    if pol == "s":
        r01 = (c - n1 * c1) / (c + n1 * c1)
        t01 = 2 * c / (c + n1 * c1)
        r12 = (n1 * c1 - n2 * c2) / (n1 * c1 + n2 * c2)
    else:
        r01 = (n1 * c - c1) / (n1 * c + c1)
        t01 = 2 * c / (n1 * c + c1)
        r12 = (n2 * c1 - n1 * c2) / (n2 * c1 + n1 * c2)
    g = (4 * math.pi * sigma * n1 * c1 / lam) ** 2
    e1 = np.exp(1j * 2 * math.pi * n1 * c1 * d / lam)
    A = t01 * e1 / (1 + r01 * r12 * math.exp(-g / 2) * e1 * e1)
    return n1 * c1 / c * abs(A) ** 2, c1


@pytest.mark.parametrize("lam, tl, tv, cphi", [(430.0, 10.0, 35.0, -1.0), (560.0, 50.0, 20.0, -0.3), (690.0, 70.0, 5.0, 0.6)])
def test_single_film_diffuse_vs_independent_composition(lam, tl, tv, cphi):
    """k_d = (n0/n1)² T(l) ρ_dd(in the film) T(v), T from an independent Airy-type sum (s/p averaged)."""
    n1, d, sigma = 1.4, 800.0, 30.0
    n2 = complex(material_nk("Al", lam))
    cl, cv = math.cos(math.radians(tl)), math.cos(math.radians(tv))
    T = {}
    for name, c in (("l", cl), ("v", cv)):
        Ts, c1 = _T_down_one_film(lam, c, n1, d, n2, sigma, "s")
        Tp, _ = _T_down_one_film(lam, c, n1, d, n2, sigma, "p")
        T[name] = (0.5 * (Ts + Tp), c1)
    rho = rs.he_directional_diffuse(t64(lam), T["l"][1], T["v"][1], cphi, sigma, TAU, n2, n_incident=n1, shadowing=False)
    ref = (1 / n1) ** 2 * T["l"][0] * float(rho) * T["v"][0]
    got = rs.rough_multilayer_diffuse(t64(lam), cl, cv, cphi, tc128([1.0, n1, n2]), t64([d]), sigma, TAU,
                                      shadowing=False)
    assert abs(float(got) - ref) <= 1e-12 * ref
