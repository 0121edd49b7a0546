r"""The kernel of :func:`torchirid.multilayer`: Hirayama's recursion carried as a fraction.

Hirayama's step :math:`γ' = (r + γ e_2)/(1 + r γ e_2)` (``e_2 = e^{2iφ}`` of the film behind
the interface) is a Möbius map of γ. Carried as a fraction ``γ = N / D`` it becomes

.. math:: x = e_2 N, \qquad N' = x + r D, \qquad D' = D + r x

— three complex multiply-adds per film and no division — and the transmission step
:math:`τ' = t\, e^{iφ} τ / (1 + r γ e_2) = t\, e^{iφ} τ\, D / D'` (``t = 1 + r``) telescopes:
over a run of films :math:`|τ|^2` gains :math:`\prod |t_j|^2 \prod |e_{2,j}| / |D|^2`, where
:math:`\prod |e_{2,j}| = \exp(-2\sum_j \mathrm{Im}\,φ_j)` is one real exponential for the whole
run. Only the power :math:`|τ|^2` enters ``T = Re(η_B) |τ|² / η_A``. Every ``BLOCK`` films the
fraction is renormalised (``N ← N/D``, ``D ← 1``, :math:`|τ|^2` updated).

Per film the work is the phase factor over the batch, shared by both polarizations —
``e_1 = e^{-\mathrm{Im}\,φ}(\cos + i \sin)(\mathrm{Re}\,φ)`` in real arithmetic (only the
decaying exponential is formed; skipped for films that neither absorb nor are evanescent anywhere
in the batch; computed once for a film that recurs in the stack), ``e_2 = e_1^2`` — and the three
multiply-adds on the state ``[P, *batch]``, which holds both polarizations, so that every op runs
once for both. Without a gradient the ops write into preallocated buffers: no allocation per
film, and no array with a film axis the size of the batch.

Range and the 0/0 step. Over a block ``|D|`` changes by the product of the films' ``|1 + r γ
e₂|``: far inside the exponent range for physical stacks, but not for a run of near-0/0 steps
(zero-thickness films at grazing incidence, Fresnel amplitudes ±(1 − ε): ~ε per film), nor for
the exact 0/0 step of the division form (then ``N = D = 0``). At the end of each block ``|D|²``
is checked against the normal range; if it left it anywhere, the batch is run again film by
film (renormalised after every film, i.e. the division form) with the guarded step, which
resets a point that meets 0/0 to ``γ = 0``, ``τ = 0`` on the spot. Under
:func:`torchirid._checks.traceable` (vmap, ``torch.compile``) that guarded film-by-film pass runs
from the start and no value is read back. Thick absorbers underflow ``e_2`` (and the run's
:math:`\prod|e_2|`) to zero, giving the bulk reflectance and ``T = 0``, with no overflow.
"""

from __future__ import annotations

import torch

from .. import _checks

__all__ = ["reflect_transmit"]

#: films between two renormalisations of the fraction N / D, per real dtype: over a block |D|
#: changes by the product of the block's |1 + r γ e₂|, far inside the exponent range.
BLOCK = {torch.float64: 32, torch.float32: 8}


class _OutOfRange(Exception):
    """Raised by the unguarded pass when |D|² left the normal range at some point: the 0/0 state,
    or a run of near-0/0 steps (|1 + r γ e₂| ~ ε per film, e.g. zero-thickness films at grazing
    incidence) that underflows D within a block."""


def _abs2(z: torch.Tensor) -> torch.Tensor:
    """|z|² = Re² + Im² (real tensor), without the hypot of ``abs``."""
    return torch.addcmul(z.real * z.real, z.imag, z.imag)


def reflect_transmit(r: torch.Tensor, t2: torch.Tensor, k: torch.Tensor, u: torch.Tensor, batch, seed=None):
    r"""|γ|² and (scaled) |τ|² of a stack, per polarization.

    Args:
        r: interface amplitudes ``[P, *Bq, L+1]`` (complex), ``r[..., j]`` between media ``j``
            and ``j+1``; ``Bq`` broadcasts against ``batch`` (polarization axis leading).
        t2: ``|t_j|²`` of the same interfaces (real, same shape), possibly scaled (the
            caller folds ``Re η_B / η_A`` into the last one).
        k: ``2π q_j d_j`` of the ``L`` films ``[*Bk, L]`` (complex, Im ≥ 0): film ``j``'s
            phase is ``φ_j = k_j u``.
        u: ``1/λ`` (real), broadcasting against ``batch``.
        batch: the broadcast batch shape of the stack.
        seed: γ₀ (complex, broadcasting against ``[P, *batch]``) instead of ``r[..., L]``, e.g.
            a rough last interface's (Hirayama eq. 9); ``t2[..., L]`` then carries |τ₀|².

    Returns:
        ``(R, tau2)``, both ``[P, *batch]`` real: :math:`|γ|^2` and
        :math:`\prod_j t2_j\, |e^{iφ_j}|^2 / |\prod_j (1 + r_j γ_j e^{2iφ_j})|^2` (Hirayama eq.
        4 squared); ``tau2 = 0`` where the guarded step fired.
    """
    shape = (r.shape[0], *batch)
    if k.shape[-1] == 0:  # a bare interface
        return _abs2(r[..., 0] if seed is None else seed).expand(shape), t2[..., 0].expand(shape)
    traceable = _checks.traceable()
    grad = torch.is_grad_enabled() and any(x is not None and x.requires_grad for x in (r, t2, k, u, seed))
    step = _Functional if (traceable or grad) else _InPlace
    if traceable:
        return _run(r, t2, k, u, seed, shape, step, guard=True)
    try:
        return _run(r, t2, k, u, seed, shape, step, guard=False)
    except _OutOfRange:
        return _run(r, t2, k, u, seed, shape, step, guard=True)


def _run(r, t2, k, u, seed, shape, step, guard: bool):
    L = k.shape[-1]
    rl = r.movedim(-1, 0).contiguous()  # [L+1, P, *Bq]: one contiguous slice per interface
    t2 = t2.movedim(-1, 0)
    kk = torch.stack([k.real, -k.imag]).movedim(-1, 0)  # [L, 2, *Bk]: Re φ/u, −Im φ/u ≤ 0
    kk = kk.reshape(L, 2, *([1] * (len(shape) - 1 - (kk.ndim - 2))), *kk.shape[2:]).contiguous()
    # Shortcuts that read values back, taken only by the in-place pass (with a gradient, every
    # film's e^{-Im φ} has a derivative, and equal films have distinct thicknesses to differentiate):
    # films that neither absorb nor are evanescent anywhere skip e^{-Im φ} = 1, and a film that
    # recurs in the stack (a Bragg mirror's) has its e₂ computed once
    fast = step is _InPlace and not guard
    decays = (kk[:, 1] != 0).reshape(L, -1).any(1).tolist() if fast and kk[0].numel() else [True] * L
    repeats = _repeated_films(kk) if fast else None
    cache = {}
    block = 1 if guard else BLOCK.get(u.dtype, 8)
    tiny = torch.finfo(u.dtype).tiny

    state = step.start(rl[L] if seed is None else seed, shape, u)
    tau2 = t2[L]
    dead = torch.zeros(shape, dtype=torch.bool, device=u.device) if guard else None
    acc_t2 = acc_nki = None
    run = 0
    for j in range(L - 1, -1, -1):
        key = repeats.get(j) if repeats else None
        e2 = cache.get(key)
        if e2 is None:
            e2 = step.phase(state, kk[j], decays[j], u, cache_it=key is not None)
            if key is not None:
                cache[key] = e2
        step.update(state, e2, rl[j])
        if guard:
            # the division form's den == 0 (here D' = 0, and then N' = 0 too): γ = 0, τ = 0
            degenerate = state["D"] == 0
            state["N"] = torch.where(degenerate, torch.zeros_like(state["N"]), state["N"])
            state["D"] = torch.where(degenerate, torch.ones_like(state["D"]), state["D"])
            dead = dead | degenerate
        acc_t2 = t2[j] if acc_t2 is None else acc_t2 * t2[j]
        if decays[j]:
            acc_nki = kk[j, 1] if acc_nki is None else acc_nki + kk[j, 1]
        run += 1
        if run == block or j == 0:
            d2 = _abs2(state["D"])
            if not guard and bool(((d2 < tiny) | (d2 > 1 / tiny)).any()):
                raise _OutOfRange
            inv = torch.reciprocal(d2)
            # |τ|² over the run: ∏|t|² · ∏|e₂| / |D|², with ∏|e₂| = exp(−2 Σ Im φ) ≤ 1
            scale = inv if acc_nki is None else inv * torch.exp((2 * acc_nki) * u)
            tau2 = (tau2 * acc_t2) * scale
            if j > 0:
                step.renormalise(state)
                acc_t2 = acc_nki = None
                run = 0
    R = _abs2(state["N"]) * inv
    if guard:
        tau2 = torch.where(dead, torch.zeros_like(tau2), tau2)
    return R, tau2.expand(shape)


#: at most this many distinct repeated films keep their e₂ (one batch-sized complex array each)
CACHED_FILMS = 4


def _repeated_films(kk: torch.Tensor):
    """``{film index: key}`` for the films whose phase coefficients ``kk[j]`` recur in the stack
    (the ``CACHED_FILMS`` most frequent), or None. Only for coefficients that do not span the
    batch (indices and thicknesses shared by all points), where comparing them is cheap."""
    L = kk.shape[0]
    if L < 2 or not 0 < kk[0].numel() <= 4096:
        return None
    _, inverse, counts = torch.unique(kk.reshape(L, -1), dim=0, return_inverse=True, return_counts=True)
    counts = counts.tolist()
    inverse = inverse.tolist()
    top = sorted((c, i) for i, c in enumerate(counts) if c > 1)[::-1][:CACHED_FILMS]
    keep = {i for _, i in top}
    return {j: i for j, i in enumerate(inverse) if i in keep} or None


class _InPlace:
    """Film steps writing into preallocated buffers (no gradient is recorded)."""

    @staticmethod
    def start(seed, shape, u):
        N = torch.empty(shape, dtype=seed.dtype, device=seed.device)
        N.copy_(seed.expand(shape))
        phase = torch.empty((2, *shape[1:]), dtype=u.dtype, device=u.device)
        return dict(N=N, D=torch.ones_like(N), x=torch.empty_like(N), phase=phase,
                    cs=torch.empty_like(phase), e1=torch.empty(shape[1:], dtype=N.dtype, device=N.device))

    @staticmethod
    def phase(s, kk, decays, u, cache_it):
        """e₂ = e^{2iφ} of one film over the batch (in a buffer, or a new array to cache)."""
        phase, cs, e1 = s["phase"], s["cs"], s["e1"]
        if decays:
            torch.mul(kk, u, out=phase)  # Re φ, −Im φ
            phase[1].exp_()  # |e₁| = e^{−Im φ} ≤ 1
        else:
            torch.mul(kk[0], u, out=phase[0])
        torch.cos(phase[0], out=cs[0])
        torch.sin(phase[0], out=cs[1])
        if decays:
            cs.mul_(phase[1])
        torch.complex(cs[0], cs[1], out=e1)  # e₁ = e^{iφ}
        return torch.mul(e1, e1) if cache_it else e1.mul_(e1)  # e₂ = e₁²

    @staticmethod
    def update(s, e2, r):
        x, N, D = s["x"], s["N"], s["D"]
        torch.mul(e2, N, out=x)  # x = e₂ N
        torch.addcmul(x, r, D, out=N)  # N' = x + r D
        D.addcmul_(r, x)  # D' = D + r x

    @staticmethod
    def renormalise(s):
        s["N"].div_(s["D"])
        s["D"].fill_(1)


class _Functional:
    """The same steps out of place: differentiable, and without ``out=`` for vmap / compile."""

    @staticmethod
    def start(seed, shape, u):
        N = seed.expand(shape)
        return dict(N=N, D=torch.ones_like(N))

    @staticmethod
    def phase(s, kk, decays, u, cache_it):
        a = kk[0] * u
        m = torch.exp(kk[1] * u)
        e1 = torch.complex(m * torch.cos(a), m * torch.sin(a))
        return e1 * e1

    @staticmethod
    def update(s, e2, r):
        x = e2 * s["N"]
        s["N"] = torch.addcmul(x, r, s["D"])
        s["D"] = torch.addcmul(s["D"], r, x)

    @staticmethod
    def renormalise(s):
        s["N"] = s["N"] / s["D"]
        s["D"] = torch.ones_like(s["D"])
