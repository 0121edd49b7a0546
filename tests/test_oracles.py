"""Self-checks of tests/oracles.py: the independent references must agree with each other.

mpmath (characteristic matrices, binary powers) vs tmm (interface/propagation matrices)
on small random stacks; quarter-wave closed form vs mpmath; mpmath huge-N powers vs the
Cayley-Hamilton / Chebyshev form; materials and Hirayama data sanity.
"""

import math

import mpmath
import numpy as np
import pytest

import oracles
from oracles import (
    HIRAYAMA_FIG8,
    HIRAYAMA_TABLE1,
    bragg_stack,
    hirayama_stack,
    material_nk,
    mpmath_bragg_R,
    mpmath_bragg_RT,
    mpmath_stack_RT,
    quarter_wave_R,
    quarter_wave_T,
    tmm_RT,
    tmm_RT_grid,
)

POLS = ("s", "p", "unpolarized")


def _random_bragg_cases(seed, count, *, complex_n, tir):
    """Random small Bragg stacks: (wavelength, cos_theta, n1, n2, d1, d2, cells, n_incident)."""
    rng = np.random.default_rng(seed)
    cases = []
    for _ in range(count):
        n1 = rng.uniform(1.2, 2.5)
        n2 = rng.uniform(1.2, 3.5)
        if complex_n:
            n1 = n1 + 1j * rng.uniform(0.0, 0.3)
            n2 = n2 + 1j * rng.uniform(0.0, 3.0)
        if tir:
            # host denser than both layers; sinθ0 beyond the largest critical angle
            n_incident = max(abs(n1), abs(n2)) + rng.uniform(0.2, 1.0)
            s_min = max(n1.real if isinstance(n1, complex) else n1,
                        n2.real if isinstance(n2, complex) else n2) / n_incident
            s = rng.uniform(s_min, 1.0)
            cos_theta = math.sqrt(1.0 - s * s)
        else:
            # the incident medium must be real: n_incident = n1 (None) only for real n1
            n_incident = rng.uniform(1.0, 1.8)
            if not complex_n and rng.uniform() < 0.5:
                n_incident = None
            cos_theta = rng.uniform(0.05, 1.0)
        cases.append((rng.uniform(380.0, 780.0), cos_theta, n1, n2,
                      rng.uniform(10.0, 200.0), rng.uniform(10.0, 200.0),
                      int(rng.integers(1, 6)), n_incident))
    return cases


CASES = (
    [("real",) + c for c in _random_bragg_cases(1, 6, complex_n=False, tir=False)]
    + [("complex",) + c for c in _random_bragg_cases(2, 6, complex_n=True, tir=False)]
    + [("tir",) + c for c in _random_bragg_cases(3, 4, complex_n=False, tir=True)]
    + [("tir_complex",) + c for c in _random_bragg_cases(4, 2, complex_n=True, tir=True)]
)


@pytest.mark.parametrize("pol", POLS)
@pytest.mark.parametrize("case", CASES, ids=[f"{c[0]}{i}" for i, c in enumerate(CASES)])
def test_mpmath_bragg_matches_tmm(case, pol):
    _, wl, c, n1, n2, d1, d2, cells, n_incident = case
    indices, thick = bragg_stack(n1, n2, d1, d2, cells, n_incident=n_incident)
    R_tmm, T_tmm = tmm_RT(wl, c, indices, thick, pol)
    R_mp, T_mp = mpmath_bragg_RT(wl, c, n1, n2, d1, d2, cells, n_incident=n_incident, polarization=pol)
    assert abs(R_mp - R_tmm) < 1e-12
    assert abs(T_mp - T_tmm) < 1e-12
    # the general-stack oracle agrees with the Bragg one to far below float precision
    R_st, T_st = mpmath_stack_RT(wl, c, indices, thick, pol, as_mpf=True)
    R_br, T_br = mpmath_bragg_RT(wl, c, n1, n2, d1, d2, cells, n_incident=n_incident,
                                 polarization=pol, as_mpf=True)
    assert abs(R_st - R_br) < mpmath.mpf(10) ** -40
    assert abs(T_st - T_br) < mpmath.mpf(10) ** -40


def test_tir_cases_are_tir():
    """The TIR cases really have an evanescent exit (T = 0) and lossless R = 1."""
    for kind, wl, c, n1, n2, d1, d2, cells, n_incident in CASES:
        if kind != "tir":
            continue
        for pol in ("s", "p"):
            R, T = mpmath_bragg_RT(wl, c, n1, n2, d1, d2, cells, n_incident=n_incident, polarization=pol)
            assert T == 0.0
            assert abs(R - 1.0) < 1e-14
            assert tmm_RT(wl, c, *bragg_stack(n1, n2, d1, d2, cells, n_incident), pol)[1] == 0.0


@pytest.mark.parametrize("pol", ("s", "p"))
def test_lossless_energy_conservation(pol):
    R, T = mpmath_bragg_RT(500.0, 0.6, 1.45, 2.3, 97.0, 61.0, 7, n_incident=1.0, polarization=pol,
                           as_mpf=True)
    assert abs(R + T - 1) < mpmath.mpf(10) ** -45


@pytest.mark.parametrize("cells", [0, 1, 2, 7, 40])
@pytest.mark.parametrize("n_incident", [None, 1.0])
def test_quarter_wave_closed_form(cells, n_incident):
    n1, n2, lam0 = 1.38, 2.35, 550.0
    d1, d2 = lam0 / (4 * n1), lam0 / (4 * n2)
    R_mp, T_mp = mpmath_bragg_RT(lam0, 1.0, n1, n2, d1, d2, cells, n_incident=n_incident, as_mpf=True)
    R_qw = quarter_wave_R(n1, n2, cells, n_incident=n_incident, as_mpf=True)
    T_qw = quarter_wave_T(n1, n2, cells, n_incident=n_incident, as_mpf=True)
    assert abs(R_mp - R_qw) < 1e-13
    # relative, resolved even where R rounds to 1 (float thickness rounding ~1e-16 rel.)
    assert abs(T_mp - T_qw) <= 1e-12 * T_qw
    assert abs(float(R_qw) - quarter_wave_R(n1, n2, cells, n_incident=n_incident)) == 0.0


@pytest.mark.parametrize("cells", [10**3, 10**6])
def test_quarter_wave_huge_n(cells):
    """N up to 10**6: R -> 1, T = 1 - R ~ 10**-(huge); compare T in log space."""
    n1, n2, lam0 = 1.5, 2.5, 550.0
    T_mp = mpmath_bragg_RT(lam0, 1.0, n1, n2, lam0 / 6, lam0 / 10, cells, as_mpf=True)[1]
    T_qw = quarter_wave_T(n1, n2, cells, as_mpf=True)
    assert T_qw > 0
    assert abs(mpmath.log(T_mp) - mpmath.log(T_qw)) < 1e-9 * abs(mpmath.log(T_qw))
    assert quarter_wave_R(n1, n2, cells) == 1.0  # float64 rounds it
    # closed form = tanh²(N ln(n2/n1))
    assert abs(quarter_wave_R(n1, n2, 3) - math.tanh(3 * math.log(n2 / n1)) ** 2) < 1e-15


@pytest.mark.parametrize("pol", ("s", "p"))
@pytest.mark.parametrize("n1,n2,wl,c", [
    (1.5, 2.5, 700.0, 0.9),            # pass band, lossless: |cos KΛ| < 1
    (1.5 + 1e-4j, 2.5 + 2e-4j, 430.0, 0.7),  # weakly absorbing
])
def test_binary_power_vs_chebyshev_huge_n(n1, n2, wl, c, pol):
    """M^N = U_{N-1}(a) M - U_{N-2}(a) I (Cayley-Hamilton, det M = 1, a = tr M / 2)."""
    N, d1, d2 = 10**6, 91.0, 55.0
    n_incident = 1.0
    R = mpmath_bragg_R(wl, c, n1, n2, d1, d2, N, n_incident=n_incident, polarization=pol, as_mpf=True)
    with mpmath.workdps(60):
        n1m, n2m = oracles._mpc(n1), oracles._mpc(n2)
        n0 = mpmath.mpf(n_incident)
        cm = mpmath.mpf(c)
        s2 = n0 * n0 * (1 - cm) * (1 + cm)
        k0 = 2 * mpmath.pi / mpmath.mpf(wl)
        M = (oracles._layer_matrix(n2m, mpmath.mpf(d2), s2, k0, pol)
             * oracles._layer_matrix(n1m, mpmath.mpf(d1), s2, k0, pol))
        t = mpmath.acos((M[0, 0] + M[1, 1]) / 2)

        def U(k):  # Chebyshev U_k(cos t) = sin((k+1)t)/sin t
            return mpmath.sin((k + 1) * t) / mpmath.sin(t)

        MN = U(N - 1) * M - U(N - 2) * mpmath.eye(2)
        eta = oracles._admittance(n1m, oracles._q(n1m, s2), pol)
        eta0 = oracles._admittance(n0, n0 * cm, pol)
        R_ch, _ = oracles._r_t_from_matrix(MN, eta0, eta, n1m)
    assert abs(R - R_ch) < 1e-35  # measured ~1e-45 (pass band) at dps=50


def test_bragg_stack_layout():
    idx, th = bragg_stack(1.5, 2.5, 90.0, 50.0, 3, n_incident=1.0)
    assert idx == [1.0, 2.5, 1.5, 2.5, 1.5, 2.5, 1.5, 1.5]
    assert th == [50.0, 90.0] * 3
    idx, th = bragg_stack(1.5, 2.5, 90.0, 50.0, 0)
    assert idx == [1.5, 1.5] and th == []


def test_tmm_conventions():
    # bare interface at normal incidence
    R, T = tmm_RT(500.0, 1.0, [1.0, 1.5], [], "s")
    assert abs(R - 0.04) < 1e-15 and abs(T - 0.96) < 1e-15
    # absorbing exit medium under a lossless film: T is the power entering it, 1 - R
    R, T = tmm_RT(500.0, 0.8, [1.0, 1.4, 0.2 + 3.0j], [100.0], "p")
    assert 0.0 < R < 1.0 and abs(T - (1 - R)) < 1e-12
    assert T == oracles.tmm_coh(500.0, 0.8, [1.0, 1.4, 0.2 + 3.0j], [100.0], "p")["T"]
    # grazing incidence: R = 1
    for pol in ("s", "p"):
        assert abs(tmm_RT(500.0, 0.0, [1.0, 1.5, 1.2], [100.0], pol)[0] - 1.0) < 1e-12
        assert abs(mpmath_stack_RT(500.0, 0.0, [1.0, 1.5, 1.2], [100.0], pol)[0] - 1.0) < 1e-30
    with pytest.raises(ValueError):
        tmm_RT(500.0, 1.0, [1.0, 1.5], [], "x")
    with pytest.raises(ValueError):
        mpmath_bragg_R(500.0, 1.0, 1.5, 2.5, 90.0, 50.0, 2, n_incident=1.0 + 0.1j)


def test_tmm_grid_broadcasts():
    wl = np.linspace(400.0, 700.0, 4)
    c = np.array([[1.0], [0.5]])
    R, T = tmm_RT_grid(wl, c, [1.0, 1.45, 1.52], [300.0], "unpolarized")
    assert R.shape == (2, 4) and T.shape == (2, 4)
    assert abs(R[1, 2] - tmm_RT(wl[2], 0.5, [1.0, 1.45, 1.52], [300.0], "unpolarized")[0]) == 0
    assert np.allclose(R + T, 1.0, atol=1e-14)


def test_materials_offline():
    wl = np.linspace(380.0, 780.0, 41)
    for name in ("Ag", "Au", "Cu", "Al", "Si", "W"):
        nk = material_nk(name, wl)
        assert nk.shape == wl.shape and nk.dtype == complex
        assert np.all(np.isfinite(nk)) and np.all(nk.imag >= 0) and np.all(nk.real > 0)
    # Johnson & Christy 1972 table points (eV 2.26 = 548.6 nm): Ag 0.059+3.586i, Au 0.43+2.455i
    assert abs(complex(material_nk("silver", 1239.84193 / 2.26)) - (0.059 + 3.586j)) < 2e-3
    assert abs(complex(material_nk("gold", 1239.84193 / 2.26)) - (0.43 + 2.455j)) < 2e-3
    assert material_nk("Au", 550.0).shape == ()
    with pytest.raises(ValueError):
        material_nk("unobtainium", 550.0)
    with pytest.raises(ValueError):
        material_nk("Si", 100.0)  # Green 2008 starts at 250 nm


@pytest.mark.parametrize("entry", HIRAYAMA_TABLE1 + HIRAYAMA_FIG8, ids=lambda e: e["name"])
def test_hirayama_stacks_tmm_vs_mpmath(entry):
    for wl, c in ((450.0, 1.0), (633.0, 0.4)):
        idx, th = hirayama_stack(entry, wl)
        for pol in ("s", "p"):
            R_t, T_t = tmm_RT(wl, c, idx, th, pol)
            R_m, T_m = mpmath_stack_RT(wl, c, idx, th, pol)
            assert abs(R_t - R_m) < 1e-12
            assert abs(T_t - T_m) < 1e-12  # the power entering the metal / silicon substrate
            assert 0.0 < R_m < 1.0 and 0.0 <= T_m <= 1.0 - R_m + 1e-15


def test_hirayama_table1_content():
    names = [e["name"] for e in HIRAYAMA_TABLE1]
    assert names == ["teapot", "cylinder", "sphere"]
    assert [e["substrate"] for e in HIRAYAMA_TABLE1] == ["Al", "Si", "Cu"]
    assert sum(d for _, d in HIRAYAMA_TABLE1[1]["layers"]) == 4000.0
