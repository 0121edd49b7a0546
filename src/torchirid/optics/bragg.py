r"""Bragg mirrors (1-D photonic crystals): Yeh's closed form (Fourneau et al. 2024, §3.1, app. D).

The mirror is exactly the stack

    ``n_incident | (n2, d2), (n1, d1)`` repeated ``N = cells`` times ``| n1`` (semi-infinite),

lit from the host medium at incidence cosine ``cos_theta``; ``n_incident = None`` means
``n_incident = n1`` (eq. 2–10), otherwise appendix D's infinitesimal host layer is added:
:math:`r_{hN} = (r_N + r_{h1})/(1 + r_{h1} r_N)`.

With :math:`a = k_{1z} d_1`, :math:`b = k_{2z} d_2` and the admittances η (η = q for s,
η = q/n² for p, q = n cos θ) the unit cell's transfer matrix gives the dispersion relation

.. math::  \cos KΛ = \cos a \cos b - \tfrac12 Ω \sin a \sin b, \qquad Ω = η_1/η_2 + η_2/η_1 \quad (8)

and :math:`|C|^2 = \tfrac14 Δ^2 \sin^2 b`, :math:`Δ = η_1/η_2 - η_2/η_1`, so that Yeh's
reflectance (eq. 2 and 9) is

.. math::  R = \frac{|C|^2 U_{N-1}^2}{1 + |C|^2 U_{N-1}^2}, \qquad U_{N-1}(\cos KΛ) = \frac{\sin NKΛ}{\sin KΛ},

with :math:`U_{N-1}` the Chebyshev polynomial of the second kind (``sinh`` form in band gaps).

Numerics (the hard cases are the product):

* ``1 ∓ cos KΛ`` are evaluated from product forms
  :math:`1 - \cos KΛ = 2\sin^2\frac{a+b}{2} + \tfrac12(η_1-η_2)^2 m_1 m_2 k_0^2 d_1 d_2\,\mathrm{sinc}\,a\,\mathrm{sinc}\,b`
  (``m = q/η``), free of the cancellation of ``1 − cos KΛ`` near band edges;
* at band edges ``|cos KΛ| = 1`` the 0/0 of ``sin NKΛ / sin KΛ`` is replaced by its Taylor
  series in ``ε = 1 − |cos KΛ|`` (both sides), so values *and gradients* are finite there;
* in band gaps (|cos KΛ| = cosh t) only ``e^{-2Nt}`` is formed, through ``expm1``:
  R = P²m²/(P²m² + 4Q² sinh²t (1 + m)) with m = e^{-2Nt} − 1 — no overflow for N = 10⁶;
* grazing incidence (``η₁ = 0``) is handled by scaling numerator and denominator by ``2η₁``
  and writing ``sin a / a`` as sinc, so R → 1 without 0·∞;
* all of the above is real arithmetic (the common lossless, propagating case; see
  docs/performance.md for its speed).  Light evanescent in n1 or n2 (total internal reflection) and
  absorbing layers go through an exact scattering-matrix evaluation: the cell's
  (r, r', t) are combined by Redheffer star products with binary exponentiation in
  ``⌈log₂ N⌉`` steps, which forms only decaying exponentials.
"""

from __future__ import annotations

import math

import torch

from .. import _autograd, _checks, _chunks, _compile
from .fresnel import interface, normal_wavenumber, same_medium

__all__ = ["bragg_reflectance", "bragg_dispersion", "bragg_envelope"]

# N²|ε| below which U_{N-1}, T_N are taken from their Taylor series at the band edge:
# the neglected term is ~(2N²ε)³/5040 < 1e-17 relative.
_EDGE_SERIES = 5e-5


# ----------------------------------------------------------------------------------------
# argument handling
# ----------------------------------------------------------------------------------------
_NO_CELLS = object()


def _prepare(wavelength, cos_theta, n1, n2, d1, d2, n_incident, cells=_NO_CELLS):
    """The arguments as checked tensors ``(dtype, lam, c, n1, n2, d1, d2, nh, N)``; ``nh`` None for a
    mirror lit from n1 (also when ``n_incident`` equals n1); ``wavelength`` None: no wavelength."""
    dtype, device = _checks.resolve_dtype_device(wavelength, cos_theta, n1, n2, d1, d2, n_incident)
    lam = None if wavelength is None else _checks.as_real(wavelength, "wavelength", dtype, device)
    c = _checks.as_real(cos_theta, "cos_theta", dtype, device)
    n1 = _checks.as_index(n1, "n1", dtype, device)
    n2 = _checks.as_index(n2, "n2", dtype, device)
    d1 = _checks.as_real(d1, "d1", dtype, device)
    d2 = _checks.as_real(d2, "d2", dtype, device)
    nh = None if n_incident is None else _checks.as_index(n_incident, "n_incident", dtype, device)
    N = None if cells is _NO_CELLS else _checks.as_cells(cells, device)
    if lam is not None:
        _checks.check_wavelength(lam)
    _checks.check_cosine(c)
    _checks.check_nonnegative(d1, "d1")
    _checks.check_nonnegative(d2, "d2")
    _checks.check_index(n1, "n1")
    _checks.check_index(n2, "n2")
    if nh is not None:
        _checks.check_real_index(nh, "n_incident")
        nh = nh.real if nh.is_complex() else nh
        # a host equal to n1 is the plain mirror (appendix D's host layer then changes nothing, to
        # ~1e-15): take the cheaper n_incident = None path, unless n_incident carries a gradient or a shape
        if (not nh.requires_grad and not n1.is_complex() and (nh.dim() == 0 or nh.shape == n1.shape)
                and bool((nh == n1).all())):
            nh = None
    elif n1.is_complex() and bool((n1.imag != 0).any()):
        raise ValueError("n1 must be real when n_incident is None (n1 is then the incident medium)")
    return dtype, lam, c, n1, n2, d1, d2, nh, N


def prepare_bragg_mirror(cos_theta, n1, n2, d1, d2, cells, n_incident=None):
    """The mirror arguments of :func:`bragg_reflectance`, converted and checked once, for a caller
    that evaluates the mirror over wavelengths of its own (the Bragg colour): ``(dtype, c, n1, n2,
    d1, d2, nh, N)``, to pass to :func:`bragg_reflectance_kernel` with a wavelength tensor of
    ``dtype``. Raises the ValueErrors of :func:`bragg_reflectance`."""
    dtype, _, c, n1, n2, d1, d2, nh, N = _prepare(None, cos_theta, n1, n2, d1, d2, n_incident, cells)
    return dtype, c, n1, n2, d1, d2, nh, N


#: the arguments whose shapes broadcast (named in the error of those that do not)
_ARGUMENTS = ("wavelength", "cos_theta", "n1", "n2", "d1", "d2", "cells", "n_incident")


def bragg_reflectance_kernel(lam, c, n1, n2, d1, d2, nh, N, *, polarization, n_max=None):
    """:func:`bragg_reflectance` of checked arguments (:func:`prepare_bragg_mirror`, a wavelength
    tensor in nm of their dtype, a valid ``polarization``; ``n_max``: the largest cell count if known
    as a Python int), with no checks: block by block over large batches (``torchirid._chunks``)."""
    batch = _checks.broadcast_shapes(lam.shape, c.shape, n1.shape, n2.shape, d1.shape, d2.shape, N.shape,
                                     () if nh is None else nh.shape, names=_ARGUMENTS)
    return _chunks.evaluate(_bragg_core, (lam, c, n1, n2, d1, d2, nh, N), batch, polarization=polarization,
                            n_max=n_max)


# ----------------------------------------------------------------------------------------
# Chebyshev factors U_{N-1}(y), T_N(y) of y = |cos KΛ| = 1 - ε, stable for every ε and N
# ----------------------------------------------------------------------------------------
def _edge_series(N, e):
    """U_{N-1}(1+e) and T_N(1+e) by their Taylor series at the band edge y = 1."""
    N2 = N * N
    U = N * (1 + (N2 - 1) * e / 3 + (N2 - 1) * (N2 - 4) * e * e / 30)
    T = 1 + N2 * e + N2 * (N2 - 1) * e * e / 6
    return U, T


def _chebyshev(eps, N):
    """Scaled Chebyshev pair for y = 1 - eps ≥ 0.

    Returns ``(u, t, gap)``: in the pass band (``eps > 0``) ``u = U_{N-1}(y)`` and
    ``t = T_N(y)``; in a band gap (``gap``) ``u = 1/U_{N-1}(y)`` and ``t = T_N(y)/U_{N-1}(y)``
    (everything divided by the overflowing U).  Near the edges both come from the series.
    """
    one = torch.ones_like(eps)
    near = (N * N) * eps.abs() < _EDGE_SERIES
    gap = eps < 0
    pas = ~gap & ~near
    gp = gap & ~near
    # guard: every branch gets inputs that are valid for it, so backward never sees NaN
    e_near = torch.where(near, -eps, torch.zeros_like(eps))
    Us, Ts = _edge_series(N, e_near)

    ep = torch.where(pas, eps, one)  # pass band: y = cos θ, θ ∈ (0, π/2]
    theta = 2 * torch.asin(torch.sqrt(0.5 * ep))
    sin_t = torch.sqrt(ep * (2 - ep))
    Up = torch.sin(N * theta) / sin_t

    eg = torch.where(gp, -eps, one)  # band gap: y = cosh t, t > 0
    sinh_t = torch.sqrt(eg * (2 + eg))
    t = torch.log1p(eg + sinh_t)
    ex = torch.exp(-N * t)
    den = -torch.expm1(-2 * N * t)  # 1 - e^{-2Nt}, accurate for small Nt
    inv_U = 2 * sinh_t * ex / den

    u = torch.where(near, torch.where(gap, 1 / Us, Us), torch.where(gap, inv_U, Up))
    Tp = torch.cos(N * theta)
    tau = sinh_t * (1 + ex * ex) / den  # T/U = sinh t · coth(Nt)
    t_ = torch.where(near, torch.where(gap, Ts / Us, Ts), torch.where(gap, tau, Tp))
    return u, t_, gap


# ----------------------------------------------------------------------------------------
# the real-arithmetic closed form (lossless, propagating in n1 and n2)
# ----------------------------------------------------------------------------------------
def _sin_over_q(phase, q, k0d, zero_possible):
    """sin(phase) and sin(phase)/q = k0 d sinc(phase) for phase = k0 q d.

    Where q = 0 (grazing in that medium) the quotient is k0 d; the guarded form (taken when
    such points exist) keeps values and gradients finite there.
    """
    s = torch.sin(phase)
    if not zero_possible:
        return s, s * q.reciprocal()  # 1/q is small (angle-only), one product on the grid
    zero = phase == 0
    # guard: phase = 0 at grazing or zero thickness; the unused branch gets a safe divisor
    safe = torch.where(zero, torch.ones_like(phase), phase)
    return s, torch.where(zero, k0d.expand_as(phase) if k0d.shape != phase.shape else k0d, s * k0d / safe)


def _any_below(q1, q2, tiny) -> bool:
    """Whether some q of ``q1``, ``q2`` (≥ 0, real) lies below ``tiny`` (NaN does not, nor hides one)."""
    v1, v2 = _checks.small_values(q1), _checks.small_values(q2)
    if v1 is not None and v2 is not None:  # a few values: read them
        return any(v < tiny for v in v1 + v2)
    return bool((q1 < tiny).any()) or bool((q2 < tiny).any())


class _RealCell:
    """Polarization-independent per-point quantities of the real closed form.

    ``a = k0 q1 d1``, ``b = k0 q2 d2``, ``sh, ch = sin, cos((a+b)/2)`` (for the
    cancellation-free forms of 1 ∓ cos KΛ).  ``sin a / q1`` and ``sin b / q2`` must stay
    finite at grazing (q = 0): where some q is (nearly) 0 they are formed as ``k0 d sinc``
    on the grid; otherwise the 1/q factors stay on the small angle-only tensors and are
    folded into the coefficients (``G = g_scale · G_raw = sin a sin b / (q1 q2)``,
    ``sin b / q2 = b_scale · sb_raw``), which saves two passes over the grid.
    """

    def __init__(self, lam, q1, q2, d1, d2, need_cos, static=False):
        k0 = lam.reciprocal() * (2 * math.pi)  # (= 2π / λ, without torch's Python wrapper of __rtruediv__)
        # small (angle-only) tensors first, then one product on the grid
        qd1, qd2 = q1 * d1, q2 * d2
        self.a = k0 * qd1
        self.b = k0 * qd2
        # static (compiled) kernels take the guarded branch unconditionally: no data-dependent control flow
        # (tiny q too: 1/q overflows or k0 q d underflows below √(smallest normal)); a NaN elsewhere in
        # the batch does not hide a grazing point (a minimum over the batch would be NaN)
        guarded = static or _any_below(q1, q2, torch.finfo(lam.dtype).tiny ** 0.5)
        if guarded:
            self.sin_a, self.sa_q1 = _sin_over_q(self.a, q1, k0 * d1, True)
            self.sin_b, self.sb_q2 = _sin_over_q(self.b, q2, k0 * d2, True)
            self.G_raw, self.g_scale = self.sa_q1 * self.sb_q2, 1.0
            self.sb_raw, self.b_scale = self.sb_q2, 1.0
        else:
            self.sin_a, self.sin_b = torch.sin(self.a), torch.sin(self.b)
            self._q1, self._q2 = q1, q2
            self.G_raw, self.g_scale = self.sin_a * self.sin_b, (q1 * q2).reciprocal()
            self.sb_raw, self.b_scale = self.sin_b, q2.reciprocal()
        half = k0 * (0.5 * (qd1 + qd2))
        self.sh = torch.sin(half)
        self.ch = torch.cos(half)
        if need_cos:
            self.cos_a = torch.cos(self.a)
            self.cos_b = torch.cos(self.b)

    def __getattr__(self, name):  # sin a / q1 and sin b / q2 on the grid, only when asked for
        if name == "sa_q1":
            self.sa_q1 = self.sin_a * self._q1.reciprocal()
            return self.sa_q1
        if name == "sb_q2":
            self.sb_q2 = self.sin_b * self._q2.reciprocal()
            return self.sb_q2
        raise AttributeError(name)


def _admittance_factors(pol, q1, q2, n1, n2, nd=None, squares=None):
    """(η1, η2, m1, m2) with η = q/m, m = 1 (s) or n² (p) (``squares``: n1², n2² if at hand).

    ``pol = ("s", "p")``: both on a new leading polarization axis (m = [1, n²], aligned to a batch
    of ``nd`` dims), so that every later op runs once for both; the s entries are the s values
    (q / 1 and x · 1 are exact)."""
    if pol == "s":
        return q1, q2, 1.0, 1.0  # Python constants: no tensor ops spent on multiplying by one
    m1, m2 = (n1 * n1, n2 * n2) if squares is None else squares
    if not isinstance(pol, str):
        one = torch.ones_like(m1)
        m1 = _with_s(m1, one, nd)
        m2 = _with_s(m2, one if one.shape == m2.shape else torch.ones_like(m2), nd)
    return q1 / m1, q2 / m2, m1, m2


def _with_s(m, one, nd):
    """``[1, m]`` (``one``: ones of m's shape) on a new leading axis, its other axes aligned to a
    batch of ``nd`` dims."""
    m = torch.stack((one, m))
    return m if m.ndim == nd + 1 else m.reshape(2, *([1] * (nd + 1 - m.ndim)), *m.shape[1:])


#: polarization groups of the real closed form (no host layer): both in one pass on a leading axis
#: for batches up to this many points (dispatch-bound), one after the other on larger ones
_STACKED_POINTS = 4096


def _one_minus_x(cell, eta1, eta2, m1, m2, inplace=False):
    """(1 - cos KΛ, 1 + cos KΛ) from the cancellation-free product forms.

    ``inplace`` (no autograd) reuses the temporaries: same values, fewer passes over memory.
    """
    d = eta1 - eta2
    D = (0.5 * (d * d) * (m1 * m2) * cell.g_scale) * cell.G_raw
    omx = torch.addcmul(D, cell.sh, cell.sh, value=2)
    opx = D.neg_().addcmul_(cell.ch, cell.ch, value=2) if inplace else torch.addcmul(-D, cell.ch, cell.ch, value=2)
    return omx, opx


def yeh_reflectance_kernel(P2, Q2, eps, N, safe, static=False):
    r"""Yeh's R = P²U²/(P²U² + Q²), U = U_{N-1}(1 − ε), for pass bands and gaps alike
    (Fourneau et al. 2024 eq. 5–10): the unvalidated kernel of :func:`bragg_reflectance`.

    Inputs are real tensors of one dtype/device: ``P2``, ``Q2`` the squared coefficients of
    eq. 9–10, ``eps`` = 1 − |cos KΛ| (signed: < 0 in a band gap), ``N`` the cell count;
    ``safe`` keeps gradients finite (no in-place temporaries), ``static`` makes the control
    flow data-independent (for ``torch.compile``).

    With W = ε(2 − ε) (= sin²θ in a pass band, −sinh²t in a gap) and r = √|W|:

    * pass band (ε > 0, |cos KΛ| = cos θ): θ = atan2(r, 1 − ε) and
      R = P² sin²Nθ / (P² sin²Nθ + Q² W);
    * band gap (ε < 0, |cos KΛ| = cosh t): t = log1p(r − ε), m = expm1(−2Nt) and
      R = P² m² / (P² m² − 4 Q² W (1 + m)); nothing overflows for any N;
    * near the edge (N²|ε| small) U comes from its Taylor series, so values and gradients
      stay finite at |cos KΛ| = 1.

    Both branches are evaluated on valid inputs (also faster: NaN-producing inputs take
    slow paths in the vector math library).
    """
    abs_eps = eps.abs()
    # A few points on the CPU with a Python cell count (one float64 count): read ε and take only
    # the branch every point needs (the band-edge series only if some point is near an edge, the
    # pass-band or gap formula alone if all points lie in one) — the values of the masked form.
    values = None
    if not (static or torch.is_tensor(N)) and _checks.reads_cheaply(eps):
        values = _checks.small_values(eps)
    if values is not None:
        threshold = 1.0 / (N * N) * _EDGE_SERIES  # (= the tensor form below: reciprocal, then product)
        has_near = any(abs(v) < threshold for v in values)  # (NaN is not near, nor in a gap)
        near = abs_eps < threshold if has_near else None
        regime = "pass" if not any(v < 0 for v in values) else "gap" if all(v < 0 for v in values) else None
    else:
        # (N a tensor, or a Python number read from a one-element float64 count: the same threshold)
        near = abs_eps < ((N * N).reciprocal() if torch.is_tensor(N) else 1.0 / (N * N)) * _EDGE_SERIES
        has_near = static or _checks.any_true(near)
        regime = None
    gap = eps < 0 if regime is None or has_near else None
    # no autograd (and cells not broadcasting beyond the grid): temporaries may be overwritten
    inplace = not (safe or static) and _checks.broadcast_shapes(eps.shape, getattr(N, "shape", ())) == eps.shape
    absW = abs_eps.mul_(torch.rsub(eps, 2)) if inplace else abs_eps * torch.rsub(eps, 2)  # |W|, 2 - ε > 0 always
    if safe and has_near:
        # guard: sqrt'(0) = inf at the edge itself, where the series is used instead
        absW = torch.where(near, torch.ones_like(absW), absW)
    r = torch.sqrt(absW)
    if regime == "pass":  # sin Nθ, |W| / 4
        F = torch.atan2(r, torch.rsub(eps, 1)).mul_(N).sin_() if inplace else torch.sin(N * torch.atan2(r, torch.rsub(eps, 1)))
        Yw = absW * 0.25
        num = F.mul_(F).mul_(P2) if inplace else P2 * (F * F)
    elif regime == "gap":  # e^{-2Nt} - 1, 4|W|e^{-2Nt} / 4
        if inplace:
            F = r.sub_(eps).log1p_().mul_(-2 * N).expm1_()
            Yw = torch.add(F, 1).mul_(absW)
            num = F.mul_(F).mul_(P2)
        else:
            F = torch.expm1((-2 * N) * torch.log1p(r - eps))
            Yw = absW * (1 + F)
            num = P2 * (F * F)
    elif inplace:
        s = torch.atan2(r, torch.rsub(eps, 1)).mul_(N).sin_()  # pass band: sin Nθ
        m = r.sub_(eps).log1p_().mul_(-2 * N).expm1_()  # band gap: e^{-2Nt} - 1
        F = torch.where(gap, m, s)
        Yw = torch.where(gap, m.add_(1), 0.25).mul_(absW)  # (gap: 4|W|e^{-2Nt}, pass: |W|) / 4
        num = F.mul_(F).mul_(P2)
    else:
        s = torch.sin(N * torch.atan2(r, torch.rsub(eps, 1)))
        m = torch.expm1((-2 * N) * torch.log1p(r - eps))
        F = torch.where(gap, m, s)
        Yw = absW * torch.where(gap, 1 + m, 0.25)
        num = P2 * (F * F)
    den = torch.addcmul(num, 4 * Q2, Yw)
    if has_near:
        e_near = torch.where(near, -eps, torch.zeros_like(eps))
        Us, _ = _edge_series(N, e_near)
        num_n = P2 * Us * Us
        num = torch.where(near, num_n, num)
        den = torch.where(near, num_n + Q2, den)
    if static or not _checks.nonzero(Q2):
        # guard: den = 0 only at grazing (Q = 0) with a vanishing numerator: R = 1 (grazing)
        # unless the cell is invisible (P = 0: no index contrast, or a zero/half-wave n2 layer)
        limit = (P2 > 0).to(den.dtype).expand_as(den)
        degenerate = den == 0  # (NaN is not degenerate: it propagates)
        return torch.where(degenerate, limit, num / torch.where(degenerate, torch.ones_like(den), den))
    return num / den


def _needs_grad(*ts):
    return torch.is_grad_enabled() and any(isinstance(t, torch.Tensor) and t.requires_grad for t in ts)


def _layer_q(n, nsq, host, qh, s2, safe, propagating=False):
    """q = n cos θ = √max(n² − s², 0) of a layer (``nsq = n * n``) on the real path, exactly ``qh``
    where ``n`` is the host index (exact even where cos² θ underflows); ``safe``: a gradient may flow
    (√ guarded at 0); ``propagating``: n² ≥ s² is known everywhere (no clamp)."""
    x = nsq - s2
    # (n² − s² is never −0, so √max(x, 0) is safe_sqrt's value: 0 where x ≤ 0, NaN kept)
    q = _checks.safe_sqrt(x) if safe else torch.sqrt(x if propagating else x.clamp(min=0))
    if n.numel() == 1 and host.numel() == 1 and _checks.reads_cheaply(n):  # one index each: compare them here
        return q if not n.item() == host.item() else same_medium(n == host, qh, q)
    same = n == host
    return q if _checks.known_false(same) else same_medium(same, qh, q)


def _cell_count(N, dtype):
    """The cell count in ``dtype`` for the closed form: a Python float when one float64 count can be
    read cheaply (its products with N are then Python arithmetic, the same values as in float64
    tensors), else the tensor."""
    if dtype == torch.float64 and N.numel() == 1 and _checks.reads_cheaply(N):
        return float(N.item())
    return N.to(dtype)


def _real_reflectance(lam, c, n1, n2, d1, d2, nh, N, polarization, static=False, propagating=False):
    """R on the real path; entries that are not lossless-propagating are garbage (masked later).
    ``propagating``: light is known to propagate in n1 and n2 everywhere (:func:`_propagating`)."""
    host = n1 if nh is None else nh
    squares = n1 * n1, n2 * n2
    s2 = (squares[0] if nh is None else nh * nh) * torch.rsub(c * c, 1)  # (rsub: 1 − c² without torch's Python wrapper)
    qh = host * c  # exact in the incident medium: R → 1 at grazing without a sqrt
    # a layer of exactly the host index gets qh itself (exact even where cos² θ underflows)
    safe = static or _needs_grad(lam, c, n1, n2, d1, d2, nh)
    q1 = qh if nh is None else _layer_q(n1, squares[0], nh, qh, s2, safe, propagating)
    q2 = _layer_q(n2, squares[1], host, qh, s2, safe, propagating)
    cell = _RealCell(lam, q1, q2, d1, d2, need_cos=nh is not None, static=static)
    Nf = _cell_count(N, lam.dtype)
    if nh is None:
        pols = _checks.POLARIZATION_TERMS[polarization]
        nd = max(t.ndim for t in (lam, c, n1, n2, d1, d2, N))
        points = math.prod(_checks.broadcast_shapes(lam.shape, c.shape, n1.shape, n2.shape, d1.shape, d2.shape, N.shape))
        groups = [pols] if len(pols) == 2 and not static and points <= _STACKED_POINTS else pols
        out = []
        for pol in groups:
            eta1, eta2, m1, m2 = _admittance_factors(pol, q1, q2, n1, n2, nd, squares)
            inplace = not (safe or static)
            omx, opx = _one_minus_x(cell, eta1, eta2, m1, m2, inplace)
            eps = torch.minimum(omx, opx, out=omx) if inplace else torch.minimum(omx, opx)  # 1 - |cos KΛ|
            # |C| U scaled by 2η1: P = (η1² - η2²) m2 sin b / q2, Q = 2 η1
            e1sq = eta1 * eta1
            P = ((e1sq - eta2 * eta2) * m2 * cell.b_scale) * cell.sb_raw
            out.append(yeh_reflectance_kernel(P.square_() if inplace else P * P, 4 * e1sq, eps, Nf, safe, static))
        if len(out) == 2:
            return 0.5 * (out[0] + out[1])  # R ≤ 1 by construction
        return out[0] if len(pols) == 1 else out[0].sum(0) * 0.5  # (s, p stacked: their mean)
    out = []
    for pol in _checks.POLARIZATION_TERMS[polarization]:
        eta1, eta2, m1, m2 = _admittance_factors(pol, q1, q2, n1, n2)
        omx, opx = _one_minus_x(cell, eta1, eta2, m1, m2)
        eps = torch.minimum(omx, opx)  # 1 - |cos KΛ|
        # |C| U scaled by 2η1: P = (η1² - η2²) m2 sin b / q2, Q = 2 η1
        P = ((eta1 * eta1 - eta2 * eta2) * m2) * cell.sb_q2
        Q = 2 * eta1
        u, t, gap = _chebyshev(eps, Nf)
        sgn = torch.where(omx <= opx, 1.0, -1.0).to(eps.dtype)  # sign of cos KΛ
        T = sgn * t
        U = torch.where(gap, torch.ones_like(u), u)
        # Q·W with W = sin a cos b + Ω/2 cos a sin b  (½(A − D) = −iW)
        Wq = (2 * eta1 * eta1 * m1) * cell.sa_q1 * cell.cos_b + ((eta1 * eta1 + eta2 * eta2) * m2) * cell.sb_q2 * cell.cos_a
        qh = nh * c
        if pol == "s":
            eh, e1h = qh, q1
        else:
            eh, e1h = qh / (nh * nh), q1 / (n1 * n1)
        rh1 = interface(eh, e1h)
        PU = P * U
        # r_hN = (r_h1 den_N + num_N)/(den_N + r_h1 num_N), num_N = PU(-sin a - i cos a), den_N = QT - i Wq U
        X1 = rh1 * Q * T - PU * cell.sin_a
        Y1 = -rh1 * Wq * U - PU * cell.cos_a
        X2 = Q * T - rh1 * PU * cell.sin_a
        Y2 = -Wq * U - rh1 * PU * cell.cos_a
        num = X1 * X1 + Y1 * Y1
        den = X2 * X2 + Y2 * Y2
        degenerate = den == 0  # (NaN is not degenerate: it propagates)
        # guard: den = 0 only exactly at grazing in n1 with a vanishing numerator: R = 1, unless
        # the cells are invisible (P = 0) and only the host/n1 interface remains: R = r_h1²
        limit = torch.where(P * P > 0, torch.ones_like(rh1), rh1 * rh1).expand_as(den)
        out.append(torch.where(degenerate, limit, num / torch.where(degenerate, torch.ones_like(den), den)))
    R = out[0] if len(out) == 1 else 0.5 * (out[0] + out[1])
    return R.clamp(0, 1)  # float32 rounding can leave R an ulp outside [0, 1]


def _real_reflectance_static(lam, c, n1, n2, d1, d2, nh, N, polarization):
    """The real closed form without data-dependent branches (for ``torch.compile``)."""
    return _real_reflectance(lam, c, n1, n2, d1, d2, nh, N, polarization, static=True)


# ----------------------------------------------------------------------------------------
# the general path: scattering matrices, binary exponentiation (absorbing / evanescent)
# ----------------------------------------------------------------------------------------
def _star(A, B):
    """Redheffer star product of two reciprocal stacks given as (r, r', t), A on top."""
    rA, rpA, tA = A
    rB, rpB, tB = B
    den = 1 - rpA * rB
    if _checks.traceable() or bool((den == 0).any()):
        # guard: den = 0 needs |r'_A| = |r_B| = 1, hence t_A = t_B = 0 (lossless total
        # reflection, e.g. grazing): the two stacks do not see each other
        degenerate = den == 0
        den = torch.where(degenerate, torch.ones_like(den), den)
        zero = torch.zeros_like(den)
        return (torch.where(degenerate, rA, rA + tA * tA * rB / den),  # (where broadcasts: any shapes)
                torch.where(degenerate, rpB, rpB + tB * tB * rpA / den),
                torch.where(degenerate, zero, tA * tB / den))
    tt = tA * tB / den
    return rA + tA * tA * rB / den, rpB + tB * tB * rpA / den, tt


def _general_reflectance(lam, c, n1, n2, d1, d2, nh, N, polarization, n_max=None):
    cdt = _checks.complex_dtype(lam.dtype)
    n1c, n2c = n1.to(cdt), n2.to(cdt)
    host = n1.real if nh is None else nh
    s2 = host * host * (1 - c * c)
    qh = host * c
    q1 = qh.to(cdt) if nh is None else normal_wavenumber(n1c, s2, host, qh)
    q2 = normal_wavenumber(n2c, s2, host, qh)
    k0 = (2 * math.pi) / lam
    e1a = torch.exp(1j * (k0 * d1 * q1))  # |·| ≤ 1: only decaying exponentials
    e1b = torch.exp(1j * (k0 * d2 * q2))
    e2a, e2b = e1a * e1a, e1b * e1b
    bits = []
    Nmax = int(N.max()) if n_max is None else n_max  # (a Python int: no read-back under torch.compile)
    n = N.clone()
    for _ in range(max(1, Nmax.bit_length())):
        bits.append((n & 1).bool())
        n = n >> 1
    out = []
    for pol in _checks.POLARIZATION_TERMS[polarization]:
        if pol == "s":
            eta1, eta2 = q1, q2
        else:
            eta1, eta2 = q1 / (n1c * n1c), q2 / (n2c * n2c)
        r12 = interface(eta1, eta2)
        den = 1 - r12 * r12 * e2b
        # q2 = 0 (n2 exactly at its critical angle: r12 = 1, e^{2ib} = 1, a 0/0 up to rounding),
        # or den = 0 exactly (η1 = 0, grazing in n1, with a zero- or half-wave n2 layer)
        degenerate = (eta2 == 0) | (den == 0)
        if _checks.traceable() or bool(degenerate.any()):
            # guard: the slab's exact limit from its characteristic matrix
            # [[1, −iβ], [0, 1]], β = k0 d2 m2 (sin b / η2 as b, η2 → 0): r = −iη1β/(2 − iη1β),
            # t = 2 e^{ib}/(2 − iη1β);
            # it is r = 0, t = e^{ib} (an invisible zero- or half-wave slab) when η1 = 0
            m2 = 1 if pol == "s" else n2c * n2c
            ib = -1j * (k0 * d2 * m2) * eta1  # −iβη1
            lim_den = 2 + ib
            den = torch.where(degenerate, torch.ones_like(den), den)
            r_slab = torch.where(degenerate, ib / lim_den, r12 * (1 - e2b) / den)
            t_slab = torch.where(degenerate, 2 * e1b / lim_den, (1 - r12 * r12) * e1b / den)
        else:
            r_slab = r12 * (1 - e2b) / den
            t_slab = (1 - r12 * r12) * e1b / den
        base = (r_slab, r_slab * e2a, t_slab * e1a)  # cell: n2 slab then the n1 layer
        zero = torch.zeros_like(base[0])
        acc = (zero, zero, torch.ones_like(base[0]))
        for k, bit in enumerate(bits):
            prod = _star(acc, base)
            acc = tuple(torch.where(bit, p, a) for p, a in zip(prod, acc))
            if k + 1 < len(bits):
                base = _star(base, base)
        rN = acc[0]
        if nh is not None:
            qh = (nh * c).to(cdt)
            eh = qh if pol == "s" else qh / (nh * nh).to(cdt)
            rh1 = interface(eh, eta1)
            rN = (rh1 + rN) / (1 + rh1 * rN)
        out.append(rN.real ** 2 + rN.imag ** 2)
    R = out[0] if len(out) == 1 else 0.5 * (out[0] + out[1])
    return R.clamp(0, 1)


# ----------------------------------------------------------------------------------------
# public API
# ----------------------------------------------------------------------------------------
def _needs_general(c, n1, n2, nh):
    """Mask of points where the real closed form does not apply (absorption or evanescence)."""
    if n1.is_complex() or n2.is_complex():
        return None  # everything complex: use the general path throughout
    host = n1 if nh is None else nh
    s2 = host * host * (1 - c * c)
    evanescent = (n2 * n2 - s2) < 0
    if nh is not None:
        evanescent = evanescent | ((n1 * n1 - s2) < 0)
    return evanescent


@_autograd.inference_when_small  # (a few points without a gradient: no autograd bookkeeping)
def bragg_reflectance(
    wavelength, cos_theta, n1, n2, d1, d2, cells, *, n_incident=None, polarization: str = "unpolarized"
) -> torch.Tensor:
    r"""Reflectance of a Bragg mirror of ``cells`` periods (Yeh; Fourneau et al. 2024 eq. 2–10, app. D).

    The mirror is the stack ``n_incident | (n2, d2), (n1, d1) × cells | n1``; the cost does not
    depend on ``cells`` for lossless propagating light (the closed form), and grows as
    ``log₂ cells`` for absorbing layers or total internal reflection.

    Args:
        wavelength: vacuum wavelength λ in nm (> 0). Shape ``(*)``.
        cos_theta: cosine of the incidence angle in the host (incident) medium, in [0, 1].
        n1, n2: indices ``n + iκ`` (κ ≥ 0) of the two layers; n1 is also the semi-infinite
            medium below the mirror (and the incident medium when ``n_incident`` is None).
        d1, d2: layer thicknesses in nm (≥ 0); the period is Λ = d1 + d2.
        cells: number N ≥ 1 of (n2, n1) periods: an int or an integer tensor that broadcasts.
        n_incident: real index of the incident medium, or None for n1 (appendix D when ≠ n1).
        polarization: ``"s"``, ``"p"`` or ``"unpolarized"`` (mean of s and p).

    Returns:
        R in [0, 1], broadcast shape, real dtype of the inputs.

    Example (Fourneau Fig. 1: n2 = 1.5, d1 = 125, d2 = 375, N = 20, normal incidence):
        >>> import torch, torchirid
        >>> R = torchirid.bragg_reflectance(torch.tensor([680.0, 600.0], dtype=torch.float64), 1.0,
        ...                                 1.0, 1.5, 125.0, 375.0, 20)
        >>> [round(v, 6) for v in R.tolist()]
        [0.999998, 0.038657]
    """
    _checks.check_polarization(polarization)
    dtype, lam, c, n1, n2, d1, d2, nh, N = _prepare(wavelength, cos_theta, n1, n2, d1, d2, n_incident, cells)
    n_max = int(cells) if isinstance(cells, int) and not isinstance(cells, bool) else None
    return bragg_reflectance_kernel(lam, c, n1, n2, d1, d2, nh, N, polarization=polarization, n_max=n_max)


def _bragg_core(lam, c, n1, n2, d1, d2, nh, N, *, polarization, n_max):
    """:func:`bragg_reflectance` on validated tensors (one block of the batch)."""
    c = _checks.flush_grazing(c)
    batch = _checks.broadcast_shapes(lam.shape, c.shape, n1.shape, n2.shape, d1.shape, d2.shape, N.shape,
                                     () if nh is None else nh.shape)
    if n1.is_complex() or n2.is_complex():  # everything complex: the general path throughout
        return _general_reflectance(lam, c, n1, n2, d1, d2, nh, N, polarization,
                                    n_max if _checks.traceable() else None)
    if _checks.traceable():  # vmap / torch.compile: the static kernel, both paths where needed
        R = _real_reflectance(lam, c, n1, n2, d1, d2, nh, N, polarization, static=True)
        # (no data-dependent test of the mask: the general path is evaluated for every point)
        general = _needs_general(c, n1, n2, nh)
        return torch.where(general, _general_reflectance(lam, c, n1, n2, d1, d2, nh, N, polarization, n_max), R)
    real = _compile.kernel("bragg_real", _real_reflectance, _real_reflectance_static, math.prod(batch))
    propagating = _propagating(n1, n2, nh)
    if propagating and real is _real_reflectance:
        return real(lam, c, n1, n2, d1, d2, nh, N, polarization, propagating=True)
    R = real(lam, c, n1, n2, d1, d2, nh, N, polarization)
    if not propagating:
        general = _needs_general(c, n1, n2, nh)
        if _checks.any_true(general):
            Rg = _general_reflectance(lam, c, n1, n2, d1, d2, nh, N, polarization)
            R = torch.where(general, Rg, R)
    return R


def _propagating(n1, n2, nh) -> bool:
    """True when light is known to propagate in n1 and n2 at every angle, read from a few values on
    the CPU: real layers no lower than the incident index (then n² ≥ s² for every cos θ in [0, 1],
    also in floating point, where s² = n_h² (1 − cos² θ) rounds to at most n_h²); False when that
    cannot be told so cheaply (the caller then forms the mask)."""
    host = n1 if nh is None else nh
    if not _checks.reads_cheaply(host):
        return False
    layers = (n2,) if nh is None else (n1, n2)
    values = [_checks.small_values(t) for t in (host, *layers)]
    if any(not v or any(x != x for x in v) for v in values):  # (too many to read, none, or NaN)
        return False
    top = max(values[0])
    return all(min(v) >= top for v in values[1:])


def bragg_dispersion(wavelength, cos_theta, n1, n2, d1, d2, *, n_incident=None, polarization: str = "s") -> torch.Tensor:
    r"""Dispersion relation :math:`\cos KΛ = \cos a\cos b - \tfrac12 Ω \sin a \sin b` (Fourneau eq. 8).

    ``|cos KΛ| > 1`` marks a photonic band gap; band edges are where it equals ±1.

    Args:
        wavelength, cos_theta, n1, n2, d1, d2, n_incident: as in :func:`bragg_reflectance`.
        polarization: ``"s"`` or ``"p"`` (Ω depends on it, eq. 6–7).

    Returns:
        cos KΛ, real for lossless layers (also with evanescent ones), complex if an index is.

    Example (quarter-wave stack at its design wavelength: cos KΛ = −Ω/2):
        >>> import torch, torchirid
        >>> x = torchirid.optics.bragg_dispersion(torch.tensor(600.0, dtype=torch.float64), 1.0, 1.0, 1.5, 150.0, 100.0)
        >>> round(float(x), 6)
        -1.083333
    """
    if polarization not in ("s", "p"):
        raise ValueError(f"polarization must be 's' or 'p' for the dispersion relation; got {polarization!r}")
    dtype, lam, c, n1, n2, d1, d2, nh, _ = _prepare(wavelength, cos_theta, n1, n2, d1, d2, n_incident)
    c = _checks.flush_grazing(c)
    cdt = _checks.complex_dtype(dtype)
    complex_in = n1.is_complex() or n2.is_complex()
    general = _needs_general(c, n1, n2, nh)
    if not complex_in and not bool(general.any()):
        q1 = n1 * c if nh is None else torch.sqrt(torch.clamp(n1 * n1 - nh * nh * (1 - c * c), min=0))
        q2 = torch.sqrt(torch.clamp(n2 * n2 - (n1 if nh is None else nh) ** 2 * (1 - c * c), min=0))
        cell = _RealCell(lam, q1, q2, d1, d2, need_cos=False)
        omx, opx = _one_minus_x(cell, *_admittance_factors(polarization, q1, q2, n1, n2))
        # the more accurate of the two product forms
        return torch.where(omx <= opx, 1 - omx, opx - 1)
    n1c, n2c = n1.to(cdt), n2.to(cdt)
    host = n1.real if nh is None else nh
    s2 = host * host * (1 - c * c)
    qh = host * c
    q1 = qh.to(cdt) if nh is None else normal_wavenumber(n1c, s2, host, qh)
    q2 = normal_wavenumber(n2c, s2, host, qh)
    k0 = (2 * math.pi) / lam
    a, b = k0 * q1 * d1, k0 * q2 * d2
    eta1, eta2, m1, m2 = _admittance_factors(polarization, q1, q2, n1c, n2c)
    _, sa_q1 = _sin_over_q(a, q1, k0 * d1, True)
    _, sb_q2 = _sin_over_q(b, q2, k0 * d2, True)
    x = torch.cos(a) * torch.cos(b) - 0.5 * (eta1 * eta1 + eta2 * eta2) * m1 * m2 * sa_q1 * sb_q2
    return x if complex_in else x.real


def bragg_envelope(wavelength, cos_theta, n1, n2, d1, d2, *, n_incident=None, polarization: str = "unpolarized") -> torch.Tensor:
    r"""Reflectance envelope :math:`R^e = |C|^2 / (|C|^2 + \sin^2 KΛ)` (Fourneau eq. 11), 1 in band gaps.

    The large-N envelope of the oscillating Yeh spectrum, for a mirror embedded in n1
    (``n_incident`` only sets the angle: ``cos_theta`` is measured in the host medium).

    Args: as :func:`bragg_reflectance` without ``cells``.

    Returns:
        R^e in [0, 1]; for ``"unpolarized"`` the mean of the s and p envelopes.

    Example (inside the band gap of a quarter-wave stack at its design wavelength, R^e = 1):
        >>> import torch, torchirid
        >>> R = torchirid.optics.bragg_envelope(torch.tensor(600.0, dtype=torch.float64), 1.0, 1.0, 1.5, 150.0, 100.0)
        >>> float(R)
        1.0
    """
    _checks.check_polarization(polarization)
    dtype, lam, c, n1, n2, d1, d2, nh, _ = _prepare(wavelength, cos_theta, n1, n2, d1, d2, n_incident)
    if n1.is_complex() or n2.is_complex():
        raise ValueError("bragg_envelope needs real n1 and n2 (the envelope is defined for lossless layers)")
    if bool(_needs_general(c, n1, n2, nh).any()):
        raise ValueError("bragg_envelope needs light propagating in n1 and n2 (no total internal reflection)")
    c = _checks.flush_grazing(c)
    host = n1 if nh is None else nh
    s2 = host * host * (1 - c * c)
    q1 = n1 * c if nh is None else torch.sqrt(torch.clamp(n1 * n1 - s2, min=0))
    q2 = torch.sqrt(torch.clamp(n2 * n2 - s2, min=0))
    cell = _RealCell(lam, q1, q2, d1, d2, need_cos=False)
    out = []
    for pol in _checks.polarization_terms(polarization):
        eta1, eta2, m1, m2 = _admittance_factors(pol, q1, q2, n1, n2)
        omx, opx = _one_minus_x(cell, eta1, eta2, m1, m2)
        sin2 = omx * opx  # sin² KΛ = (1 - x)(1 + x), negative in a band gap
        P = (eta1 * eta1 - eta2 * eta2) * m2 * cell.sb_q2
        Q2 = 4 * eta1 * eta1
        num = P * P
        den = num + Q2 * sin2
        gap = sin2 <= 0
        safe = torch.where(gap | (den <= 0), torch.ones_like(den), den)
        out.append(torch.where(gap | (den <= 0), torch.ones_like(den), num / safe))
    return out[0] if len(out) == 1 else 0.5 * (out[0] + out[1])
