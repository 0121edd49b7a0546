r"""Complex Snell cosines and Fresnel amplitudes.

Everything here works with the *normal wavenumber factor* ``q = n cos θ`` of a medium, so
that ``k_z = 2π q / λ``.  With the invariant ``s² = n₀² sin² θ₀`` of the (real) incident
medium, Snell's law reads :math:`q_j = \sqrt{n_j^2 - s^2}`; the branch with
``Im q_j ≥ 0`` (a wave decaying away from the interface) is chosen deterministically, also
when ``n_j² − s²`` is a negative real with a signed zero imaginary part.

Interfaces are written with *admittances* :math:`\eta`:
``η = q`` (s polarization) and ``η = q / n²`` (p polarization), so that both read

.. math:: r_{ij} = \frac{\eta_i - \eta_j}{\eta_i + \eta_j}, \qquad t_{ij} = 1 + r_{ij}

(:math:`t^{(p)}_{ij}` is scaled by :math:`n_i / n_j` relative to the tmm/Born–Wolf
convention; the factors telescope and cancel in power transmittance).  The p sign
convention equals the ``tmm`` package's: :math:`r_p = (n_j\cos θ_i − n_i\cos θ_j)/(n_j\cos θ_i + n_i\cos θ_j)`.
"""

from __future__ import annotations

import math

import torch

from .. import _checks

__all__ = ["fresnel_reflectance"]


def _sqrt_upper(z: torch.Tensor) -> torch.Tensor:
    """Complex square root on the branch Im ≥ 0 (decaying / outgoing wave).

    Gradient-safe at z = 0 (critical angle, grazing in the same medium): the derivative
    there is reported as 0 instead of inf·0 = NaN.
    """
    if not (z.requires_grad and torch.is_grad_enabled()):  # no backward: √0 = 0 needs no guard
        root = torch.sqrt(z)
        return torch.where(root.imag < 0, -root, root)  # deterministic branch: Im q >= 0
    zero = z == 0
    # guard: sqrt'(0) is infinite; feed the unused branch a safe value so backward stays finite
    root = torch.sqrt(torch.where(zero, torch.ones_like(z), z))
    root = torch.where(root.imag < 0, -root, root)  # deterministic branch: Im q >= 0
    return torch.where(zero, torch.zeros_like(root), root)


def _sqrt_upper_real(z: torch.Tensor, cdt) -> torch.Tensor:
    """:func:`_sqrt_upper` of a real ``z`` (a real index's n² − s²), as ``cdt``: its imaginary part
    is +0, so the principal root already lies on the branch Im ≥ 0 (+i√|z| for z < 0) and needs
    no flip; the guard of √0 is needed only for a backward pass through a zero."""
    zc = z.to(cdt)
    if z.requires_grad and torch.is_grad_enabled() and not _checks.known_nonzero(z):
        return _sqrt_upper(zc)
    return torch.sqrt(zc)


def normal_wavenumber(n: torch.Tensor, s2: torch.Tensor, n0=None, q0=None) -> torch.Tensor:
    r"""``q = n cos θ = sqrt(n² − s²)`` (complex, ``Im q ≥ 0``) for the invariant ``s² = (n₀ sin θ₀)²``.

    With the incident medium's ``n0`` and ``q0 = n0 cos θ0``, a medium of exactly the
    incident index gets ``q0`` itself (exact even where ``cos² θ0`` underflows), so that
    repeated media never show a spurious interface.
    """
    cdt = _checks.complex_dtype(s2.dtype)
    n = n.to(cdt) if n.is_complex() else n.to(s2.dtype)
    return _normal_wavenumber(n, n * n, s2, n0, q0)


def _normal_wavenumber(n, n2, s2, n0=None, q0=None):
    """:func:`normal_wavenumber` given ``n2 = n * n`` too (``n`` complex of ``s2``'s precision, or real
    of its dtype), for a caller that needs n² again (the p admittance q / n²)."""
    cdt = _checks.complex_dtype(s2.dtype)
    if n.is_complex():
        q = _sqrt_upper(n2 - s2.to(cdt))
    else:  # a real index: n² − s² in real arithmetic (the same values as in complex, without the flip)
        q = _sqrt_upper_real(n2 - s2, cdt)
    if n0 is not None:
        same = n == n0
        if not _checks.known_false(same):  # (else no medium of the incident index: q as is)
            q = same_medium(same, q0.to(cdt), q)
    return q


def same_medium(same: torch.Tensor, q0: torch.Tensor, q: torch.Tensor) -> torch.Tensor:
    """``q`` with ``q0`` (the incident medium's) where ``same`` (the medium has exactly the incident
    index): q0's value, exact even where cos² θ0 underflows, but with q's derivative where q ≠ 0 —
    q0 = n0 cos θ0 alone would miss how q = √(n² − n0² sin² θ0) moves with n and n0 (the gradient
    of a layer index, or of the incident index, at the point where the two are equal)."""
    if not (q.requires_grad or q0.requires_grad) or not torch.is_grad_enabled():
        return torch.where(same, q0, q)
    live = same & (q != 0)  # (at grazing, q = 0, √ has no finite slope: q0's is kept)
    return torch.where(live, q + (q0 - q).detach(), torch.where(same, q0, q))


def nudge_critical(q: torch.Tensor, n: torch.Tensor, where: torch.Tensor) -> torch.Tensor:
    """Replace an exactly zero ``q`` (a film lit exactly at its critical angle) by ``√ε·|n|``.

    At ``q = 0`` the film's two Fresnel amplitudes are ±1 and the Airy/Rouard step is 0/0.
    ``√ε·|n|`` (ε the dtype's machine epsilon) is the ``q`` that one ulp of ``s² = n² − q²``
    already produces, so the result is the exact reflectance at an input one ulp away:
    R is continuous there but only √-conditioned, and no float evaluation does better.
    Only applied where ``where`` is True (not at grazing incidence, where ``q = 0`` means
    "the same medium as the incident one" and the interface must vanish).
    """
    if _checks.known_nonzero(q):  # no zero q (the common case): nothing to nudge
        return q
    zero = (q == 0) & where
    tiny = math.sqrt(torch.finfo(q.real.dtype).eps) * n.abs()
    return torch.where(zero, tiny.to(q.dtype).expand_as(q) if tiny.shape != q.shape else tiny.to(q.dtype), q)


def admittance(q: torch.Tensor, n: torch.Tensor, polarization: str) -> torch.Tensor:
    """η = q (s) or q / n² (p) for a medium of index ``n`` and ``q = n cos θ``."""
    if polarization == "s":
        return q
    return q / (n * n)


def interface(eta_i: torch.Tensor, eta_j: torch.Tensor) -> torch.Tensor:
    r"""Fresnel amplitude :math:`r_{ij} = (η_i − η_j)/(η_i + η_j)`.

    Equal admittances (the same medium twice, also exactly at grazing incidence where
    η_i = η_j = 0) give exactly r = 0: no 0/0, and no complex division of subnormals.
    """
    den = eta_i + eta_j
    if _checks.known_nonzero(den):
        # no 0/0 anywhere: the plain quotient (equal admittances give 0 / 2η = 0, the guarded value up
        # to the sign of zero; with a gradient, the guarded branch divides there too)
        return (eta_i - eta_j) / den
    if torch.is_grad_enabled() and (eta_i.requires_grad or eta_j.requires_grad):
        # r = 0/den = 0 at equal admittances anyway; dividing keeps its derivative
        # (dη_i − dη_j)/(η_i + η_j), which is not 0 (e.g. an incident index equal to the next one)
        same = den == 0
    else:
        same = eta_i == eta_j  # passive media: η_i + η_j = 0 only if both vanish
    den = torch.where(same, torch.ones_like(den), den)  # guard: the unused branch divides safely
    return torch.where(same, torch.zeros_like(den), (eta_i - eta_j) / den)


@_checks.arguments(cos_theta=_checks.COSINE, n_incident=_checks.INCIDENT_INDEX, n_substrate=_checks.INDEX,
                   polarization=_checks.POLARIZATION, broadcast=True)
def fresnel_reflectance(cos_theta, n_incident, n_substrate, *, polarization: str = "unpolarized") -> torch.Tensor:
    r"""Reflectance of a single smooth interface, :math:`R = |r|^2`.

    Args:
        cos_theta: cosine of the incidence angle in the outer medium, in [0, 1]. Shape ``(*)``.
        n_incident: real refractive index of the incident medium (> 0).
        n_substrate: refractive index ``n + iκ`` (κ ≥ 0) of the second medium.
        polarization: ``"s"``, ``"p"`` or ``"unpolarized"`` (mean of s and p reflectances).

    Returns:
        R in [0, 1], broadcast shape of the inputs, real dtype of the inputs.

    Example:
        >>> import torch, torchirid
        >>> round(float(torchirid.optics.fresnel_reflectance(torch.tensor(1.0, dtype=torch.float64), 1.0, 1.5)), 6)
        0.04
    """
    c = _checks.flush_grazing(cos_theta)
    n0 = n_incident.real if n_incident.is_complex() else n_incident
    n1 = n_substrate
    s2 = n0 * n0 * (1 - c * c)
    cdt = _checks.complex_dtype(c.dtype)
    q0 = (n0 * c).to(cdt)
    q1 = normal_wavenumber(n1, s2, n0, n0 * c)
    out = []
    for pol in _checks.POLARIZATION_TERMS[polarization]:
        r = interface(admittance(q0, n0.to(cdt), pol), admittance(q1, n1.to(cdt), pol))
        out.append(r.real * r.real + r.imag * r.imag)
    R = out[0] if len(out) == 1 else 0.5 * (out[0] + out[1])
    return R.clamp(0, 1)  # |r|² = re² + im² can round an ulp above 1 under total internal reflection
