r"""Hirayama's recursion as a product of 2×2 matrices, reduced as a tree: few ops for short stacks.

The fraction step of ``_transfer_fast`` — :math:`x = e_2 N,\ N' = x + r D,\ D' = D + r x` — is
linear in ``(N, D)``:

.. math:: \begin{pmatrix} N' \\ D' \end{pmatrix} = M_j \begin{pmatrix} N \\ D \end{pmatrix},
          \qquad M_j = \begin{pmatrix} e_{2,j} & r_j \\ r_j e_{2,j} & 1 \end{pmatrix},

so the whole stack is :math:`(N, D)^T = M_0 M_1 \cdots M_{L-1} (r_L, 1)^T` and
:math:`R = |N|^2/|D|^2`, :math:`|τ|^2 = \prod_j |t_j|^2 \prod_j |e_{2,j}| / |D|^2`. The product
is reduced pairwise (``⌈log₂ L⌉`` batched 2×2 products) and every film's phase is computed in
one op over all films: ~30 tensor ops for any L instead of ~9 per film, which is what a small
batch costs (the design optimisers evaluate a population or a few candidates, with autograd,
thousands of times). The price is a film axis in memory (``[L, P, *batch, 2, 2]``) and no
renormalisation: every entry of :math:`M_j` is at most 1 in modulus, so the product's entries are
at most :math:`2^L`; the caller uses it for L ≤ ``MAX_FILMS`` and batches below
``MAX_POINTS`` and falls back to ``reflect_transmit``
otherwise, and whenever :math:`|D|^2` leaves the normal range (the 0/0 states that kernel guards).
"""

from __future__ import annotations

import torch

__all__ = ["fits", "reflect_transmit_scan"]

#: longest stack reduced as a matrix product (entries ≤ 2^L stay far inside float32's range)
MAX_FILMS = 96
#: most points ``P × batch`` reduced as a matrix product: beyond ~1000 points the work, not the
#: number of ops, dominates and the film loop (no film axis in memory, in-place without a
#: gradient) is faster (measured on 6–40-film stacks, with and without a gradient: the
#: crossover lies between 800 and 4000 points)
MAX_POINTS = 1024


def fits(L: int, P: int, batch) -> bool:
    """Whether a stack of ``L`` films over ``P × batch`` points takes the matrix-product path."""
    size = P
    for s in batch:
        size *= s
    return 0 < L <= MAX_FILMS and size <= MAX_POINTS


def reflect_transmit_scan(r: torch.Tensor, t2: torch.Tensor, k: torch.Tensor, u: torch.Tensor, batch):
    """``(R, tau2)`` per polarization ``[P, *batch]``, as ``reflect_transmit`` (same arguments, no
    seed), or None when ``|D|²`` left the normal range somewhere (the caller then runs the
    guarded kernel)."""
    L = k.shape[-1]
    shape = (r.shape[0], *batch)
    phi = k * u[..., None]  # [*batch, L] complex φ_j
    # e₂ = e^{2iφ}: |e₂| = e^{−2 Im φ} ≤ 1, its phase 2 Re φ (polar: no complex exp)
    e2 = torch.polar(torch.exp(-2 * phi.imag), 2 * phi.real).movedim(-1, 0)[:, None]  # [L, 1, *batch]
    rj = r[..., :L].movedim(-1, 0)  # [L, P, *Bq]
    # M_j = [[a, b], [c, d]] = [[e₂, r], [r e₂, 1]], reduced pairwise: M_0 M_1 ⋯ M_{L-1}
    a, b = torch.broadcast_tensors(e2, rj)
    c = b * a
    d = None  # all ones until the first product
    while a.shape[0] > 1:
        if a.shape[0] % 2:  # fold the last two so that the count is even
            a, b, c, d = _fold_last(a, b, c, d)
            if a.shape[0] == 1:
                break
        a1, a2, b1, b2, c1, c2 = a[0::2], a[1::2], b[0::2], b[1::2], c[0::2], c[1::2]
        if d is None:
            a, b, c, d = a1 * a2 + b1 * c2, a1 * b2 + b1, c1 * a2 + c2, c1 * b2 + 1
        else:
            d1, d2 = d[0::2], d[1::2]
            a, b, c, d = a1 * a2 + b1 * c2, a1 * b2 + b1 * d2, c1 * a2 + d1 * c2, c1 * b2 + d1 * d2
    a, b, c = a[0].expand(shape), b[0].expand(shape), c[0].expand(shape)
    d = torch.ones_like(a) if d is None else d[0].expand(shape)
    seed = r[..., L].expand(shape)
    N = a * seed + b
    D = c * seed + d
    d2 = D.real * D.real + D.imag * D.imag
    tiny = torch.finfo(d2.dtype).tiny
    if not torch.compiler.is_compiling() and bool(((d2 < tiny) | (d2 > 1 / tiny)).any()):
        return None
    Rr = (N.real * N.real + N.imag * N.imag) / d2
    decay = torch.exp(-2 * (phi.imag.sum(-1)))  # ∏|e₂| over the films, [*batch]
    tau2 = t2.prod(-1) * decay / d2
    return Rr, tau2.expand(shape)


def _fold_last(a, b, c, d):
    """The last two matrices replaced by their product (the count drops by one)."""
    a1, a2, b1, b2, c1, c2 = a[-2], a[-1], b[-2], b[-1], c[-2], c[-1]
    if d is None:
        m = (a1 * a2 + b1 * c2, a1 * b2 + b1, c1 * a2 + c2, c1 * b2 + 1)
        ones = torch.ones_like(a)
        return tuple(torch.cat([x[:-2], y[None]]) for x, y in zip((a, b, c, ones), m))
    d1, d2 = d[-2], d[-1]
    m = (a1 * a2 + b1 * c2, a1 * b2 + b1 * d2, c1 * a2 + d1 * c2, c1 * b2 + d1 * d2)
    return tuple(torch.cat([x[:-2], y[None]]) for x, y in zip((a, b, c, d), m))
