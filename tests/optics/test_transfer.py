"""Tests of torchirid.multilayer (Hirayama 2000 recursion): R and T of a smooth stack.

References: the ``tmm`` package (oracles.tmm_RT / tmm_RT_grid) on random and tabulated-metal
stacks, Hirayama's Table 1 stacks, the 50-digit characteristic-matrix reference
(oracles.mpmath_stack_RT) where tmm's angle round trip is not accurate enough (exact
grazing) or tmm clamps opaque layers (thick metals), fresnel_reflectance for L = 0 and for
the bulk of thick absorbers; physics properties (R + T = 1, reciprocity, d → 0, invisible
layers), shapes, dtypes, gradients (gradcheck + finite at the hard cases), NaN.

T convention (tmm's): the power that crosses the last interface into the exit medium, absorbing
or not; 0 for an evanescent exit wave.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

import torchirid
from oracles import HIRAYAMA_TABLE1, hirayama_stack, material_nk, mpmath_stack_RT, tmm_RT, tmm_RT_grid

from tensors import C128, F64, METALS, POLS, t64, tc128  # noqa: F401


def ml(wl, c, idx, d, pol="unpolarized"):
    return torchirid.multilayer(t64(wl), t64(c), tc128(idx), t64(d), polarization=pol)


def _reference(wl, c, idx, d, pol):
    """tmm, except exactly at grazing: there tmm sees cos(arccos 0) = 6e-17, which a
    guided-mode resonance can amplify to ~1e-9 in R; mpmath takes the exact cosine."""
    if c == 0.0:
        return mpmath_stack_RT(wl, c, list(idx), list(d), pol)
    return tmm_RT(wl, c, list(idx), list(d), pol)


# ----------------------------------------------------------------------------------------
# random stacks vs tmm
# ----------------------------------------------------------------------------------------
def _random_stacks(L, B, seed, kind):
    g = np.random.default_rng(seed)
    wl = g.uniform(380.0, 780.0, B)
    c = g.uniform(0.0, 1.0, B)
    c[0] = 0.0
    c[1] = 1.0
    n0 = np.where(g.random(B) < 0.5, 1.0, g.uniform(1.0, 1.7, B))
    layers = g.uniform(1.2, 2.5, (B, L)) + 0j
    d = g.uniform(0.0, 500.0, (B, L))
    if L:
        d[2, 0] = 0.0
    exit_ = g.uniform(1.0, 2.0, B) + 0j
    if kind == "absorbing":  # complex layers (κ up to 0.6) and complex exit media
        layers += 1j * g.uniform(0.0, 0.6, (B, L)) * (g.random((B, L)) < 0.6)
        exit_ += 1j * g.uniform(0.0, 0.5, B) * (g.random(B) < 0.5)
    elif kind == "metal":  # thin metal / silicon layers, metal exit
        for b in range(B):
            for j in range(L):
                if g.random() < 0.4:
                    layers[b, j] = complex(material_nk(METALS[(b + j) % 5], wl[b]))
                    d[b, j] = g.uniform(0.0, 40.0)
            exit_[b] = complex(material_nk(METALS[b % 5], wl[b]))
    elif kind == "tir":  # dense incident medium, steep angles: evanescent layers / exit
        n0 = g.uniform(1.8, 2.2, B)
        layers = g.uniform(1.2, 2.4, (B, L)) + 0j
        exit_ = g.uniform(1.0, 1.6, B) + 1j * g.uniform(0.0, 0.02, B) * (g.random(B) < 0.3)
        c = g.uniform(0.0, 0.6, B)
        c[0] = 0.0
    idx = np.concatenate([n0[:, None] + 0j, layers, exit_[:, None]], axis=1)
    return wl, c, idx, d


@pytest.mark.parametrize("kind", ["lossless", "absorbing", "metal", "tir"])
@pytest.mark.parametrize("L", range(0, 7))
def test_vs_tmm_random_stacks(L, kind):
    B = 9
    wl, c, idx, d = _random_stacks(L, B, seed=1000 * L + len(kind), kind=kind)
    for pol in POLS:
        R, T = ml(wl, c, idx, d, pol)  # one batched call per polarization
        assert R.shape == T.shape == (B,)
        ref = np.array([_reference(wl[b], c[b], idx[b], d[b], pol) for b in range(B)])
        dR = np.abs(R.numpy() - ref[:, 0]).max()
        dT = np.abs(T.numpy() - ref[:, 1]).max()
        assert dR <= 1e-9 and dT <= 1e-9, (pol, dR, dT)


_METAL_STACKS = [
    # (incident, [(layer, d)], exit)
    (1.0, [(1.38, 100.0), ("Ag", 20.0), (1.5, 80.0)], "Au"),
    (1.0, [("Al", 10.0), (1.6, 200.0)], "Cu"),
    (1.33, [("Si", 30.0), (1.45, 150.0)], 1.5),
    (1.0, [("Au", 40.0)], 1.5),
    (1.0, [(2.0, 50.0), ("Cu", 15.0), (1.4, 300.0)], "Si"),
    (1.0, [("Ag", 8.0), ("Au", 6.0), ("Al", 3.0)], 1.52),
]


@pytest.mark.parametrize("stack", range(len(_METAL_STACKS)))
def test_vs_tmm_metal_stacks(stack):
    inc, layers, ex = _METAL_STACKS[stack]
    wl = np.linspace(380.0, 780.0, 9)

    def nk(m):
        return material_nk(m, wl) if isinstance(m, str) else np.full(wl.shape, m, dtype=complex)

    idx = np.stack([nk(inc)] + [nk(m) for m, _ in layers] + [nk(ex)], axis=-1)  # (W, L+2)
    d = np.array([t for _, t in layers])
    c = np.array([1.0, 0.7, 0.35, 0.05])[:, None]
    for pol in ("s", "p"):
        R, T = ml(wl, c, idx, d, pol)
        assert R.shape == (4, wl.size)
        Rr, Tr = tmm_RT_grid(wl[None, :], c, [idx[:, j] for j in range(idx.shape[1])], list(d), pol)
        assert np.abs(R.numpy() - Rr).max() <= 1e-9
        assert np.abs(T.numpy() - Tr).max() <= 1e-9


@pytest.mark.parametrize("entry", HIRAYAMA_TABLE1, ids=[e["name"] for e in HIRAYAMA_TABLE1])
def test_hirayama_table1(entry):
    wl = np.linspace(380.0, 780.0, 41)
    indices, thick = hirayama_stack(entry, wl)
    idx = np.stack([np.broadcast_to(np.asarray(n, dtype=complex), wl.shape) for n in indices], axis=-1)
    c = np.array([1.0, 0.7, 0.3, 0.05])[:, None]
    out = {}
    for pol in ("s", "p"):
        R, T = ml(wl, c, idx, thick, pol)
        Rr, Tr = tmm_RT_grid(wl[None, :], c, indices, thick, pol)
        assert np.abs(R.numpy() - Rr).max() <= 1e-9
        assert np.abs(T.numpy() - Tr).max() <= 1e-9
        assert T.min() >= 0 and (R + T).max() <= 1 + 1e-12  # the power entering the metal / silicon
        out[pol] = R
    Ru, _ = ml(wl, c, idx, thick, "unpolarized")
    assert (Ru - 0.5 * (out["s"] + out["p"])).abs().max().item() <= 1e-15
    # a second, independent reference at a few points (50 digits)
    for w in (0, 17, 40):
        for ai in (0, 2):
            for pol in ("s", "p"):
                Rm, _ = mpmath_stack_RT(wl[w], c[ai, 0], list(idx[w]), thick, pol)
                assert abs(out[pol][ai, w].item() - Rm) <= 1e-12


# ----------------------------------------------------------------------------------------
# thick absorbers: bulk reflectance, no transmission, finite everything
# ----------------------------------------------------------------------------------------
_THICK = [("W", 1000.0), ("Au", 2000.0), ("Au", 10000.0)]
_COS = [0.0, 0.05, 0.3, 0.7, 1.0]


@pytest.mark.parametrize("metal,d", _THICK)
@pytest.mark.parametrize("exit_medium", ["glass", "Cu"])
def test_thick_absorber_is_bulk(metal, d, exit_medium):
    wl = np.array([380.0, 550.0, 780.0])
    nm = material_nk(metal, wl)
    ex = np.full(3, 1.5 + 0j) if exit_medium == "glass" else material_nk("Cu", wl)
    idx = np.stack([np.ones(3, dtype=complex), nm, ex], axis=-1)
    c = np.array(_COS)[:, None]
    for pol in POLS:
        R, T = ml(wl, c, idx, [d], pol)
        Rb = torchirid.optics.fresnel_reflectance(t64(c), 1.0, tc128(nm), polarization=pol)
        assert torch.isfinite(R).all() and torch.isfinite(T).all()
        assert (R - Rb).abs().max().item() <= 1e-12
        # Into glass or Cu the transmitted power is physical, e^{-4πκd/λ}-small: 1 µm W lets
        # ~2e-20 through at 780 nm, 2 µm Au ~1e-49, 10 µm Au < 1e-240 (not 0).
        bound = {1000.0: 1e-18, 2000.0: 1e-48, 10000.0: 1e-240}[d]
        assert T.min().item() >= 0.0 and T.max().item() <= bound
    if exit_medium == "glass" and d < 5000:
        # T itself against the 50-digit reference (tmm clamps opaque layers: not usable)
        for i, w in enumerate(wl):
            R, T = ml(w, 0.3, idx[i], [d], "s")
            Rm, Tm = mpmath_stack_RT(w, 0.3, list(idx[i]), [d], "s")
            assert abs(R.item() - Rm) <= 1e-12
            assert abs(T.item() - Tm) <= 1e-9 * Tm


@pytest.mark.parametrize("dtype", [F64, torch.float32])
@pytest.mark.parametrize("metal,d", _THICK)
def test_thick_absorber_float32_and_gradients(metal, d, dtype):
    cdt = C128 if dtype == F64 else torch.complex64
    wl_np = np.array([380.0, 550.0, 780.0])
    nm = material_nk(metal, wl_np)
    for ex in (1.5 + 0j, complex(material_nk("Cu", 550.0))):
        wl = torch.tensor(wl_np, dtype=dtype, requires_grad=True)
        c = torch.tensor(_COS, dtype=dtype)[:, None].requires_grad_()
        th = torch.tensor([d], dtype=dtype, requires_grad=True)
        idx = torch.stack([torch.ones(3, dtype=cdt), torch.tensor(nm, dtype=cdt),
                           torch.full((3,), ex, dtype=cdt)], dim=-1)
        for pol in POLS:
            R, T = torchirid.multilayer(wl, c, idx, th, polarization=pol)
            assert R.dtype == dtype and R.shape == (5, 3)
            assert torch.isfinite(R).all() and torch.isfinite(T).all()
            assert R.min().item() >= 0.0 and R.max().item() <= 1.0
            assert T.min().item() >= 0.0 and T.max().item() <= 1e-18
            Rb = torchirid.optics.fresnel_reflectance(c.detach(), 1.0, idx[:, 1], polarization=pol)
            tol = 1e-12 if dtype == F64 else 1e-6
            assert (R - Rb).abs().max().item() <= tol
            grads = torch.autograd.grad((R + T).sum(), (wl, c, th))
            for g in grads:
                assert torch.isfinite(g).all()


# ----------------------------------------------------------------------------------------
# physics properties
# ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("L", [1, 2, 3, 6])
def test_energy_conservation_lossless(L):
    g = np.random.default_rng(50 + L)
    B = 400
    n0 = np.where(g.random(B) < 0.5, 1.0, 1.33)
    layers = g.uniform(1.4, 2.5, (B, L))
    ex = g.uniform(1.4, 2.0, B)
    idx = np.concatenate([n0[:, None], layers, ex[:, None]], axis=1)
    d = g.uniform(0.0, 800.0, (B, L))
    wl = g.uniform(380.0, 780.0, B)
    c = g.uniform(0.0, 1.0, B)
    c[:3] = (0.0, 1.0, 1e-9)
    for pol in POLS:
        R, T = torchirid.multilayer(t64(wl), t64(c), t64(idx), t64(d), polarization=pol)
        assert (R + T - 1).abs().max().item() <= 1e-12
        assert R.min().item() >= 0.0 and T.min().item() >= 0.0


@pytest.mark.parametrize("absorbing", [False, True])
def test_reciprocity_of_T(absorbing):
    """T is the same for light from either side at Snell-corresponding angles (n0 sinθ0 = ne sinθe)."""
    g = np.random.default_rng(77 + absorbing)
    B, L = 60, 4
    n0 = np.where(g.random(B) < 0.5, 1.0, 1.2)
    ne = g.uniform(1.3, 1.8, B)
    layers = g.uniform(1.2, 2.4, (B, L)) + 1j * absorbing * g.uniform(0.0, 0.3, (B, L))
    d = g.uniform(0.0, 400.0, (B, L))
    wl = g.uniform(380.0, 780.0, B)
    c0 = g.uniform(0.05, 1.0, B)
    c0[0] = 1.0
    ce = np.sqrt(1.0 - (n0 / ne) ** 2 * (1.0 - c0 * c0))
    fwd = np.concatenate([n0[:, None], layers, ne[:, None]], axis=1)
    bwd = fwd[:, ::-1].copy()
    for pol in POLS:
        Rf, Tf = ml(wl, c0, fwd, d, pol)
        Rb, Tb = ml(wl, ce, bwd, d[:, ::-1].copy(), pol)
        assert Tf.min().item() > 1e-6  # a real, not trivially zero, transmission
        assert (Tf - Tb).abs().max().item() <= 1e-12
        if not absorbing:  # lossless: R is reciprocal too
            assert (Rf - Rb).abs().max().item() <= 1e-12


@pytest.mark.parametrize("pol", POLS)
def test_zero_thickness_layer_is_removed(pol):
    g = np.random.default_rng(5)
    B, L = 50, 4
    for absorbing in (False, True):
        layers = g.uniform(1.2, 2.4, (B, L)) + 1j * absorbing * g.uniform(0.0, 0.5, (B, L))
        idx = np.concatenate([np.ones((B, 1)), layers, (1.5 + 0.3j * absorbing) * np.ones((B, 1))], axis=1)
        d = g.uniform(10.0, 400.0, (B, L))
        wl = g.uniform(380.0, 780.0, B)
        c = g.uniform(0.01, 1.0, B)
        c[0] = 1.0
        for j in range(L):
            dz = d.copy()
            dz[:, j] = 0.0
            R, T = ml(wl, c, idx, dz, pol)
            R2, T2 = ml(wl, c, np.delete(idx, j + 1, axis=1), np.delete(d, j, axis=1), pol)
            assert (R - R2).abs().max().item() <= 1e-14
            assert (T - T2).abs().max().item() <= 1e-14
            # continuity d -> 0
            dz[:, j] = 1e-6
            R3, T3 = ml(wl, c, idx, dz, pol)
            assert (R3 - R).abs().max().item() < 1e-6 and (T3 - T).abs().max().item() < 1e-6


@pytest.mark.parametrize("pol", POLS)
def test_invisible_and_merged_layers(pol):
    g = np.random.default_rng(9)
    B = 40
    wl = g.uniform(380.0, 780.0, B)
    c = g.uniform(0.0, 1.0, B)
    c[:2] = (0.0, 1.0)
    n0 = np.where(g.random(B) < 0.5, 1.0, 1.33)
    a = g.uniform(1.3, 2.3, B) + 0.1j * (g.random(B) < 0.5)
    b = g.uniform(1.3, 2.3, B)
    for ex in (g.uniform(1.0, 1.7, B) + 0j, material_nk("Ag", wl)):
        base = np.stack([n0 + 0j, a, b + 0j, ex], axis=1)
        dab = np.stack([g.uniform(0, 300, B), g.uniform(0, 300, B)], axis=1)
        R, T = ml(wl, c, base, dab, pol)
        extra = g.uniform(0.0, 2000.0, B)
        # a layer of the incident medium's index in front: invisible
        idx1 = np.concatenate([base[:, :1], n0[:, None], base[:, 1:]], axis=1)
        R1, T1 = ml(wl, c, idx1, np.concatenate([extra[:, None], dab], axis=1), pol)
        # a layer of the exit medium's index at the back: invisible
        idx2 = np.concatenate([base[:, :3], ex[:, None], base[:, 3:]], axis=1)
        R2, T2 = ml(wl, c, idx2, np.concatenate([dab, extra[:, None]], axis=1), pol)
        for Ri in (R1, R2):
            assert (Ri - R).abs().max().item() <= 1e-12
        assert (T1 - T).abs().max().item() <= 1e-12
        if np.all(ex.imag == 0):
            assert (T2 - T).abs().max().item() <= 1e-12
        # two adjacent layers of one index are one layer of the summed thickness
        idx3 = np.stack([n0 + 0j, a, a, b + 0j, ex], axis=1)
        split = g.uniform(0.0, 1.0, B)
        d3 = np.stack([dab[:, 0] * split, dab[:, 0] * (1 - split), dab[:, 1]], axis=1)
        d3[:, 1] = dab[:, 0] - d3[:, 0]
        R3, T3 = ml(wl, c, idx3, d3, pol)
        assert (R3 - R).abs().max().item() <= 1e-12 and (T3 - T).abs().max().item() <= 1e-12


@pytest.mark.parametrize("pol", POLS)
def test_grazing_and_normal_incidence(pol):
    wl = np.linspace(380.0, 780.0, 9)
    stacks = [
        ([1.0, 1.4, 1.5], [300.0]),
        ([1.0, 1.4, 2.1, 1.5], [0.0, 120.0]),
        ([1.0, 2.0 + 0.3j, 1.38, 1.5 + 0.1j], [40.0, 100.0]),
        ([1.33, 1.0, 1.5], [200.0]),
        ([1.0, complex(material_nk("Au", 550.0)), 1.5], [25.0]),
        ([1.5, 1.0], []),
        ([1.0, 1.5], []),
    ]
    for idx, d in stacks:
        R, T = ml(wl, 0.0, np.array(idx, dtype=complex), d, pol)
        assert (R - 1).abs().max().item() <= 1e-14 and (T == 0).all(), (idx, d)
        Rs, Ts = ml(wl, 1.0, np.array(idx, dtype=complex), d, "s")
        Rp, Tp = ml(wl, 1.0, np.array(idx, dtype=complex), d, "p")
        assert (Rs - Rp).abs().max().item() <= 1e-15 and (Ts - Tp).abs().max().item() <= 1e-15


def test_quarter_wave_closed_form():
    """Docstring example: quarter-wave layer of index sqrt(n_s) at its design wavelength."""
    R, T = torchirid.multilayer(t64(600.0), 1.0, t64([1.0, 1.5, 2.25]), t64([100.0]))
    assert R.item() < 1e-30 and abs(T.item() - 1.0) < 1e-15


# Known limitation (stated in docs/performance.md): R and T are smooth in cos θ at a film's
# critical angle (they depend on q_film only through q², cos δ and sin δ / q), but Hirayama's
# recursion works with q itself, computed from q² = n² − s² that carries ~1e-16 of rounding:
# within a few ulps of q = 0 the forward error grows to ~√ε ≈ 1e-8. These tests pin that.
@pytest.mark.parametrize("pol", ["s", "p"])
def test_exact_critical_angle_of_a_layer(pol):
    # n0 = 1.25, layer 1.0, cos θ = 0.6: s² = 1.25² · 0.64 = 1.0 = n_layer² exactly
    R, T = ml(500.0, 0.6, [1.25, 1.0, 1.5], [100.0], pol)
    Rm, Tm = mpmath_stack_RT(500.0, 0.6, [1.25, 1.0, 1.5], [100.0], pol)
    # lossless: energy cannot be created. At q_layer = 0 exactly the film is evaluated one ulp
    # of s² away (fresnel.nudge_critical); the step leaves ~5e-10 of rounding
    assert R.item() + T.item() <= 1.0 + 1e-9
    assert abs(R.item() - Rm) <= 2e-9 and abs(T.item() - Tm) <= 2e-9


def test_near_critical_angle_of_a_layer():
    c = np.nextafter(0.6, 1.0)
    worst = 0.0
    for cc in (c, np.nextafter(c, 1.0), np.nextafter(np.nextafter(0.6, 0.0), 0.0)):
        for pol in ("s", "p"):
            R, T = ml(500.0, cc, [1.25, 1.0, 1.5], [100.0], pol)
            Rm, Tm = mpmath_stack_RT(500.0, float(cc), [1.25, 1.0, 1.5], [100.0], pol)
            worst = max(worst, abs(R.item() - Rm), abs(T.item() - Tm))
    assert worst <= 2e-8  # measured ~1e-8 (see the note above); 1e-9 elsewhere
    # a micro-radian away the error is back below the 1e-9 bar
    for pol in ("s", "p"):
        cc = 0.6 + 1e-6
        R, T = ml(500.0, cc, [1.25, 1.0, 1.5], [100.0], pol)
        Rm, Tm = mpmath_stack_RT(500.0, cc, [1.25, 1.0, 1.5], [100.0], pol)
        assert abs(R.item() - Rm) <= 1e-9 and abs(T.item() - Tm) <= 1e-9


@pytest.mark.parametrize("idx,d", [([1.5, 1.0, 1.5], [0.0]), ([2.0, 1.0, 2.0, 2.0], [0.0, 0.0])])
def test_zero_thickness_grazing_same_media(idx, d):
    for pol in ("s", "p"):
        R, T = ml(500.0, 0.0, idx, d, pol)
        R2, T2 = ml(500.0, 0.0, [idx[0], idx[-1]], [], pol)
        assert torch.isfinite(R) and abs(R.item() - R2.item()) <= 1e-14


# ----------------------------------------------------------------------------------------
# shapes
# ----------------------------------------------------------------------------------------
def test_broadcasting_and_elementwise():
    L = 3
    g = np.random.default_rng(3)
    wl = t64([400.0, 500.0, 600.0, 700.0])  # (W,)
    c = t64([[1.0], [0.5], [0.0]])  # (A, 1)
    d = t64(g.uniform(0, 300, (2, 1, 1, L)))  # batch (D, 1, 1)
    idx = tc128(np.concatenate([np.ones((2, 1)), g.uniform(1.2, 2.2, (2, L)) + 0.05j,
                                np.full((2, 1), 1.5)], axis=1)).reshape(2, 1, 1, 1, L + 2)  # (S,1,1,1)
    for pol in POLS:
        R, T = torchirid.multilayer(wl, c, idx, d, polarization=pol)
        assert R.shape == T.shape == (2, 2, 3, 4)
        for s in range(2):
            for di in range(2):
                for a in range(3):
                    for w in range(4):
                        r, t = torchirid.multilayer(wl[w], c[a, 0], idx[s, 0, 0, 0], d[di, 0, 0],
                                                    polarization=pol)
                        assert r.shape == ()
                        assert abs(R[s, di, a, w].item() - r.item()) <= 1e-15
                        assert abs(T[s, di, a, w].item() - t.item()) <= 1e-15


@pytest.mark.parametrize("pol", POLS)
def test_bare_interface_L0(pol):
    c = t64(np.linspace(0.0, 1.0, 51))
    for n0, n1 in ((1.0, 1.5), (1.5, 1.0), (1.33, complex(material_nk("Ag", 500.0))), (2.0, 1.2)):
        idx = tc128([n0, n1])
        R, T = torchirid.multilayer(t64(500.0), c, idx, t64(np.zeros(0)), polarization=pol)
        assert R.shape == (51,)
        Rf = torchirid.optics.fresnel_reflectance(c, n0, tc128(n1), polarization=pol)
        assert (R - Rf).abs().max().item() <= 1e-15
        if complex(n1).imag == 0:
            tir = n0 * n0 * (1 - c * c) >= complex(n1).real ** 2
            assert (T[tir] == 0).all()
            assert (R + T - 1).abs().max().item() <= 1e-14
        else:  # no film absorbs: all that is not reflected enters the absorbing exit medium
            assert (R + T - 1).abs().max().item() <= 1e-14 and (T[1:] > 0).all()  # (grazing: no power in)
    # batched indices (B, 2) with thicknesses (0,)
    idx = t64([[1.0, 1.5], [1.0, 2.0]])
    R, T = torchirid.multilayer(t64(500.0), t64([[1.0], [0.5]]), idx, torch.zeros(0, dtype=F64),
                                polarization=pol)
    assert R.shape == (2, 2)


def test_shape_errors():
    wl, c = t64(500.0), 1.0
    with pytest.raises(ValueError, match="indices"):
        torchirid.multilayer(wl, c, t64([1.0, 1.5, 1.4]), t64([100.0, 200.0]))  # L mismatch
    with pytest.raises(ValueError, match="indices"):
        torchirid.multilayer(wl, c, t64([[1.0, 1.4, 1.5]]), t64([[100.0, 5.0]]))
    with pytest.raises(ValueError, match="indices"):
        torchirid.multilayer(wl, c, t64([1.0]), t64(np.zeros(0)))  # no exit medium
    with pytest.raises(ValueError, match="indices"):
        torchirid.multilayer(wl, c, t64(1.0), t64(np.zeros(0)))  # scalar
    with pytest.raises(ValueError, match="thicknesses"):
        torchirid.multilayer(wl, c, t64([1.0, 1.5]), t64(0.0))  # scalar thicknesses


# ----------------------------------------------------------------------------------------
# dtypes, float32
# ----------------------------------------------------------------------------------------
def test_dtypes():
    a32 = (torch.tensor([450.0, 600.0]), torch.tensor(0.5), torch.tensor([1.0, 1.4, 1.5]), torch.tensor([90.0]))
    R, T = torchirid.multilayer(*a32)
    assert R.dtype == T.dtype == torch.float32
    R, T = torchirid.multilayer(*(x.double() for x in a32))
    assert R.dtype == T.dtype == F64
    R, T = torchirid.multilayer(550.0, 1.0, [1.0, 1.4, 1.5], [100.0])  # plain Python
    assert R.dtype == torch.get_default_dtype() and R.shape == ()
    R, T = torchirid.multilayer(a32[0], 0.5, torch.tensor([1.0, 1.4 + 0.1j, 1.5], dtype=torch.complex64), a32[3])
    assert R.dtype == torch.float32


@pytest.mark.parametrize("pol", POLS)
def test_float32_accuracy(pol):
    """float32 vs float64 for modest stacks (L = 4, d ≤ 300 nm, κ ≤ 0.2 layers, metal exits).

    Measured (this seed, 4000 points): max |ΔR| = 3.3e-6 (s), 1.5e-6 (p), 2.3e-6 (unpol.),
    max |ΔT| = 2.0e-6 (s), 1.1e-6 (p), 1.2e-6 (unpol.); 20 000 other random points:
    3.2e-6 (R), 1.8e-6 (T). Bar: 1e-4.
    """
    g = np.random.default_rng(11)
    N, L = 4000, 4
    wl = g.uniform(380, 780, N)
    c = g.uniform(0, 1, N)
    c[:2] = (0.0, 1.0)
    idx = np.concatenate([
        np.where(g.random((N, 1)) < 0.7, 1.0, g.uniform(1, 1.6, (N, 1))),
        g.uniform(1.2, 2.4, (N, L)) + 1j * g.uniform(0, 0.2, (N, L)) * (g.random((N, L)) < 0.3),
        g.uniform(1.3, 2, (N, 1)) + 1j * g.uniform(0, 3, (N, 1)) * (g.random((N, 1)) < 0.5)], axis=1)
    d = g.uniform(0, 300, (N, L))
    out = {}
    for dt, cdt in ((torch.float32, torch.complex64), (F64, C128)):
        out[dt] = torchirid.multilayer(torch.tensor(wl, dtype=dt), torch.tensor(c, dtype=dt),
                                       torch.tensor(idx, dtype=cdt), torch.tensor(d, dtype=dt), polarization=pol)
    R32, T32 = out[torch.float32]
    R64, T64 = out[F64]
    assert R32.dtype == torch.float32
    assert torch.isfinite(R32).all() and torch.isfinite(T32).all()
    assert R32.min().item() >= 0 and R32.max().item() <= 1 and T32.min().item() >= 0 and T32.max().item() <= 1
    assert (R32.double() - R64).abs().max().item() <= 1e-4
    assert (T32.double() - T64).abs().max().item() <= 1e-4


# ----------------------------------------------------------------------------------------
# gradients
# ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("pol", POLS)
def test_gradcheck_lossless_3_layers(pol):
    wl = t64([430.0, 610.0]).requires_grad_()
    c = t64([0.85, 0.4]).requires_grad_()
    idx = t64([[1.0, 1.45, 2.1, 1.38, 1.52], [1.2, 1.6, 2.3, 1.4, 1.7]]).requires_grad_()
    d = t64([[120.0, 60.0, 210.0], [80.0, 330.0, 45.0]]).requires_grad_()

    def f(wl, c, idx, d):
        return torchirid.multilayer(wl, c, idx, d, polarization=pol)

    assert torch.autograd.gradcheck(f, (wl, c, idx, d))


@pytest.mark.parametrize("pol", POLS)
def test_gradcheck_absorbing_2_layers(pol):
    nAu = complex(material_nk("Au", 560.0))
    wl = t64([560.0, 640.0]).requires_grad_()
    c = t64([0.9, 0.5]).requires_grad_()
    n_re = t64([[1.0, 1.6, nAu.real, 1.5], [1.0, 2.0, 1.5, 1.6]]).requires_grad_()
    # κ of the films and the exit medium (all > 0: gradcheck perturbs them by ±1e-6)
    k = t64([[0.1, nAu.imag, 0.01], [0.3, 0.05, 0.2]]).requires_grad_()
    d = t64([[90.0, 30.0], [150.0, 70.0]]).requires_grad_()

    def f(wl, c, n_re, k, d):
        n_im = torch.cat([torch.zeros_like(k[:, :1]), k], dim=-1)  # real incident medium
        return torchirid.multilayer(wl, c, torch.complex(n_re, n_im), d, polarization=pol)

    assert torch.autograd.gradcheck(f, (wl, c, n_re, k, d))


_HARD = [
    (500.0, 0.0, [1.0, 1.4, 1.5], [300.0]),  # grazing
    (500.0, 1.0, [1.0, 1.4, 1.5], [300.0]),  # normal
    (500.0, 0.5, [1.0, 1.4, 1.5], [0.0]),  # zero thickness
    (500.0, 0.0, [1.0, 1.4, 1.5], [0.0]),
    (500.0, 0.2, [1.8, 1.3, 1.4], [300.0]),  # TIR
    (500.0, 0.0, [1.8, 1.3, 1.4], [300.0]),
    (500.0, math.sqrt(1 - (1.4 / 1.8) ** 2), [1.8, 1.3, 1.4], [300.0]),  # critical angle of the exit
    (500.0, 0.3, [1.0, 1.4, "Ag"], [300.0]),  # metal exit
    (500.0, 0.0, [1.0, 1.4, "Ag"], [300.0]),
    (500.0, 0.3, [1.0, "Au", 1.5], [5000.0]),  # opaque metal layer
    (500.0, 0.0, [1.0, 1.0, 1.0], [300.0]),  # no interfaces at all, grazing
    (500.0, 0.5, [1.0, 1.0, 1.0], [300.0]),
    (500.0, 0.0, [1.0, 1.5], []),
    (500.0, 1.0, [1.0, 1.5], []),
    (500.0, 0.0, [1.5, 1.0, 1.5], [300.0]),
    (500.0, 0.5, [1.0, 1.4, 2.0, 1.4, 1.5], [100.0, 0.0, 300.0]),
]


@pytest.mark.parametrize("dtype", [F64, torch.float32])
@pytest.mark.parametrize("pol", POLS)
def test_gradients_finite_at_hard_cases(pol, dtype):
    for wl, c, idx, d in _HARD:
        vals = [complex(material_nk(v, wl)) if isinstance(v, str) else complex(v) for v in idx]
        lam = torch.tensor(wl, dtype=dtype, requires_grad=True)
        ct = torch.tensor(c, dtype=dtype, requires_grad=True)
        th = torch.tensor(d, dtype=dtype, requires_grad=True)
        n_re = torch.tensor([v.real for v in vals], dtype=dtype, requires_grad=True)
        n_im = torch.tensor([v.imag for v in vals], dtype=dtype)
        n = torch.complex(n_re, n_im) if any(v.imag for v in vals) else n_re
        R, T = torchirid.multilayer(lam, ct, n, th, polarization=pol)
        assert torch.isfinite(R) and torch.isfinite(T), (idx, d, c)
        assert 0.0 <= R.item() <= 1.0 and 0.0 <= T.item() <= 1.0 + 1e-6
        grads = torch.autograd.grad(R + 2 * T, (lam, ct, th, n_re), allow_unused=True)
        for g in grads:
            assert g is None or torch.isfinite(g).all(), (idx, d, c, grads)


# ----------------------------------------------------------------------------------------
# NaN
# ----------------------------------------------------------------------------------------
def test_nan_propagates():
    nan = float("nan")
    wl = t64([500.0, 500.0])
    c = t64([0.6, 0.6])
    idx = t64([[1.0, 1.4, 1.5], [1.0, 1.4, 1.5]])
    d = t64([[100.0], [100.0]])
    R0, T0 = torchirid.multilayer(wl, c, idx, d)
    for name, pos in (("wavelength", (0,)), ("thicknesses", (0, 0)), ("indices", (0, 1)), ("indices", (0, 2))):
        args = {"wavelength": wl, "cos_theta": c, "indices": idx, "thicknesses": d}
        bad = args[name].clone()
        bad[pos] = nan
        args[name] = bad
        R, T = torchirid.multilayer(**args)  # no exception
        assert torch.isnan(R[0]) and torch.isnan(T[0]), (name, pos)
        assert R[1].item() == R0[1].item() and T[1].item() == T0[1].item(), (name, pos)


@pytest.mark.parametrize("which", ["cos_theta", "incident index"])
def test_nan_cos_or_incident_index_propagates_to_T(which):
    nan = float("nan")
    c = nan if which == "cos_theta" else 0.6
    n0 = nan if which == "incident index" else 1.0
    R, T = torchirid.multilayer(t64(500.0), t64(c), t64([n0, 1.4, 1.5]), t64([100.0]))
    assert torch.isnan(R) and torch.isnan(T)


def test_nan_cos_or_incident_index_propagates_to_R():
    nan = float("nan")
    R, _ = torchirid.multilayer(t64(500.0), t64(nan), t64([1.0, 1.4, 1.5]), t64([100.0]))
    assert torch.isnan(R)
    R, _ = torchirid.multilayer(t64(500.0), t64(0.6), t64([nan, 1.4, 1.5]), t64([100.0]))
    assert torch.isnan(R)


@pytest.mark.parametrize("pol", ["s", "p"])
@pytest.mark.parametrize("substrate", ["Si", "Ag", "Au", "Cu", "Al"])
def test_transmittance_into_an_absorbing_substrate_is_tmms(substrate, pol):
    """T into an absorbing exit medium is the Poynting flux just inside it, as tmm.coh_tmm
    reports it (raw, not through tmm_RT), from normal to near-grazing incidence, for s and p;
    with lossless films R + T = 1 (everything not reflected enters the substrate), with an
    absorbing film 1 − R − T > 0 is what the film absorbs."""
    import oracles

    wl = np.array([420.0, 550.0, 700.0])
    nsub = material_nk(substrate, wl)
    for w, ns in zip(wl, nsub):
        for c in (1.0, 0.6, 0.05):
            for films, d in (([1.38, 2.3], [95.0, 60.0]), ([1.5, 0.06 + 3.5j], [80.0, 12.0])):
                idx = [1.0, *films, complex(ns)]
                R, T = torchirid.multilayer(t64(w), t64(c), tc128(idx), t64(d), polarization=pol)
                ref = oracles.tmm_coh(float(w), c, idx, d, pol)
                assert abs(R.item() - ref["R"]) <= 1e-12
                assert abs(T.item() - ref["T"]) <= 1e-12 and T.item() > 0
                if all(complex(f).imag == 0 for f in films):
                    assert abs(R.item() + T.item() - 1) <= 1e-12
                else:
                    assert 1 - R.item() - T.item() > 1e-6  # the silver film absorbs
