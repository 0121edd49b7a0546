r"""The ballistic transmission filter :math:`F_\alpha(\theta_i,\theta_d)` of a rough Bragg layer
(Fourneau et al. 2024 §4.2.2, eq. 24–29 and Appendix C), in closed form.

A rough Bragg layer transmits ballistically (eq. 22); its integrated transmissivity is a 1-D
filtering of the mirror transmittance over the difference angle
:math:`\theta_d = \angle(\mathbf i, \mathbf m)` (eq. 28),

.. math::

    f_t(\theta_i)\cos\theta_i = \int_0^{\pi/2} T_\lambda(\theta_d)\,F_\alpha(\theta_i,\theta_d)\,d\theta_d,
    \qquad
    F_\alpha = 2G_1^2(\theta_i)\frac{\cos\theta_d}{\cos\theta_i}\sin\theta_d
               \int_0^{\psi_{d\max}}\tilde D(\theta_m)\,d\psi_d            \quad (29)

with :math:`\cos\theta_m = a + b\cos\psi`, :math:`a = \cos\theta_i\cos\theta_d`,
:math:`b = \sin\theta_i\sin\theta_d` (eq. 24), the GGX lobe
:math:`\tilde D = \alpha^2/\bigl(\pi(1-\beta^2\cos^2\theta_m)^2\bigr)`, :math:`\beta^2 = 1-\alpha^2`
(eq. 18), and :math:`\psi_{d\max} = \arccos(-a/b)` when :math:`\theta_i+\theta_d\ge\pi/2`,
else :math:`\pi` (eq. 26). The paper tabulates the ψ integral numerically; it is elementary.

Derivation of the closed form
-----------------------------
Partial fractions in :math:`x = \cos\theta_m`:

.. math::

    \frac{1}{(1-\beta^2x^2)^2} = \frac14\Bigl[\frac{1}{(1-\beta x)^2}+\frac{1}{(1+\beta x)^2}
                                  +\frac{1}{1-\beta x}+\frac{1}{1+\beta x}\Bigr],

and each term is :math:`(p + q\cos\psi)^{-n}`, ``n ∈ {1, 2}``, with
:math:`p_\mp = 1\mp\beta a`, :math:`q_\mp = \mp\beta b`. Write
:math:`A = p+q` and :math:`B = p-q`: for the ``1 − βx`` term
:math:`A_- = 1-\beta\cos(\theta_i-\theta_d)`, :math:`B_- = 1-\beta\cos(\theta_i+\theta_d)`, for
``1 + βx`` the same with ``+β``. For ``0 < α ≤ 1``, ``A, B ≥ 1 − β > 0``. With
:math:`t = \tan(\Psi/2)` (Weierstrass):

.. math::

    J_1 = \int_0^\Psi\frac{d\psi}{p+q\cos\psi}
        = \frac{2}{\sqrt{AB}}\arctan\Bigl(\sqrt{B/A}\,\tan\tfrac\Psi2\Bigr)
        = \frac{\pi - 2\arctan\bigl(\rho\sqrt{A/B}\bigr)}{\sqrt{AB}},
    \qquad \rho = \cot\tfrac\Psi2,

    J_2 = \int_0^\Psi\frac{d\psi}{(p+q\cos\psi)^2}
        = \frac{p\,J_1}{AB} - \frac{q\sin\Psi}{AB\,(p+q\cos\Psi)}

(differentiate :math:`\sin\Psi/(p+q\cos\Psi)` to check the second). At the upper bound
:math:`\Psi = \psi_{d\max}`:

* no cut (:math:`\theta_i+\theta_d\le\pi/2`): :math:`\Psi = \pi`, ``ρ = 0``, ``sin Ψ = 0``;
* cut: :math:`\cos\theta_m(\Psi) = 0`, so :math:`p+q\cos\Psi = 1` exactly, and with
  :math:`P = \cos(\theta_i-\theta_d) = b+a`, :math:`Q = -\cos(\theta_i+\theta_d) = b-a > 0`:
  :math:`\rho^2 = \frac{1+\cos\Psi}{1-\cos\Psi} = Q/P`, :math:`\sin\Psi = 2\rho/(1+\rho^2)`.

So the ψ integral is :math:`I = \tfrac14(J_{2-}+J_{2+}+J_{1-}+J_{1+})` with
:math:`J_{2\mp} = (p_\mp J_{1\mp} \pm \beta b\sin\Psi)/(A_\mp B_\mp)`, ``p = (A + B)/2``, and

.. math::

    F_\alpha = \frac{2\alpha^2}{\pi}\,G_1(\theta_i)\,\frac{2}{\cos\theta_i+\sqrt{\cos^2\theta_i+\alpha^2\sin^2\theta_i}}
               \,\cos\theta_d\sin\theta_d\; I

(:math:`G_1/\cos\theta_i` written without the division, finite at grazing).

Numerics (the reason for each guard):

* ``A∓ = (1−β) + 2β sin²((θi ∓ θd)/2)`` and ``B = ... cos²(...)`` with
  ``1 − β = α²/(1 + β)``: no cancellation when ``α → 0`` and ``θd → θi``, where
  :math:`F \sim 1/\alpha` is largest (``1 − β cos x`` computed directly would lose all digits
  of ``α²/2`` for ``α < 1e-8``).
* ``Q = −cos(θi+θd) = sin(θi + θd − π/2)`` with the sum split by TwoSum and ``π/2`` in two
  parts: right of the kink ``F`` varies like :math:`\sqrt{Q}`, so a rounding error of the
  float sum (1e-16) would otherwise cost 1e-8 relative.
* ``ρ = √(Q/P)`` through a guarded square root: exactly on the kink the gradient is the
  one-sided (left) derivative instead of ``0·∞ = NaN``; everywhere else finite.
* ``α > 1`` (``β² < 0``): ``β = iγ``, the ``±`` terms are complex conjugates and
  :math:`I = \tfrac12\mathrm{Re}(J_{2-}+J_{1-})`, with
  :math:`J_1 = (\pi-2\arctan(\rho/r))/(A r)`, :math:`r = \sqrt{B/A}` (principal branch,
  ``Re r > 0``, so the arctangent never meets its cuts).

The C¹ kink at :math:`\theta_d = \pi/2-\theta_i` (eq. 26) is a one-sided square root:
:math:`F = F_\text{smooth} - C\sqrt{\theta_d-(\pi/2-\theta_i)} + \dots` on the right (the removed
ψ-range has width :math:`\propto\sqrt{\cdot}` and integrand :math:`\tilde D(\pi/2) = \alpha^2/\pi`),
so the right derivative is infinite there. Appendix C: :math:`\int_0^{\pi/2}F_\alpha\,d\theta_d = G_1(\theta_i)`.

Tables and quadrature
---------------------
Both follow the peak, centred at :math:`c = \sqrt{\theta_i^2 + \alpha^2/3}` (α/√3 at normal
incidence, ≈ θi beyond a few α; even in θi so everything stays smooth in cos θi):

* ``filter_quadrature()`` — Gauss–Legendre in two pieces split at the kink
  ``θd = π/2 − θi``, each through a sinh warp ``θd − c = 0.7α sinh ξ`` (w-spaced nodes in the
  core, log-uniform in the ``t⁻³`` tails, so the mirror poles at ``θd = −θi ± iα`` and
  ``π − θi ± iα`` stay at O(1) distance in ξ), the second piece also squared (``s = v²``) so
  the kink's square root is smooth. Measured (unnormalised) ``|Σw − G1|/G1`` over θi ≤ 89.5°:
  α = 0.01: 1e-4 / 9e-7 / 2e-9 / 1e-12 with K = 48 / 64 / 96 / 128; α ≥ 0.1: < 1e-7 from K = 32.
* :func:`transmission_filter_lut` — axes ``(θi, u)``, ``θd = c + α tan(g_0 + u (g_1 − g_0))``
  (a Cauchy warp of all of ``[0, π/2]``; closed-form inverse for queries), storing
  ``F + S`` where the closed-form *kink term* ``S`` (``_cut_term``: what the cut of
  eq. 26 removes, integrand frozen at ``cos θm = 0``) cancels the square root; the call
  subtracts ``S`` again. Aligning the grid with the kink instead (u = 1 at the kink) fails
  near θi = 45°, where peak and kink move through each other at relative speed 2 (measured
  2.8e-2 of the peak for α = 0.025 at 0.25° steps). θi and u intervals are bisected where
  the midpoint error exceeds ``rtol`` (checked against the closed form).
"""

from __future__ import annotations

import math

import numpy as np
import torch

from .. import _checks, _chunks
from .._quadrature import gauss_legendre01
from . import _geometry

__all__ = ["transmission_filter"]  # the 2-D table: layered.filter_lut

_HALF_PI = math.pi / 2


def _half_pi_parts(dtype) -> tuple[float, float]:
    """π/2 = hi + lo with hi the nearest ``dtype`` number (lo its rounding error, as a float)."""
    hi = float(torch.tensor(_HALF_PI, dtype=dtype))
    lo = float(np.float64(_HALF_PI) - np.float64(hi)) if dtype != torch.float64 else 6.123233995736766e-17
    return hi, lo


def _kink_offset(ti: torch.Tensor, td: torch.Tensor) -> torch.Tensor:
    """δ = θi + θd − π/2 to the last bit (TwoSum of θi + θd, π/2 in two parts).

    ``δ > 0`` ⇔ part of the ψ circle is cut (eq. 26); ``Q = −cos(θi + θd) = sin δ``.
    """
    hi, lo = _half_pi_parts(ti.dtype)
    s = ti + td
    bp = s - ti
    err = (ti - (s - bp)) + (td - bp)  # exact rounding error of the sum (Knuth TwoSum)
    return (s - hi) + (err - lo)  # s − hi is exact (Sterbenz) wherever δ is small


def _safe_sqrt(x: torch.Tensor, positive: torch.Tensor) -> torch.Tensor:
    """√x where ``positive``, else 0, with a finite (zero) gradient where not positive."""
    return torch.where(positive, torch.sqrt(torch.where(positive, x, torch.ones_like(x))), torch.zeros_like(x))


def _psi_integral_real(ti, td, b, rho, sin_psi, alpha):
    r"""``I = ∫₀^Ψ dψ / (1 − β² cos²θm)²`` for ``0 < α ≤ 1`` (real arithmetic)."""
    beta2 = (1.0 - alpha) * (1.0 + alpha)  # β² = 1 − α²
    beta = _safe_sqrt(beta2, beta2 > 0)  # α = 1: β = 0 (guarded: sqrt'(0) = ∞)
    one_m_beta = alpha * alpha / (1.0 + beta)  # 1 − β without cancellation
    sm = torch.sin(0.5 * (ti - td))
    sp = torch.sin(0.5 * (ti + td))
    cm = torch.cos(0.5 * (ti - td))
    cp = torch.cos(0.5 * (ti + td))
    two_beta = 2.0 * beta
    a_m = one_m_beta + two_beta * sm * sm  # 1 − β cos(θi − θd)
    b_m = one_m_beta + two_beta * sp * sp  # 1 − β cos(θi + θd)
    a_p = one_m_beta + two_beta * cm * cm  # 1 + β cos(θi − θd)
    b_p = one_m_beta + two_beta * cp * cp  # 1 + β cos(θi + θd)

    def j1(a_, b_):
        return (math.pi - 2.0 * torch.atan(rho * torch.sqrt(a_ / b_))) / torch.sqrt(a_ * b_)

    j1m = j1(a_m, b_m)
    j1p = j1(a_p, b_p)
    bs = beta * b * sin_psi
    j2m = (0.5 * (a_m + b_m) * j1m + bs) / (a_m * b_m)
    j2p = (0.5 * (a_p + b_p) * j1p - bs) / (a_p * b_p)
    return 0.25 * (j2m + j2p + j1m + j1p)


def _psi_integral_complex(ti, td, b, rho, sin_psi, alpha):
    r"""The same integral for ``α > 1``: ``β = iγ``, ``I = ½ Re(J₂₋ + J₁₋)``."""
    g2 = (alpha - 1.0) * (alpha + 1.0)
    pos = g2 > 0
    gamma = _safe_sqrt(g2, pos)
    cdt = torch.complex128 if ti.dtype == torch.float64 else torch.complex64
    ig = torch.complex(torch.zeros_like(gamma), gamma).to(cdt)
    a_ = 1.0 - ig * torch.cos(ti - td)
    b_ = 1.0 - ig * torch.cos(ti + td)
    r = torch.sqrt(b_ / a_)
    j1 = (math.pi - 2.0 * torch.atan(rho / r)) / (a_ * r)
    j2 = (0.5 * (a_ + b_) * j1 + ig * b * sin_psi) / (a_ * b_)
    return 0.5 * (j2 + j1).real


def _cut_geometry(ti: torch.Tensor, td: torch.Tensor):
    """``ρ = cot(Ψ/2)`` (0 without cut) and ``sin Ψ`` at the ψ bound of eq. 26."""
    delta = _kink_offset(ti, td)
    cut = delta > 0  # θi + θd > π/2: ψ is cut at ψ_dmax < π (eq. 26)
    q = torch.sin(delta)  # −cos(θi + θd), exact near the kink
    p_ = torch.cos(ti - td)  # > 0 inside the domain (= 0 only at the corner θi = 0, θd = π/2)
    ratio = q / torch.where(cut, p_, torch.ones_like(p_))
    rho = _safe_sqrt(ratio, cut & (ratio > 0))  # √(Q/P); guarded: finite gradient on the kink
    return rho, 2.0 * rho / (1.0 + rho * rho)


def _prefactor(ti: torch.Tensor, td: torch.Tensor, alpha: torch.Tensor) -> torch.Tensor:
    """``2α²/π · G1²(θi)/cos θi · cos θd sin θd`` (G1²/cos θi = G1 · 2/(cos θi + root), finite at grazing)."""
    ci, si = torch.cos(ti).clamp(min=0.0), torch.sin(ti)  # clamp: float32(π/2) > π/2 has cos < 0
    a2 = alpha * alpha
    root = torch.sqrt(ci * ci + a2 * si * si)  # > 0 for α > 0
    g1 = 2.0 * ci / (ci + root)
    return (4.0 / math.pi) * a2 * g1 / (ci + root) * torch.cos(td).clamp(min=0.0) * torch.sin(td)


def _filter(ti: torch.Tensor, td: torch.Tensor, alpha: torch.Tensor) -> torch.Tensor:
    """Closed-form F_α on broadcast tensors (no validation)."""
    pref = _prefactor(ti, td, alpha)
    rho, sin_psi = _cut_geometry(ti, td)
    b = torch.sin(ti) * torch.sin(td)
    real_lane = alpha <= 1
    with torch.no_grad():
        any_complex = bool((~real_lane).any())
        any_real = bool(real_lane.any())
    out = None
    if any_real:
        a_r = alpha if not any_complex else torch.where(real_lane, alpha, torch.full_like(alpha, 0.5))
        out = _psi_integral_real(ti, td, b, rho, sin_psi, a_r)
    if any_complex:  # α > 1 (NaN lands here too and propagates)
        a_c = alpha if not any_real else torch.where(real_lane, torch.full_like(alpha, 2.0), alpha)
        out_c = _psi_integral_complex(ti, td, b, rho, sin_psi, a_c)
        out = out_c if out is None else torch.where(real_lane, out, out_c)
    if out is None:  # empty tensors
        out = torch.zeros_like(pref)
    return pref * out


def _cut_term(ti: torch.Tensor, td: torch.Tensor, alpha: torch.Tensor) -> torch.Tensor:
    r"""``S = 2α²/π G1²/cos θi cos θd sin θd · (π − ψ_dmax)``: what the cut of eq. 26 removes
    from F_α when the integrand is frozen at its value at ``cos θm = 0`` (where it is 1).

    ``F + S`` has no square root at the kink any more (the remainder is
    :math:`O(\delta^{5/2})`); the table stores ``F + S`` and subtracts ``S`` after interpolating.
    """
    rho, _ = _cut_geometry(ti, td)
    return _prefactor(ti, td, alpha) * (2.0 * torch.atan(rho))  # π − Ψ = 2 atan ρ


# ----------------------------------------------------------------------------------------
# warped coordinates of θd (the table's u, the quadrature's pieces)
# ----------------------------------------------------------------------------------------
#: width of the table's Cauchy warp, in units of α
_TABLE_WIDTH = 1.0
#: width of the quadrature's sinh warp, in units of α (measured: 0.35–0.7 alike; 0.7 best for K ≥ 48)
_QUAD_WIDTH = 0.7


def _warp_centre(ti: torch.Tensor, alpha: torch.Tensor) -> torch.Tensor:
    """Centre ``c = √(θi² + α²/3)`` of the warps: the filter's peak (α/√3 at normal
    incidence, ≈ θi beyond a few α). Even in θi, so everything stays smooth in cos θi."""
    return torch.sqrt(ti * ti + alpha * alpha / 3.0)


class _CauchyWarp:
    """``s ∈ [0, 1] ↔ θ ∈ [L, L + length]``, node density ∝ Cauchy(c, w) (arctangent warp).

    The table's θd coordinate: in it the filter's core and its ``t⁻³`` tails are both
    resolved by uniform nodes, and the map has a closed-form inverse (for queries).
    """

    def __init__(self, left, length, c, w):
        self.left = left
        self.w = w
        self.c = c
        self.x_left = (left - c) / w
        x_right = (left + length - c) / w
        self.g_left = torch.atan(self.x_left)
        self.dg = torch.atan2(length / w, 1.0 + self.x_left * x_right)  # gR − gL ≥ 0, no cancellation
        self.cos_left = torch.rsqrt(1.0 + self.x_left * self.x_left)

    def theta(self, s):
        """``θ(s) − L`` and ``dθ/ds``."""
        g = self.g_left + s * self.dg
        cg = torch.cos(g)
        return self.w * torch.sin(s * self.dg) / (cg * self.cos_left), self.w * self.dg / (cg * cg)

    def s_of(self, offset):
        """Inverse: ``s`` of ``θ = L + offset`` (0 on an empty segment)."""
        x = (self.left + offset - self.c) / self.w
        ang = torch.atan2(offset / self.w, 1.0 + self.x_left * x)  # atan x − atan xL
        nonempty = self.dg > 0
        return torch.where(nonempty, ang / torch.where(nonempty, self.dg, torch.ones_like(self.dg)), torch.zeros_like(ang))


class _SinhWarp:
    """``s ∈ [0, 1] ↔ θ ∈ [L, L + length]`` with ``θ − c = w sinh ξ``, ξ uniform in s.

    The quadrature's warp: near c the nodes are ``w``-spaced, further out log-uniform, so the
    filter's far structure (the mirror images of its GGX poles at ``θd = −θi ± iα`` and
    ``π − θi ± iα``) stays at O(1) distance in ξ, and Gauss–Legendre converges geometrically
    (an arctangent warp squeezes it against the ends: measured ~100× slower).
    """

    def __init__(self, left, length, c, w):
        self.left = left
        self.c = c
        self.w = w
        self.xi_left = torch.asinh((left - c) / w)
        self.dxi = torch.asinh((left + length - c) / w) - self.xi_left

    def theta(self, s):
        xi = self.xi_left + s * self.dxi
        return self.c + self.w * torch.sinh(xi) - self.left, self.w * torch.cosh(xi) * self.dxi


def _quadrature_pieces(ti: torch.Tensor, alpha: torch.Tensor):
    """The pieces ``[0, π/2 − θi]`` and ``[π/2 − θi, π/2]`` (split at the kink)."""
    c = _warp_centre(ti, alpha)
    w = _QUAD_WIDTH * alpha * torch.ones_like(c)
    hi, lo = _half_pi_parts(ti.dtype)
    kink = (hi - ti) + lo  # π/2 − θi
    return _SinhWarp(torch.zeros_like(kink), kink, c, w), _SinhWarp(kink, ti * torch.ones_like(kink), c, w)


def _table_warp(ti: torch.Tensor, alpha: torch.Tensor) -> _CauchyWarp:
    """The table's θd coordinate ``u ∈ [0, 1]`` over ``[0, π/2]`` (the kink is subtracted instead)."""
    c = _warp_centre(ti, alpha)
    return _CauchyWarp(torch.zeros_like(c), torch.full_like(c, _HALF_PI), c, _TABLE_WIDTH * alpha * torch.ones_like(c))


# ----------------------------------------------------------------------------------------
# public API
# ----------------------------------------------------------------------------------------
def _check_range(t: torch.Tensor, name: str, lo: float, hi: float, what: str) -> None:
    with torch.no_grad():
        bad = (t < lo) | (t > hi)  # NaN passes (it propagates)
        if bool(bad.any()):
            raise ValueError(f"{name} must lie in [{lo:g}, {hi:.10g}] ({what}); got {t[bad].flatten()[0].item():g}")


def _angle(what: str) -> _checks.Arg:
    """An angle in radians in [0, π/2] (π/2 rounded to the argument's dtype), ``what`` in the message."""
    return _checks.real(lambda t, name: _check_range(t, name, 0.0, _half_pi_parts(t.dtype)[0], what))


@_checks.arguments(theta_i_rad=_angle("radians, incidence angle"),
                   theta_d_rad=_angle("radians, difference angle θd = ∠(i, m)"), alpha=_geometry.ALPHA)
def transmission_filter(theta_i_rad, theta_d_rad, alpha) -> torch.Tensor:
    r"""Transmission filter :math:`F_\alpha(\theta_i, \theta_d)` (Fourneau et al. 2024 eq. 29), in rad⁻¹.

    Exact closed form of the ψ integral (derivation in the module docstring): no quadrature,
    float64 agrees with adaptive quadrature of eq. 29 to ~1e-15 relative, on and next to the
    kink :math:`\theta_d = \pi/2 - \theta_i` included.

    Args:
        theta_i_rad: incidence angle θi in **radians**, in [0, π/2] (angles, not cosines: F_α
            is a density in θd). ``F = 0`` at grazing (θi = π/2, where G1 = 0).
        theta_d_rad: difference angle θd = ∠(i, m) in radians, in [0, π/2].
        alpha: GGX roughness, > 0 (α > 1 allowed: analytic continuation, ``β² < 0``).

    Returns:
        ``F`` broadcast over the three inputs; :math:`\int_0^{\pi/2} F\,d\theta_d = G_1(\theta_i)`
        (Appendix C). Differentiable in all three inputs; finite gradients at θi = 0, θd = 0,
        θd = π/2 and on the kink (there: the left derivative — the right one is infinite).
        float32 stays finite (relative accuracy ~1e-6, ~1e-4 next to the kink).

    >>> import torch
    >>> theta_i = torch.tensor(0.5, dtype=torch.float64)
    >>> round(float(transmission_filter(theta_i, 0.5, 0.1)), 9)
    5.064837242
    """
    return _filter(theta_i_rad, theta_d_rad, alpha)


def _quadrature(ti: torch.Tensor, alpha: torch.Tensor, nodes: int, normalize: bool, cos_i=None):
    """Nodes θd (*, K) and weights (*, K) for ∫₀^{π/2} g(θd) F_α(θi, θd) dθd (no validation).

    ``cos_i``: the exact cos θi when known (G1 of the normalisation is then exactly 0 at grazing).
    """
    k_a = (nodes + 1) // 2
    k_b = nodes - k_a
    seg_a, seg_b = _quadrature_pieces(ti.unsqueeze(-1), alpha.unsqueeze(-1))
    ua, wa = gauss_legendre01(k_a, ti.dtype, ti.device)
    off_a, jac_a = seg_a.theta(ua)
    theta = [off_a]
    weight = [wa * jac_a]
    if k_b > 0:
        vb, wb = gauss_legendre01(k_b, ti.dtype, ti.device)
        off_b, jac_b = seg_b.theta(vb * vb)  # s = v²: the kink's square root becomes smooth in v
        theta.append(seg_b.left + off_b)
        weight.append(wb * jac_b * 2.0 * vb)
    hi, _ = _half_pi_parts(ti.dtype)
    theta = torch.cat(theta, -1).clamp(0.0, hi)
    weight = torch.cat(weight, -1) * _filter(ti.unsqueeze(-1), theta, alpha.unsqueeze(-1))
    if normalize:  # Σ w = G1 exactly (Appendix C); the rule's own error for g = 1 is < 1e-9
        ci = torch.cos(ti) if cos_i is None else cos_i
        a2 = alpha * alpha
        g1 = 2.0 * ci / (ci + torch.sqrt(ci * ci + a2 * (1.0 - ci * ci)))
        total = weight.sum(-1)
        ok = total > 0
        scale = torch.where(ok, g1 / torch.where(ok, total, torch.ones_like(total)), torch.ones_like(total))
        weight = weight * scale.unsqueeze(-1)
    return theta, weight


def _normal_cap(c: torch.Tensor, alpha: torch.Tensor) -> torch.Tensor:
    """Largest cosine the rule is built for: ``cos θmin`` with ``θmin = min(1e-3, α/300)`` rad."""
    theta_min = torch.clamp(alpha / 300.0, max=1e-3)
    return torch.cos(theta_min).to(c.dtype)


def _quadrature_cos(c: torch.Tensor, alpha: torch.Tensor, nodes: int, normalize: bool):
    """:func:`_quadrature` for cosines, with gradients that stay meaningful at normal incidence.

    arccos has an infinite slope at ``c = 1``: single nodes and weights move like
    ``√(1 − c)`` there, while integrals ``Σ w g`` are even in θi (smooth in ``c``) — but the
    rule is not exactly even (its kink split follows θi), so the gradient through arccos would
    amplify the rule's error by ``1/sin θi``. Cosines above ``cos θmin`` (θmin = min(1e-3,
    α/300) rad) are therefore replaced by ``cos θmin`` with the gradient passed straight
    through: the gradient of an integral is then its normal-incidence limit, with a relative
    error ≲ 300 × the rule's relative error, and integrals at normal incidence move by
    ~0.03 (θmin/α)² ≲ 4e-7 relative (measured for a smooth g).
    """
    top = _normal_cap(c, alpha)
    c_s = c - (c - torch.minimum(c, top)).detach()
    return _quadrature(torch.acos(c_s), alpha, nodes, normalize, c_s)


@_checks.arguments(cos_theta_i=_checks.COSINE, alpha=_geometry.ALPHA, nodes=_checks.integer(2), normalize=_checks.FLAG)
def filter_quadrature(cos_theta_i, alpha, nodes: int = 64, *, normalize: bool = True):
    r"""A quadrature rule with weight function :math:`F_\alpha(\theta_i,\cdot)` (eq. 28):
    :math:`\sum_k w_k\,g(\theta_{d,k}) \approx \int_0^{\pi/2} g(\theta_d)F_\alpha(\theta_i,\theta_d)\,d\theta_d`.

    Gauss–Legendre in the warped coordinate of the module docstring, in two pieces split at
    the kink ``θd = π/2 − θi`` (``ceil(K/2)`` nodes on ``[0, π/2 − θi]``, ``floor(K/2)`` on the
    rest, with ``s = v²`` there so the kink's square root is smooth), concentrated around the
    filter's peak by the Cauchy warp. The weights already contain ``F_α``: they are
    positive, and with ``normalize=True`` rescaled so that ``Σ w = G1(θi)`` exactly (the
    Appendix C moment). Without rescaling, ``Σ w`` matches G1 to < 1e-9 from 16 nodes on
    (α ∈ [0.01, 1]).

    Args:
        cos_theta_i: cosine of the incidence angle, in [0, 1], shape ``(*)``.
        alpha: GGX roughness > 0, broadcasting with ``cos_theta_i``.
        nodes: ``K ≥ 2`` nodes per incidence angle. A smooth ``g`` needs ~16–32; a Bragg
            transmittance ``1 − R(θd)`` with sharp band edges needs more (see
            :func:`torchirid.layered.transmission.integrated_transmissivity`).
        normalize: rescale the weights to ``Σ w = G1`` (default True).

    Returns:
        ``(cos_theta_d, weights)``, each ``(*, K)``: the cosines of the nodes θd and the
        weights (in rad⁻¹·rad, i.e. dimensionless). Differentiable with respect to
        ``cos_theta_i`` and ``alpha``; finite at ``cos_theta_i = 1`` and ``0`` (grazing:
        all weights 0). Near normal incidence single nodes and weights move like
        ``√(1 − cos θi)`` while sums ``Σ w g`` are smooth in ``cos θi``: above ``cos θmin``,
        θmin = min(1e-3, α/300) rad, the rule of ``cos θmin`` is returned (gradient passed
        through; integrals move by ≲ 4e-7 relative), so that gradients of sums are their
        normal-incidence limit (``_quadrature_cos``).

    >>> import torch
    >>> c, w = filter_quadrature(torch.tensor(0.5, dtype=torch.float64), 0.1, nodes=32)
    >>> c.shape, round(float(w.sum()), 12)   # = G1(60°) for α = 0.1
    (torch.Size([32]), 0.992610433948)
    """
    c, a = torch.broadcast_tensors(cos_theta_i, alpha)
    theta, weight = _quadrature_cos(c, a, nodes, normalize)
    return torch.cos(theta), weight


def _hat_weights(ti: torch.Tensor, alpha: torch.Tensor, cells: int, cos_i=None) -> torch.Tensor:
    r"""Product-integration weights :math:`W_{rj} = \int_0^{\pi/2} F_\alpha(\theta_{i,r},\theta_d)\,\phi_j(\theta_d)\,d\theta_d`
    for the hat functions φ_j of the uniform grid ``θ_j = j π/(2·cells)``, ``j = 0..cells``.

    ``Σ_j W_rj g(θ_j)`` integrates the piecewise-linear interpolant of ``g`` against F_α
    exactly up to the per-cell 2-point Gauss–Legendre rule (error ~ (h/α)⁴/4320 of F's
    scale, h = π/(2·cells)); the rows are rescaled to sum to G1 exactly. ``ti`` is 1-D (R,).
    Rows are evaluated in blocks of the block size of :mod:`torchirid._chunks` (2·cells filter
    values per row, at least ``MIN_BLOCK_POINTS`` rows; ``chunk_size=None``: all at once); rows
    are independent.
    """
    dtype, device = ti.dtype, ti.device
    h = _HALF_PI / cells
    x, w = gauss_legendre01(2, dtype, device)
    grid = torch.linspace(0.0, _HALF_PI, cells + 1, dtype=dtype, device=device)
    nodes = (grid[:-1].unsqueeze(-1) + h * x).clamp(max=_HALF_PI)  # (cells, 2)
    points = _chunks.get_chunk_size(device)
    chunk = (max(1, ti.numel()) if points is None
             else max(min(points, _chunks.MIN_BLOCK_POINTS), points // (2 * cells)))
    rows = []
    for start in range(0, ti.numel(), chunk):
        t = ti[start:start + chunk].reshape(-1, 1, 1)
        fw = _filter(t, nodes, alpha) * (w * h)  # (r, cells, 2)
        left = (fw * (1.0 - x)).sum(-1)
        right = (fw * x).sum(-1)
        rows.append(torch.nn.functional.pad(left, (0, 1)) + torch.nn.functional.pad(right, (1, 0)))
    weights = torch.cat(rows, 0)
    ci = torch.cos(ti) if cos_i is None else cos_i  # the exact cosine: G1 = 0 exactly at grazing
    a2 = alpha * alpha
    g1 = 2.0 * ci / (ci + torch.sqrt(ci * ci + a2 * (1.0 - ci * ci)))
    total = weights.sum(-1)
    ok = total > 0
    scale = torch.where(ok, g1 / torch.where(ok, total, torch.ones_like(total)), torch.ones_like(total))
    return weights * scale.unsqueeze(-1)
