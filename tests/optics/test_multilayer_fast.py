"""The kernel of torchirid.multilayer: Hirayama's recursion carried as a fraction γ = N / D
(optics/_transfer_fast.py, issue 23.2).

References: ``tmm`` (and the 50-digit characteristic-matrix oracle at exact grazing) on random
stacks of 1–40 films, 1e-12 in R and T; the division form of the same recursion
(``optics.transfer.recursion``, the previous implementation of multilayer) on large random
batches; the closed-form Bragg mirror for stacks of thousands of films. Also the kernel's own
machinery: the 0/0 state and its guarded rerun, the renormalisation every few films (float32
and float64 stacks that would overflow without it), the repeated-film cache (bitwise), the
in-place and differentiable passes (the same values; gradcheck through a renormalisation and
repeated films).
"""

from __future__ import annotations

import numpy as np
import pytest
import torch

import torchirid
from oracles import mpmath_stack_RT, tmm_RT
from tensors import F64, t64, tc128
from torchirid.optics import _transfer_fast, transfer


def _stacks(L, B, seed, kind):
    """B random stacks of L films: ``kind`` lossless / absorbing / metal / tir."""
    g = np.random.default_rng(seed)
    wl = g.uniform(380.0, 780.0, B)
    c = g.uniform(0.0, 1.0, B)
    c[:2] = (0.0, 1.0)
    n0 = np.where(g.random(B) < 0.5, 1.0, g.uniform(1.0, 1.7, B))
    films = g.uniform(1.2, 2.5, (B, L)) + 0j
    d = g.uniform(0.0, 500.0, (B, L))
    d[2, 0] = 0.0
    exit_ = g.uniform(1.0, 2.0, B) + 0j
    if kind == "absorbing":
        films += 1j * g.uniform(0.0, 0.6, (B, L)) * (g.random((B, L)) < 0.6)
        exit_ += 1j * g.uniform(0.0, 0.5, B) * (g.random(B) < 0.5)
    elif kind == "metal":  # metal-like films (n 0.05–1.5, κ 1–6, ≤ 40 nm) and metal exits
        metal = g.random((B, L)) < 0.35
        films = np.where(metal, g.uniform(0.05, 1.5, (B, L)) + 1j * g.uniform(1.0, 6.0, (B, L)), films)
        d = np.where(metal, g.uniform(0.0, 40.0, (B, L)), d)
        exit_ = g.uniform(0.05, 1.5, B) + 1j * g.uniform(0.0, 6.0, B)
    elif kind == "tir":  # dense incident medium, steep angles: evanescent films and exits
        n0 = g.uniform(1.8, 2.2, B)
        films = g.uniform(1.2, 2.4, (B, L)) + 0j
        exit_ = g.uniform(1.0, 1.6, B) + 1j * g.uniform(0.0, 0.02, B) * (g.random(B) < 0.3)
        c = g.uniform(0.0, 0.6, B)
        c[0] = 0.0
    idx = np.concatenate([n0[:, None] + 0j, films, exit_[:, None]], axis=1)
    return wl, c, idx, d


def _multilayer(wl, c, idx, d, pol):
    return torchirid.multilayer(t64(wl), t64(c), tc128(idx), t64(d), polarization=pol)


def _division_form(wl, c, idx, d, pol):
    """The previous multilayer: γ, τ divided out at every film (transfer.recursion)."""
    lam, c, n, d = t64(wl), t64(c), tc128(idx), t64(d)
    q, e1, e2, nc_b = transfer.stack_wavenumbers(lam, c, n, d)
    eta = transfer.align_polarization_axis(transfer.stack_admittances(q, nc_b, pol), e2.shape[:-1])
    gamma, tau = transfer.recursion(eta, e1, e2)
    R = (gamma.real ** 2 + gamma.imag ** 2).mean(0).clamp(0, 1)
    eta0 = eta[..., 0].real
    grazing = eta0 == 0
    T = (tau.real ** 2 + tau.imag ** 2) * eta[..., -1].real / torch.where(grazing, torch.ones_like(eta0), eta0)
    T = torch.where(grazing, torch.zeros_like(T), T).mean(0).clamp(0, 1)
    return R, T


# ----------------------------------------------------------------------------------------
# against tmm: random stacks of 1–40 films, 1e-12
# ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("kind", ["lossless", "absorbing", "metal", "tir"])
@pytest.mark.parametrize("L", [1, 2, 5, 10, 20, 40])
def test_vs_tmm_many_films(L, kind):
    B = 10
    wl, c, idx, d = _stacks(L, B, seed=7000 + 100 * L + len(kind), kind=kind)
    for pol in ("s", "p"):
        R, T = _multilayer(wl, c, idx, d, pol)
        for b in range(B):
            args = (wl[b], c[b], list(idx[b]), list(d[b]), pol)
            # exactly at grazing tmm sees cos(arccos 0) = 6e-17: the 50-digit oracle instead
            Rr, Tr = mpmath_stack_RT(*args) if c[b] == 0.0 else tmm_RT(*args)
            assert abs(R[b].item() - Rr) <= 1e-12 and abs(T[b].item() - Tr) <= 1e-12, (pol, b, R[b], Rr, T[b], Tr)


# ----------------------------------------------------------------------------------------
# against the division form on large batches
# ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("kind", ["lossless", "absorbing", "metal", "tir"])
def test_matches_the_division_form(kind):
    """4000 random points per kind, L = 1–40, s / p / unpolarized. Measured max |Δ|: lossless
    8e-14, absorbing 4e-15, metal 1e-14, tir 2.4e-13; only at a guided-mode resonance under
    total internal reflection did the two differ by more than 1e-12 (2.4e-12 on one point in
    18 000, where both, and tmm, are ~3e-12 from the 50-digit value): there the fraction form
    must be at least as close to the oracle."""
    for L in (1, 2, 3, 4, 6, 9, 13, 20, 28, 40):
        wl, c, idx, d = _stacks(L, 400, seed=31 * L + len(kind), kind=kind)
        for pol in ("s", "p", "unpolarized"):
            R, T = _multilayer(wl, c, idx, d, pol)
            Ro, To = _division_form(wl, c, idx, d, pol)
            diff = torch.maximum((R - Ro).abs(), (T - To).abs())
            for b in torch.nonzero(diff > 1e-12).flatten().tolist():
                Rm, Tm = mpmath_stack_RT(wl[b], c[b], list(idx[b]), list(d[b]), pol)
                new = max(abs(R[b].item() - Rm), abs(T[b].item() - Tm))
                old = max(abs(Ro[b].item() - Rm), abs(To[b].item() - Tm))
                assert new <= max(1e-12, old), (L, pol, b, new, old)


# ----------------------------------------------------------------------------------------
# the 0/0 state: guarded rerun
# ----------------------------------------------------------------------------------------
def test_zero_over_zero_reruns_with_the_guard(monkeypatch):
    """At grazing incidence a zero-thickness film between media of the incident index makes
    N = D = 0: the batch is rerun film by film with the guarded step, the ordinary points of the
    batch keep their values, and R is the limit cos θ → 0 — 0 for the invisible stacks (rows 0,
    1, 3), 1 for row 5, which the division form's guard alone (γ = 0 at the 0/0 film) gave as 0.
    The traceable path (value checks off) gives the same."""
    wl = np.full(6, 500.0)
    c = np.array([0.0, 0.0, 0.5, 0.0, 0.9, 0.0])
    idx = np.array([[1.5, 1.0, 1.5, 1.5, 1.5], [1.0, 1.0, 1.5, 1.0, 1.0], [1.5, 1.0, 1.5, 1.5, 1.5],
                    [2.0, 1.0, 2.0, 2.0, 2.0], [1.0, 1.4, 2.0 + 0.1j, 1.3, 1.5], [1.0, 1.5, 1.0, 1.8, 1.0]])
    d = np.array([[0.0, 50.0, 10.0], [300.0, 0.0, 20.0], [0.0, 50.0, 0.0], [0.0, 0.0, 0.0],
                  [100.0, 40.0, 80.0], [0.0, 50.0, 100.0]])
    run = _transfer_fast._run
    for pol in ("s", "p", "unpolarized"):
        guards = []
        with monkeypatch.context() as m:
            m.setattr(_transfer_fast, "_run", lambda *a, guard: guards.append(guard) or run(*a, guard=guard))
            R, T = _multilayer(wl, c, idx, d, pol)
        assert guards == [False, True]  # (0/0 in rows 0, 1, 3, 5 in s and p)
        assert torch.isfinite(R).all() and torch.isfinite(T).all()
        assert R[[0, 1, 3]].abs().max().item() == 0.0 and R[5].item() == 1.0 and (T[[0, 1, 3, 5]] == 0).all()
        assert abs(mpmath_stack_RT(500.0, 0.0, list(idx[5]), list(d[5]), pol)[0] - 1.0) <= 1e-15
        Ro, To = _division_form(wl, c, idx, d, pol)
        assert (R - Ro)[:5].abs().max().item() <= 1e-15 and (T - To).abs().max().item() <= 1e-15
        for b in (2, 4):  # the rerun leaves the other points as they are alone
            Rb, Tb = _multilayer(wl[b], c[b], idx[b], d[b], pol)
            assert abs(R[b].item() - Rb.item()) <= 1e-15 and abs(T[b].item() - Tb.item()) <= 1e-15
        with torchirid.options(value_checks=False):
            Rt, Tt = _multilayer(wl, c, idx, d, pol)
        torch.testing.assert_close((Rt, Tt), (R, T), rtol=0, atol=1e-15)


# ----------------------------------------------------------------------------------------
# renormalisation: thousands of films
# ----------------------------------------------------------------------------------------
def _bragg(cells, dtype):
    """Speed_vs_error's explicit mirror: host 1.5 | (2.5 @ 55 nm, 1.5 @ 91.7 nm) × cells | 1.5."""
    idx = torch.tensor([1.5] + [2.5, 1.5] * cells + [1.5], dtype=dtype)
    d = torch.tensor([55.0, 91.7] * cells, dtype=dtype)
    return idx, d


@pytest.mark.parametrize("cells,dtype", [(2000, F64), (200, torch.float32)])
def test_long_stacks_stay_in_range(cells, dtype, monkeypatch):
    """Without renormalisation N and D overflow for these stacks (4000 films in float64, 400 in
    float32, in and out of the band gap). Renormalised every few films, R is the closed-form
    Bragg mirror's (measured 1.2e-11 in float64, as the division form: rounding over 4000 films;
    1.9e-4 in float32); with renormalisation switched off, the range check at the end of the
    (single) block sends the batch to the film-by-film pass, with the same result."""
    lam = torch.linspace(400.0, 700.0, 61, dtype=dtype)
    c = torch.tensor([1.0, 0.5, 0.05], dtype=dtype)[:, None]
    idx, d = _bragg(cells, dtype)
    Rb = torchirid.bragg_reflectance(lam.double(), c.double(), 1.5, 2.5, 91.7, 55.0, cells)
    tol = 5e-11 if dtype == F64 else 1e-3
    run = _transfer_fast._run
    for block, passes in ((None, [False]), (10**9, [False, True])):
        guards = []
        with monkeypatch.context() as m:
            if block:
                m.setitem(_transfer_fast.BLOCK, dtype, block)
            m.setattr(_transfer_fast, "_run", lambda *a, guard: guards.append(guard) or run(*a, guard=guard))
            R, T = torchirid.multilayer(lam, c, idx, d)
        assert guards == passes  # (unguarded pass only / out of range, then film by film)
        assert torch.isfinite(R).all() and torch.isfinite(T).all()
        assert (R.double() - Rb).abs().max().item() <= tol
        assert (R + T).max().item() <= 1 + 2 * tol


def test_near_zero_over_zero_runs_do_not_underflow():
    """Zero-thickness films alternating with films of the incident index at grazing incidence:
    the rounded Fresnel amplitudes are ±(1 − ε), so every film scales D by ~2ε (a near-0/0 step)
    and D underflows within a block; the range check sends the batch to the film-by-film pass.
    The stack is invisible: R = T = 0, as the closed-form Bragg mirror."""
    for cells in (1, 2, 10, 25):
        idx = t64([1.125] + [2.0, 1.125] * cells + [1.125])
        d = torch.zeros(2 * cells, dtype=F64)
        for pol in ("s", "p", "unpolarized"):
            R, T = torchirid.multilayer(t64([300.0, 500.0]), t64(0.0), idx, d, polarization=pol)
            Rb = torchirid.bragg_reflectance(t64([300.0, 500.0]), t64(0.0), 1.125, 2.0, 0.0, 0.0, cells,
                                             polarization=pol)
            assert torch.equal(R, Rb) and (T == 0).all()


@pytest.mark.parametrize("L", [3, 10, 40])
def test_exact_grazing_is_the_limit(L):
    """Exactly at grazing incidence (η = 0 in every medium of the incident index) R is the limit
    cos θ → 0: 1, unless nothing is visible (films of other indices all of zero thickness, exit of
    the incident index), then 0 — also where the recursion meets 0/0 (zero-thickness films between
    media of the incident index), whose guard alone (γ = 0 there) gave R = 0 for visible stacks."""
    g = np.random.default_rng(L)
    B = 60
    wl = g.uniform(380.0, 780.0, B)
    n0 = np.where(g.random(B) < 0.5, 1.0, g.uniform(1.0, 1.7, B))
    films = np.where(g.random((B, L)) < 0.4, n0[:, None], g.uniform(1.2, 2.5, (B, L)))
    d = np.where(g.random((B, L)) < 0.5, 0.0, g.uniform(0.0, 500.0, (B, L)))
    exit_ = np.where(g.random(B) < 0.3, n0, g.uniform(1.0, 2.0, B))
    d[:5] = 0.0  # some wholly invisible stacks
    exit_[:5] = n0[:5]
    idx = np.concatenate([n0[:, None], films, exit_[:, None]], axis=1)
    visible = ((films != n0[:, None]) & (d > 0)).any(1) | (exit_ != n0)
    assert 0 < visible.sum() < B
    for pol in ("s", "p"):
        R, T = _multilayer(wl, np.zeros(B), idx, d, pol)
        assert (T == 0).all()
        assert (R - t64(visible.astype(float))).abs().max().item() <= 1e-14
        for b in np.flatnonzero(visible)[::4]:  # the 50-digit oracle agrees (it has 0/0 for the others)
            Rm, _ = mpmath_stack_RT(wl[b], 0.0, list(idx[b]), list(d[b]), pol)
            assert abs(R[b].item() - Rm) <= 1e-14


# ----------------------------------------------------------------------------------------
# repeated films: e₂ computed once, bitwise the same
# ----------------------------------------------------------------------------------------
def test_repeated_films_are_bitwise_the_same(monkeypatch):
    g = np.random.default_rng(4)
    lam = t64(np.linspace(380.0, 780.0, 41))
    c = t64(np.linspace(0.0, 1.0, 7))[:, None]
    cells = 12
    # a Bragg mirror with an absorbing and a repeated evanescent-capable film, and one stray film
    idx = tc128([1.3] + [2.3, 1.38, 1.6 + 0.05j] * cells + [1.0, 1.52])
    d = t64([70.0, 110.0, 20.0] * cells + [g.uniform(10, 200)])
    for pol in ("s", "p", "unpolarized"):
        R, T = torchirid.multilayer(lam, c, idx, d, polarization=pol)
        with monkeypatch.context() as m:
            m.setattr(_transfer_fast, "CACHED_FILMS", 0)
            Rn, Tn = torchirid.multilayer(lam, c, idx, d, polarization=pol)
        assert torch.equal(R, Rn) and torch.equal(T, Tn)
        Ro, To = _division_form(lam.numpy(), c.numpy(), idx.numpy(), d.numpy(), pol)
        assert (R - Ro).abs().max().item() <= 1e-12 and (T - To).abs().max().item() <= 1e-12


# ----------------------------------------------------------------------------------------
# the in-place and the differentiable pass
# ----------------------------------------------------------------------------------------
def test_inplace_and_differentiable_passes_agree():
    wl, c, idx, d = _stacks(12, 300, seed=5, kind="absorbing")
    for pol in ("s", "p", "unpolarized"):
        R, T = _multilayer(wl, c, idx, d, pol)
        dg = t64(d).requires_grad_()
        Rg, Tg = torchirid.multilayer(t64(wl), t64(c), tc128(idx), dg, polarization=pol)
        assert Rg.requires_grad
        torch.testing.assert_close((Rg.detach(), Tg.detach()), (R, T), rtol=0, atol=1e-15)


def test_gradcheck_through_renormalisation_and_repeated_films(monkeypatch):
    """Two films with the same index and thickness (each with its own gradient), an absorbing film
    and exit, and a renormalisation after every second film."""
    monkeypatch.setitem(_transfer_fast.BLOCK, F64, 2)
    wl = t64([430.0, 610.0]).requires_grad_()
    c = t64([0.85, 0.3]).requires_grad_()
    n_re = t64([1.0, 1.45, 2.1, 1.45, 1.6, 1.52]).requires_grad_()
    k = t64([0.2, 0.01]).requires_grad_()  # κ of the last film and of the exit medium (> 0)
    d = t64([120.0, 60.0, 120.0, 35.0]).requires_grad_()

    def f(wl, c, n_re, k, d):
        n = torch.complex(n_re, torch.cat([torch.zeros_like(n_re[:4]), k]))
        return torchirid.multilayer(wl, c, n, d, polarization="unpolarized")

    assert torch.autograd.gradcheck(f, (wl, c, n_re, k, d))


def test_a_seed_replaces_the_last_interface():
    """reflect_transmit(seed=γ₀) (for a rough last interface): seeded with the last interface's
    own r it is bitwise the unseeded kernel; seeded with 0 it is the stack on an exit medium
    of the last film's index."""
    g = np.random.default_rng(8)
    lam = t64(np.linspace(380.0, 780.0, 9))
    c = t64([1.0, 0.6, 0.2])[:, None]
    idx = tc128([1.0, 1.4 + 0.02j, 2.2, 1.6, 1.52 + 0.1j])
    d = t64(g.uniform(20.0, 300.0, 3))
    batch = (3, 9)
    q, nc = transfer.stack_normal_wavenumbers(c, idx, torch.complex128)
    eta = transfer.align_polarization_axis(transfer.stack_admittances(q, nc, "unpolarized"), batch)
    r, t2 = transfer.interface_amplitudes(eta[..., :-1], eta[..., 1:])
    k = 2 * np.pi * q[..., 1:-1] * d
    R, T = _transfer_fast.reflect_transmit(r, t2, k, 1 / lam, batch)
    Rs, Ts = _transfer_fast.reflect_transmit(r, t2, k, 1 / lam, batch, seed=r[..., -1].clone())
    assert torch.equal(R, Rs) and torch.equal(T, Ts)
    R0, _ = _transfer_fast.reflect_transmit(r, t2, k, 1 / lam, batch, seed=torch.zeros_like(r[..., -1]))
    Rl, _ = torchirid.multilayer(lam, c, torch.cat([idx[:-1], idx[-2:-1]]), d)
    assert (R0.mean(0) - Rl).abs().max().item() <= 1e-15
