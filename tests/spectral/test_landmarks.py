"""Spectral landmarks against a dense scan of the dispersion relation."""

import math

import numpy as np
import pytest
import torch

import torchirid as ti
from tensors import F64, t64
from torchirid.spectral import bragg_landmarks
from torchirid.spectral.landmarks import dispersion_parts

W_MIN, W_MAX = 2 * math.pi / 780, 2 * math.pi / 380


def _setup(c, n1, n2, d1, d2, pol):
    q1 = n1 * c
    q2 = math.sqrt(n2 ** 2 - n1 ** 2 * (1 - c ** 2))
    e1, e2 = (q1, q2) if pol == "s" else (q1 / n1 ** 2, q2 / n2 ** 2)
    return q1 * d1, q2 * d2, (e1 - e2) ** 2 / (2 * e1 * e2)


def _finite(t):
    return np.sort(t[~torch.isnan(t)].numpy())


def test_landmarks_match_a_dense_scan():
    rng = np.random.default_rng(2)
    omega = torch.linspace(W_MIN, W_MAX, 200001, dtype=F64)
    step = float(omega[1] - omega[0])
    for _ in range(12):
        n2, lam_, f, c = rng.uniform(1.2, 2.4), rng.uniform(150, 1000), rng.uniform(0.1, 0.9), rng.uniform(0.05, 1)
        d1, d2 = f * lam_, (1 - f) * lam_
        for pol in ("s", "p"):
            A, B, delta = _setup(c, 1.0, n2, d1, d2, pol)
            L = bragg_landmarks(W_MIN, W_MAX, t64(A), t64(B), t64(delta), iterations=40)
            x = ti.optics.bragg_dispersion(2 * math.pi / omega, t64(c), 1.0, n2, d1, d2, polarization=pol)
            airy_scan = omega[:-1][torch.sign(x[1:]) != torch.sign(x[:-1])].numpy()
            gap = (x.abs() > 1).int()
            edge_scan = omega[:-1][gap[1:] != gap[:-1]].numpy()
            airy = _finite(L["airy"])
            edges = _finite(torch.cat([L["edges_lo"], L["edges_hi"]]))
            edges = edges[(edges > W_MIN) & (edges < W_MAX)]  # drop gaps clipped at the range ends
            assert len(airy) == len(airy_scan) and np.abs(airy - airy_scan).max(initial=0) <= step
            assert len(edges) == len(edge_scan) and np.abs(edges - edge_scan).max(initial=0) <= step


def test_modes_lie_in_band_gaps_and_zero_points_kill_the_envelope():
    A, B, delta = _setup(0.7, 1.0, 1.6, 300.0, 200.0, "s")
    L = bragg_landmarks(W_MIN, W_MAX, t64(A), t64(B), t64(delta))
    modes = torch.tensor(_finite(L["modes"]), dtype=F64)
    omx, opx = dispersion_parts(modes, A, B, delta)
    assert (torch.minimum(omx, opx) <= 1e-12).all()  # |cos KΛ| ≥ 1 at every mode (appendix A)
    zeros = _finite(L["zeros"])
    assert len(zeros) > 0
    Re = ti.optics.bragg_envelope(t64(2 * math.pi / zeros), t64(0.7), 1.0, 1.6, 300.0, 200.0, polarization="s")
    assert Re.abs().max() <= 1e-20


def test_gaps_close_at_brewster_for_p():
    c = math.cos(math.atan(1.5))
    A, B, delta = _setup(c, 1.0, 1.5, 200.0, 300.0, "p")
    assert abs(delta) < 1e-15
    L = bragg_landmarks(W_MIN, W_MAX, t64(A), t64(B), t64(delta))
    ok = ~torch.isnan(L["modes"])
    assert torch.equal(L["edges_lo"][ok], L["modes"][ok]) and torch.equal(L["edges_hi"][ok], L["modes"][ok])


def test_batched_over_angles_equals_one_by_one():
    cs = [0.2, 0.6, 1.0]
    ABd = [_setup(c, 1.0, 1.7, 250.0, 180.0, "s") for c in cs]
    A, B, delta = (t64([v[k] for v in ABd]) for k in range(3))
    L = bragg_landmarks(W_MIN, W_MAX, A, B, delta)
    for i, (a, b, d) in enumerate(ABd):
        Li = bragg_landmarks(W_MIN, W_MAX, t64(a), t64(b), t64(d))
        for key in ("airy", "edges_lo", "edges_hi", "zeros"):
            assert np.allclose(_finite(L[key][i]), _finite(Li[key]), rtol=0, atol=1e-12)


def test_default_iterations_are_accurate_enough():
    # the default: 5 Newton steps in the a-priori brackets (no halvings): landmarks at machine precision
    A = torch.linspace(50, 900, 60, dtype=F64)
    B = torch.linspace(900, 60, 60, dtype=F64)
    d = torch.full_like(A, 0.08)
    ref = bragg_landmarks(W_MIN, W_MAX, A, B, d, iterations=60)
    got = bragg_landmarks(W_MIN, W_MAX, A, B, d)
    for k in ("airy", "edges_lo", "edges_hi"):
        rel = torch.nan_to_num((got[k] - ref[k]).abs() / ref[k].abs(), nan=0.0)
        assert rel.max() <= 1e-12


def test_default_iterations_hold_at_grazing_and_large_contrast():
    # worst cases of the bisection: grazing incidence (A → 0, δ → ∞ for s and p) and strong contrast
    c = torch.cos(torch.deg2rad(torch.tensor([0.0, 60.0, 85.0, 89.0, 89.9, 89.99], dtype=F64)))
    rows = []
    for n2, period, f in ((1.5, 244.0, 0.1), (1.5, 988.0, 0.9), (2.4, 500.0, 0.05), (1.2, 1000.0, 0.5)):
        for pol in ("s", "p"):
            for ci in c.tolist():
                rows.append(_setup(ci, 1.0, n2, f * period, (1 - f) * period, pol))
    A, B, d = (t64([r[k] for r in rows]) for k in range(3))
    ref = bragg_landmarks(W_MIN, W_MAX, A, B, d, iterations=60)
    got = bragg_landmarks(W_MIN, W_MAX, A, B, d)
    for k in ("airy", "edges_lo", "edges_hi"):
        assert torch.equal(torch.isnan(got[k]), torch.isnan(ref[k]))
        rel = torch.nan_to_num((got[k] - ref[k]).abs() / ref[k].abs(), nan=0.0)
        assert rel.max() <= 1e-9


def test_default_iterations_hold_at_extreme_grazing():
    # cos θ down to 1e-6 (δ up to ~1e10, k → 1, γ → −1: the edges and Airy points are ill-conditioned)
    rng = np.random.default_rng(3)
    rows = []
    for _ in range(1500):
        n2, period, f = rng.uniform(1.01, 4.0), rng.uniform(100, 1100), rng.uniform(0.02, 0.98)
        c = max(rng.uniform() ** 3, 1e-6)
        rows.append(_setup(c, 1.0, n2, f * period, (1 - f) * period, "s" if rng.uniform() < 0.5 else "p"))
    A, B, d = (t64([r[k] for r in rows]) for k in range(3))
    ref = bragg_landmarks(W_MIN, W_MAX, A, B, d, iterations=80, newton_steps=0)  # plain bisection
    got = bragg_landmarks(W_MIN, W_MAX, A, B, d)
    for k in ("airy", "edges_lo", "edges_hi"):
        assert torch.equal(torch.isnan(got[k]), torch.isnan(ref[k]))
        rel = torch.nan_to_num((got[k] - ref[k]).abs() / ref[k].abs(), nan=0.0)
        assert rel.max() <= 1e-6


def test_gaps_closed_by_the_layers_sit_on_their_modes():
    # A = B (γ = 0): every even-order gap closes (sin(γφ/2) = 0 at the mode), the odd ones stay open
    L = bragg_landmarks(W_MIN, W_MAX, t64([200.0]), t64([200.0]), t64([0.08]))
    even = (L["m"] % 2 == 0) & ~torch.isnan(L["modes"])
    assert even.any()
    assert torch.equal(L["edges_lo"][even], L["modes"][even]) and torch.equal(L["edges_hi"][even], L["modes"][even])
    L = bragg_landmarks(W_MIN, W_MAX, t64([150.0]), t64([150.0]), t64([0.08]))  # mode 1 at 600 nm: open
    ok = ~torch.isnan(L["modes"])
    assert (L["edges_hi"][ok] - L["edges_lo"][ok] > 1e-4).all()


def test_iteration_counts_are_validated():
    with pytest.raises(ValueError, match="newton_steps"):
        bragg_landmarks(W_MIN, W_MAX, t64([200.0]), t64([150.0]), t64([0.08]), newton_steps=-1)
    with pytest.raises(ValueError, match="iterations"):
        bragg_landmarks(W_MIN, W_MAX, t64([200.0]), t64([150.0]), t64([0.08]), iterations=2.5)
