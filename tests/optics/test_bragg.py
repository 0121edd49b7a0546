"""Bragg mirror: Yeh's closed form against independent references and at the hard cases."""

from __future__ import annotations

import math

import mpmath
import numpy as np
import pytest
import torch

import torchirid as ti
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from oracles import bragg_stack, mpmath_bragg_R, quarter_wave_R, tmm_RT

from tensors import F64, t64


def _random_mirrors(rng, count, host_mode):
    """Random mirrors and points; host_mode in {'n1', 'host', 'tir'}."""
    P = dict(
        lam=rng.uniform(380, 780, count),
        c=rng.uniform(0, 1, count),
        n1=rng.uniform(1.0, 2.0, count),
        n2=rng.uniform(1.0, 2.5, count),
        d1=rng.uniform(0, 600, count),
        d2=rng.uniform(0, 600, count),
        N=rng.integers(1, 201, count),
    )
    if host_mode == "n1":
        P["nh"] = None
    elif host_mode == "host":
        P["nh"] = rng.uniform(1.0, 1.6, count)
    else:  # total internal reflection in n1 and/or n2 for steep angles
        P["nh"] = rng.uniform(2.0, 2.6, count)
        P["c"] = rng.uniform(0, 0.6, count)
    return P


def _ours(P, pol, dtype=F64):
    nh = None if P["nh"] is None else torch.as_tensor(P["nh"], dtype=dtype)
    return ti.bragg_reflectance(
        torch.as_tensor(P["lam"], dtype=dtype), torch.as_tensor(P["c"], dtype=dtype),
        torch.as_tensor(P["n1"], dtype=dtype), torch.as_tensor(P["n2"], dtype=dtype),
        torch.as_tensor(P["d1"], dtype=dtype), torch.as_tensor(P["d2"], dtype=dtype),
        torch.as_tensor(P["N"]), n_incident=nh, polarization=pol,
    )


def _tmm(P, i, pol):
    nh = None if P["nh"] is None else P["nh"][i]
    idx, d = bragg_stack(P["n1"][i], P["n2"][i], P["d1"][i], P["d2"][i], int(P["N"][i]), n_incident=nh)
    with np.errstate(all="ignore"):  # tmm's unnormalised matrices overflow for evanescent stacks
        R = tmm_RT(P["lam"][i], P["c"][i], idx, d, pol)[0]
    if not np.isfinite(R):
        # tmm multiplies unnormalised matrices: evanescent stacks overflow; use mpmath there
        R = mpmath_bragg_R(P["lam"][i], P["c"][i], P["n1"][i], P["n2"][i], P["d1"][i], P["d2"][i],
                           int(P["N"][i]), n_incident=nh, polarization=pol)
    return R


# ---------------------------------------------------------------------------------------
# against tmm on the explicit stack
# ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("host_mode", ["n1", "host", "tir"])
@pytest.mark.parametrize("pol", ["s", "p", "unpolarized"])
def test_matches_tmm_on_explicit_stack(host_mode, pol):
    rng = np.random.default_rng(hash((host_mode, pol)) % 2**32)
    P = _random_mirrors(rng, 25, host_mode)
    R = _ours(P, pol).numpy()
    ref = np.array([_tmm(P, i, pol) for i in range(len(R))])
    assert np.abs(R - ref).max() <= 1e-9


def test_absorbing_layers_match_tmm():
    rng = np.random.default_rng(7)
    for pol in ("s", "p"):
        for _ in range(12):
            n1 = complex(rng.uniform(1, 2), rng.uniform(0, 0.05))
            n2 = complex(rng.uniform(1, 2.5), rng.uniform(0, 0.3))
            nh, lam, c = rng.uniform(1, 1.6), rng.uniform(380, 780), rng.uniform(0, 1)
            d1, d2, N = rng.uniform(0, 400), rng.uniform(0, 400), int(rng.integers(1, 80))
            R = ti.bragg_reflectance(t64(lam), c, torch.tensor(n1, dtype=torch.complex128),
                                     torch.tensor(n2, dtype=torch.complex128), d1, d2, N,
                                     n_incident=nh, polarization=pol)
            idx, d = bragg_stack(n1, n2, d1, d2, N, n_incident=nh)
            assert abs(float(R) - tmm_RT(lam, c, idx, d, pol)[0]) <= 1e-9


def test_equals_multilayer_on_the_same_stack():
    rng = np.random.default_rng(3)
    for host in (None, 1.33):
        for N in (1, 2, 5, 17, 30):
            lam = t64(rng.uniform(380, 780, 50))
            c = t64(rng.uniform(0, 1, 50))
            n1, n2, d1, d2 = 1.1, 1.7, 140.0, 90.0
            idx, d = bragg_stack(n1, n2, d1, d2, N, n_incident=host)
            Rm, _ = ti.multilayer(lam, c, t64(idx), t64(d))
            Rb = ti.bragg_reflectance(lam, c, n1, n2, d1, d2, N, n_incident=host)
            assert (Rm - Rb).abs().max() <= 1e-10


def test_one_cell_is_the_thin_film():
    lam = torch.linspace(380, 780, 81, dtype=F64)
    c = torch.linspace(0, 1, 11, dtype=F64)[:, None]
    for pol in ("s", "p", "unpolarized"):
        Rb = ti.bragg_reflectance(lam, c, 1.2, 1.9, 300.0, 210.0, 1, polarization=pol)
        Rf = ti.thin_film_reflectance(lam, c, 1.9, 210.0, 1.2, n_incident=1.2, polarization=pol)
        assert (Rb - Rf).abs().max() <= 1e-12


# ---------------------------------------------------------------------------------------
# closed forms and hard cases
# ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("N", [1, 2, 7, 40, 1000, 10**6])
def test_quarter_wave_stack(N):
    lam0, n1, n2 = 550.0, 1.0, 1.5
    d1, d2 = lam0 / (4 * n1), lam0 / (4 * n2)
    R = ti.bragg_reflectance(t64(lam0), t64(1.0), n1, n2, d1, d2, N)
    assert abs(float(R) - quarter_wave_R(n1, n2, N)) <= 1e-12
    x = ti.optics.bragg_dispersion(t64(lam0), t64(1.0), n1, n2, d1, d2)
    assert float(x) == pytest.approx(-0.5 * (n1 / n2 + n2 / n1), abs=1e-14)


@pytest.mark.parametrize("host", [None, 1.33, 2.4])
@pytest.mark.parametrize("pol", ["s", "p", "unpolarized"])
def test_grazing_is_total_reflection(host, pol):
    lam = torch.linspace(380, 780, 41, dtype=F64)
    R = ti.bragg_reflectance(lam, t64(0.0), 1.0, 1.5, 125.0, 375.0, 20, n_incident=host, polarization=pol)
    assert torch.all(R == 1) or (R - 1).abs().max() <= 1e-12


def test_brewster_angle_p_reflectance_vanishes():
    n1, n2 = 1.0, 1.5
    c = t64(math.cos(math.atan(n2 / n1)))  # Brewster in n1 toward n2 (host = n1)
    lam = torch.linspace(380, 780, 101, dtype=F64)
    R = ti.bragg_reflectance(lam, c, n1, n2, 125.0, 375.0, 20, polarization="p")
    assert R.abs().max() <= 1e-12
    # s is not affected, and the band gaps close for p (|cos KΛ| ≤ 1 everywhere, Fourneau app. A)
    x = ti.optics.bragg_dispersion(lam, c, n1, n2, 125.0, 375.0, polarization="p")
    assert x.abs().max() <= 1 + 1e-12
    Rs = ti.bragg_reflectance(lam, c, n1, n2, 125.0, 375.0, 20, polarization="s")
    assert Rs.max() > 0.5


def test_normal_incidence_s_equals_p():
    lam = torch.linspace(380, 780, 201, dtype=F64)
    for host in (None, 1.5):
        Rs = ti.bragg_reflectance(lam, 1.0, 1.0, 1.5, 125.0, 375.0, 20, n_incident=host, polarization="s")
        Rp = ti.bragg_reflectance(lam, 1.0, 1.0, 1.5, 125.0, 375.0, 20, n_incident=host, polarization="p")
        assert (Rs - Rp).abs().max() <= 1e-13


def test_every_layer_evanescent_is_total_reflection():
    # host 2.0, layers 1.2 / 1.4 and exit 1.2: beyond both critical angles nothing propagates
    lam = torch.linspace(380, 780, 21, dtype=F64)
    c = t64([0.0, 0.2, 0.4])[:, None]
    for N in (1, 5, 200, 10**6):
        for pol in ("s", "p"):
            R = ti.bragg_reflectance(lam, c, 1.2, 1.4, 80.0, 60.0, N, n_incident=2.0, polarization=pol)
            assert torch.isfinite(R).all()
            assert (R - 1).abs().max() <= 1e-12
    # evanescent in n2 only (host = n1 = 1.6, n2 = 1.2): compare with the references
    for N in (3, 150):
        for cc in (0.1, 0.5):
            R = ti.bragg_reflectance(t64(500.0), t64(cc), 1.6, 1.2, 100.0, 40.0, N, polarization="s")
            ref = mpmath_bragg_R(500.0, cc, 1.6, 1.2, 100.0, 40.0, N, polarization="s")
            assert abs(float(R) - ref) <= 1e-9


# -- band edges: |cos KΛ| = 1, located independently with mpmath --------------------------
def _mp_cos_KL(lam, c, n1, n2, d1, d2, pol):
    lam, c, n1, n2 = (mpmath.mpf(v) for v in (lam, c, n1, n2))
    s2 = n1 ** 2 * (1 - c ** 2)
    q1, q2 = n1 * c, mpmath.sqrt(n2 ** 2 - s2)
    e1, e2 = (q1, q2) if pol == "s" else (q1 / n1 ** 2, q2 / n2 ** 2)
    a, b = 2 * mpmath.pi * q1 * d1 / lam, 2 * mpmath.pi * q2 * d2 / lam
    return mpmath.cos(a) * mpmath.cos(b) - (e1 / e2 + e2 / e1) / 2 * mpmath.sin(a) * mpmath.sin(b)


def _band_edges(c, n1, n2, d1, d2, pol, count=4):
    """Wavelengths (nm, float64) where cos KΛ = ±1, refined with mpmath at 40 digits."""
    lam = torch.linspace(380, 780, 4001, dtype=F64)
    x = ti.optics.bragg_dispersion(lam, t64(c), n1, n2, d1, d2, polarization=pol)
    edges = []
    with mpmath.workdps(40):
        for sign in (1.0, -1.0):
            f = (x - sign).numpy()
            idx = np.nonzero(np.sign(f[:-1]) != np.sign(f[1:]))[0]
            for i in idx[:count]:
                lo, hi = float(lam[i]), float(lam[i + 1])
                root = mpmath.findroot(lambda L: _mp_cos_KL(L, c, n1, n2, d1, d2, pol) - sign, (lo, hi),
                                       solver="anderson")
                edges.append(float(root))
    return edges


def _backward_tolerance(lam, c, n1, n2, d1, d2, N, pol, ulps=8):
    """Exact R at lam and its spread over lam ± a few ulps: the float64 conditioning of R."""
    ref = mpmath_bragg_R(lam, c, n1, n2, d1, d2, N, polarization=pol)
    spread = 0.0
    for k in (-ulps, ulps):
        lk = lam + k * math.ulp(lam)
        spread = max(spread, abs(mpmath_bragg_R(lk, c, n1, n2, d1, d2, N, polarization=pol) - ref))
    return ref, spread


@pytest.mark.parametrize("N", [20, 200, 10**6])
@pytest.mark.parametrize("pol", ["s", "p"])
def test_band_edges_and_their_neighbourhood(N, pol):
    c, n1, n2, d1, d2 = 0.8, 1.0, 1.5, 125.0, 375.0
    edges = _band_edges(c, n1, n2, d1, d2, pol, count=2)
    assert len(edges) >= 2
    worst = 0.0
    for e in edges:
        for lam in (e, e - 1e-7, e + 1e-7):
            R = float(ti.bragg_reflectance(t64(lam), t64(c), n1, n2, d1, d2, N, polarization=pol))
            ref, spread = _backward_tolerance(lam, c, n1, n2, d1, d2, N, pol)
            assert 0 <= R <= 1
            # forward error ≤ 1e-9 plus the change of the exact R over ±8 ulps of λ
            assert abs(R - ref) <= 1e-9 + spread
            worst = max(worst, abs(R - ref))
    if N <= 200:
        assert worst <= 1e-9


def test_huge_cell_counts_against_mpmath():
    rng = np.random.default_rng(11)
    for N in (10**4, 10**6):
        for _ in range(6):
            lam, c = rng.uniform(380, 780), rng.uniform(0, 1)
            n2, d1, d2 = rng.uniform(1.2, 2.0), rng.uniform(50, 400), rng.uniform(50, 400)
            for pol in ("s", "p"):
                R = float(ti.bragg_reflectance(t64(lam), t64(c), 1.0, n2, d1, d2, N, polarization=pol))
                ref, spread = _backward_tolerance(lam, c, 1.0, n2, d1, d2, N, pol)
                assert abs(R - ref) <= 1e-9 + spread


def test_host_medium_huge_cells_against_mpmath():
    for N in (1000, 10**6):
        for lam in (420.0, 555.5, 700.0):
            R = float(ti.bragg_reflectance(t64(lam), t64(0.7), 1.2, 1.6, 120.0, 90.0, N, n_incident=1.0,
                                           polarization="s"))
            ref = mpmath_bragg_R(lam, 0.7, 1.2, 1.6, 120.0, 90.0, N, n_incident=1.0, polarization="s")
            _, spread = _backward_tolerance(lam, 0.7, 1.2, 1.6, 120.0, 90.0, N, "s")
            assert abs(R - ref) <= 1e-9 + spread


# ---------------------------------------------------------------------------------------
# dispersion relation and envelope
# ---------------------------------------------------------------------------------------
def test_dispersion_matches_eq8_in_high_precision():
    rng = np.random.default_rng(5)
    for _ in range(40):
        lam, c, n2 = rng.uniform(380, 780), rng.uniform(0, 1), rng.uniform(1.1, 2.5)
        d1, d2 = rng.uniform(0, 500), rng.uniform(0, 500)
        for pol in ("s", "p"):
            x = float(ti.optics.bragg_dispersion(t64(lam), t64(c), 1.0, n2, d1, d2, polarization=pol))
            with mpmath.workdps(30):
                ref = float(_mp_cos_KL(lam, c, 1.0, n2, d1, d2, pol))
            assert abs(x - ref) <= 1e-12


def test_envelope_bounds_the_spectrum():
    lam = torch.linspace(380, 780, 2001, dtype=F64)
    c = t64([1.0, 0.7, 0.3])[:, None]
    for pol in ("s", "p", "unpolarized"):
        Re = ti.optics.bragg_envelope(lam, c, 1.0, 1.5, 315.0, 315.0, polarization=pol)
        for N in (5, 10, 50):
            R = ti.bragg_reflectance(lam, c, 1.0, 1.5, 315.0, 315.0, N, polarization=pol)
            assert torch.all(R <= Re + 1e-12)
        x = ti.optics.bragg_dispersion(lam, c, 1.0, 1.5, 315.0, 315.0, polarization="s")
        if pol == "s":
            assert torch.all(Re[x.abs() > 1] == 1)


def test_envelope_at_airy_points_is_the_slab():
    # where cos KΛ = 0 the envelope equals |r1|², the reflectance of one cell (Fourneau §3.2.1)
    c, n1, n2, d1, d2 = 0.9, 1.0, 1.5, 315.0, 315.0
    lam = torch.linspace(380, 780, 40001, dtype=F64)
    x = ti.optics.bragg_dispersion(lam, t64(c), n1, n2, d1, d2).numpy()
    i = np.nonzero(np.sign(x[:-1]) != np.sign(x[1:]))[0][0]
    with mpmath.workdps(30):
        root = float(mpmath.findroot(lambda L: _mp_cos_KL(L, c, n1, n2, d1, d2, "s"),
                                     (float(lam[i]), float(lam[i + 1])), solver="anderson"))
    Re = ti.optics.bragg_envelope(t64(root), t64(c), n1, n2, d1, d2, polarization="s")
    R1 = ti.bragg_reflectance(t64(root), t64(c), n1, n2, d1, d2, 1, polarization="s")
    assert abs(float(Re) - float(R1)) <= 1e-10


# ---------------------------------------------------------------------------------------
# shapes, dtypes, float32
# ---------------------------------------------------------------------------------------
def test_broadcasting_with_cell_tensor():
    lam = torch.linspace(400, 700, 7, dtype=F64)
    c = t64([1.0, 0.5])[:, None]
    N = torch.tensor([1, 10, 100])[:, None, None]
    R = ti.bragg_reflectance(lam, c, 1.0, 1.5, 125.0, 375.0, N)
    assert R.shape == (3, 2, 7)
    for k, n in enumerate((1, 10, 100)):
        assert torch.equal(R[k], ti.bragg_reflectance(lam, c, 1.0, 1.5, 125.0, 375.0, n))


def test_dtype_follows_inputs():
    R32 = ti.bragg_reflectance(torch.tensor([500.0]), 1.0, 1.0, 1.5, 125.0, 375.0, 20)
    R64 = ti.bragg_reflectance(t64([500.0]), 1.0, 1.0, 1.5, 125.0, 375.0, 20)
    assert R32.dtype == torch.float32 and R64.dtype == torch.float64


def test_float32_accuracy_and_range():
    rng = np.random.default_rng(9)
    worst = 0.0
    for mode in ("n1", "host", "tir"):
        P = _random_mirrors(rng, 400, mode)
        P["N"] = rng.integers(1, 101, 400)
        R32 = _ours(P, "unpolarized", torch.float32)
        R64 = _ours(P, "unpolarized", F64)
        assert torch.isfinite(R32).all() and (R32 >= 0).all() and (R32 <= 1).all()
        worst = max(worst, float((R32.double() - R64).abs().max()))
    assert worst <= 1e-3


def test_float32_at_band_edges_finite_and_accurate():
    c, n1, n2, d1, d2 = 0.8, 1.0, 1.5, 125.0, 375.0
    for pol in ("s", "p"):
        lam = torch.tensor(_band_edges(c, n1, n2, d1, d2, pol, count=2), dtype=F64)
        lam = torch.cat([lam, lam - 1e-7, lam + 1e-7])
        for N in (20, 100, 10**6):
            R32 = ti.bragg_reflectance(lam.float(), torch.tensor(c), n1, n2, d1, d2, N, polarization=pol)
            assert torch.isfinite(R32).all() and (R32 >= 0).all() and (R32 <= 1).all()
            if N <= 100:
                R64 = ti.bragg_reflectance(lam.float().double(), t64(c), n1, n2, d1, d2, N, polarization=pol)
                assert (R32.double() - R64).abs().max() <= 1e-3


def test_float32_hard_cases_finite_and_in_range():
    f32 = torch.float32
    lam = torch.linspace(380, 780, 401, dtype=f32)
    c = torch.tensor([0.0, 1e-7, 0.3, 0.8320503, 1.0], dtype=f32)[:, None]  # incl. Brewster (p)
    for N in (1, 20, 100, 10**4, 10**6):
        for host in (None, 1.33, 2.4):
            for pol in ("s", "p"):
                R = ti.bragg_reflectance(lam, c, 1.0, 1.5, 125.0, 375.0, N, n_incident=host, polarization=pol)
                assert torch.isfinite(R).all() and (R >= 0).all() and (R <= 1).all()


# ---------------------------------------------------------------------------------------
# gradients
# ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("host", [None, 1.33])
def test_gradcheck_interior(host):
    args = [t64(v).requires_grad_() for v in ([455.0, 612.0], [0.83, 0.41], 1.05, 1.55, 131.0, 352.0)]

    def f(lam, c, n1, n2, d1, d2):
        return ti.bragg_reflectance(lam, c, n1, n2, d1, d2, 13, n_incident=host, polarization="unpolarized")

    assert torch.autograd.gradcheck(f, args, eps=1e-6, atol=1e-6, rtol=1e-5)


def test_gradcheck_general_path():
    # total internal reflection in n2: the scattering-matrix path
    args = [t64(v).requires_grad_() for v in ([455.0], [0.5], 1.6, 1.2, 131.0, 52.0)]

    def f(lam, c, n1, n2, d1, d2):
        return ti.bragg_reflectance(lam, c, n1, n2, d1, d2, 7, polarization="s")

    assert torch.autograd.gradcheck(f, args, eps=1e-6, atol=1e-6, rtol=1e-5)


def _hard_cases():
    n1, n2, d1, d2 = 1.0, 1.5, 125.0, 375.0
    edges = _band_edges(0.8, n1, n2, d1, d2, "s", count=1)
    cases = [
        dict(lam=500.0, c=0.0),  # grazing
        dict(lam=500.0, c=1.0),  # normal incidence
        dict(lam=500.0, c=math.cos(math.atan(n2 / n1))),  # Brewster
        dict(lam=500.0, c=0.7, N=10**6),  # huge N
        dict(lam=500.0, c=0.7, d1=0.0),  # zero thickness
        dict(lam=500.0, c=0.3, n_incident=2.4),  # every layer evanescent
        dict(lam=500.0, c=0.6, n1=1.6, n2=1.2),  # evanescent in n2
        dict(lam=600.0, c=1.0, d1=150.0, d2=100.0, N=10**6),  # quarter-wave stack, deep in the gap
    ]
    for e in edges:
        for dl in (0.0, -1e-7, 1e-7):
            cases.append(dict(lam=e + dl, c=0.8))
            cases.append(dict(lam=e + dl, c=0.8, N=10**6))
    out = []
    for case in cases:
        p = dict(n1=n1, n2=n2, d1=d1, d2=d2, N=20, n_incident=None)
        p.update(case)
        out.append(p)
    return out


@pytest.mark.parametrize("pol", ["s", "p"])
def test_gradients_finite_at_hard_cases(pol):
    for p in _hard_cases():
        leaves = {k: t64(p[k]).requires_grad_() for k in ("lam", "c", "n1", "n2", "d1", "d2")}
        R = ti.bragg_reflectance(leaves["lam"], leaves["c"], leaves["n1"], leaves["n2"], leaves["d1"],
                                 leaves["d2"], p["N"], n_incident=p["n_incident"], polarization=pol)
        R.backward()
        for k, v in leaves.items():
            assert v.grad is not None and torch.isfinite(v.grad).all(), (p, k, v.grad)


# ---------------------------------------------------------------------------------------
# property test over the whole parameter domain
# ---------------------------------------------------------------------------------------
# Thicknesses are 0 or ≥ 1e-6 nm and cosines 0 or ≥ 1e-6. Exactly at grazing, a film thinner
# than that rounds to e^{2iφ} = 1 in the recursion, where the answer is a 0/0 limit (R → 1 for
# any d > 0, R = 0 for d = 0). Within ~1e-7 of grazing, the *recursion* (multilayer, like tmm)
# works with Fresnel amplitudes within ~cos θ of ±1 and loses ~ε / cos θ (1.5e-9 at
# cos θ = 1e-9 with a 1e-6 nm film), while the closed form stays exact (checked vs mpmath).
_thickness = st.one_of(st.just(0.0), st.floats(1e-6, 800))
_cosine = st.one_of(st.just(0.0), st.floats(1e-6, 1))


@settings(max_examples=60, deadline=None, derandomize=True)
@given(
    lam=st.floats(300, 1000), c=_cosine, n1=st.floats(1.0, 2.5), n2=st.floats(1.0, 2.5),
    d1=_thickness, d2=_thickness, N=st.integers(1, 25),
    host=st.one_of(st.none(), st.floats(1.0, 2.5)), pol=st.sampled_from(["s", "p", "unpolarized"]),
)
def test_property_closed_form_equals_recursion(lam, c, n1, n2, d1, d2, N, host, pol):
    # Indices equal or ≥ 1e-6 apart: a medium within ~1e-16 of the host index is at its
    # critical angle to within rounding (q = √(n² − s²) ~ 1e-8), where the recursion — not the
    # closed form — loses ~√ε (the documented near-critical limitation of multilayer).
    h = n1 if host is None else host
    assume(all(a == b or abs(a - b) > 1e-6 for a, b in ((h, n1), (h, n2), (n1, n2))))
    R = ti.bragg_reflectance(t64(lam), t64(c), n1, n2, d1, d2, N, n_incident=host, polarization=pol)
    idx, d = bragg_stack(n1, n2, d1, d2, N, n_incident=host)
    Rm, _ = ti.multilayer(t64(lam), t64(c), t64(idx), t64(d), polarization=pol)
    assert 0 <= float(R) <= 1
    assert abs(float(R) - float(Rm)) <= 1e-9


@pytest.mark.parametrize("pol", ["s", "p"])
@pytest.mark.parametrize("n1", [1.5, 1.5 + 0.01j], ids=["real path", "scattering path"])
def test_n2_exactly_at_its_critical_angle(pol, n1):
    # host 1.25, cos θ = 0.6: s² = 1.25² · 0.64 = 1 = n2² exactly, q2 = 0 (b = 0, η2 = 0):
    # the closed form takes sin b / q2 → k0 d2, the scattering path the slab's exact limit
    n1t = torch.tensor(n1, dtype=torch.complex128) if isinstance(n1, complex) else n1
    for N in (1, 3, 40):
        R = ti.bragg_reflectance(t64(500.0), t64(0.6), n1t, 1.0, 30.0, 80.0, N, n_incident=1.25, polarization=pol)
        ref = mpmath_bragg_R(500.0, 0.6, n1, 1.0, 30.0, 80.0, N, n_incident=1.25, polarization=pol)
        assert abs(float(R) - ref) <= 1e-12


def test_host_equal_to_n1_takes_the_plain_path_and_keeps_gradients():
    lam = torch.linspace(400.0, 700.0, 31, dtype=torch.float64)
    c = torch.linspace(0.0, 1.0, 7, dtype=torch.float64)[:, None]
    plain = ti.bragg_reflectance(lam, c, 1.33, 1.5, 100.0, 150.0, 20)
    assert torch.equal(ti.bragg_reflectance(lam, c, 1.33, 1.5, 100.0, 150.0, 20, n_incident=1.33), plain)
    # through appendix D's host layer (n_incident ≠ n1, or carrying a gradient) it is the same to ~1e-15
    nh = torch.tensor(1.33, dtype=torch.float64, requires_grad=True)
    R = ti.bragg_reflectance(lam, c, 1.33, 1.5, 100.0, 150.0, 20, n_incident=nh)
    assert torch.allclose(R, plain, rtol=0, atol=1e-13)
    (g,) = torch.autograd.grad(R.sum(), nh)  # (grazing incidence, R ≡ 1, is in the batch: no NaN)
    h = 1e-7
    fd = (ti.bragg_reflectance(lam, c, 1.33, 1.5, 100.0, 150.0, 20, n_incident=1.33 + h)
          - ti.bragg_reflectance(lam, c, 1.33, 1.5, 100.0, 150.0, 20, n_incident=1.33 - h)).sum() / (2 * h)
    # (the derivative at n_incident = n1 used to miss Snell's law and the host interface: 0 at normal incidence)
    assert torch.isfinite(g) and abs(float(g) - float(fd)) <= 1e-5 * abs(float(fd))
    # a host with its own shape broadcasts the batch as before
    assert ti.bragg_reflectance(lam, 1.0, 1.33, 1.5, 100.0, 150.0, 20, n_incident=torch.full((3, 1), 1.33,
                                dtype=torch.float64)).shape == (3, 31)


@pytest.mark.parametrize("host_mode", ["n1", "host", "tir"])
@pytest.mark.parametrize("pol", ["s", "p", "unpolarized"])
def test_one_point_calls_equal_the_batch(host_mode, pol):
    """A one-point call (its own small-call path: s and p in one pass, one branch of Yeh's kernel,
    the guards read back) gives the batch's value for that point."""
    rng = np.random.default_rng(7)
    P = _random_mirrors(rng, 60, host_mode)
    P["c"][::6] = 0.0  # grazing points too
    nh = None if P["nh"] is None else t64(P["nh"])
    batch = ti.bragg_reflectance(t64(P["lam"]), t64(P["c"]), t64(P["n1"]), t64(P["n2"]), t64(P["d1"]),
                                 t64(P["d2"]), torch.as_tensor(P["N"]), n_incident=nh, polarization=pol)
    for i in range(60):
        one = ti.bragg_reflectance(t64(P["lam"][i]), float(P["c"][i]), float(P["n1"][i]), float(P["n2"][i]),
                                   float(P["d1"][i]), float(P["d2"][i]), int(P["N"][i]),
                                   n_incident=None if nh is None else float(P["nh"][i]), polarization=pol)
        assert abs(float(one) - float(batch[i])) <= 1e-13, i


def test_nan_elsewhere_in_the_batch_does_not_hide_a_grazing_point():
    # (the closed form chose its guarded branch from the batch's minimum q, which a NaN made NaN)
    lam = t64(550.0)
    for nh in (None, 1.2):
        R = ti.bragg_reflectance(lam, t64([float("nan"), 0.0, 0.5]), 1.0, 1.5, 125.0, 375.0, 20, n_incident=nh)
        alone = ti.bragg_reflectance(lam, t64([0.0, 0.5]), 1.0, 1.5, 125.0, 375.0, 20, n_incident=nh)
        assert torch.isnan(R[0]) and float(R[1]) == 1.0
        torch.testing.assert_close(R[1:], alone, rtol=1e-14, atol=0)
