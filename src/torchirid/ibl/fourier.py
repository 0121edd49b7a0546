r"""Belcour–Barla thin-film colour: the Airy series in the phase, integrated against the Fourier-transformed
sensitivity Ŝ (:mod:`torchirid.ibl.sensitivity`).

Belcour & Barla 2017, summarised by Kneiphof et al. 2019, §3.1 (eq. 4–5).

Colour (eq. 4–5). Summing the Airy series, with :math:`a = r_{21} r_{23} = \sqrt{R_{21}R_{23}}\,e^{iφ_2}`
and Φ = 2πD/λ, D = 2 η₂ d cos θ₂, the reflectance is the Fourier series in Φ

.. math::
    R = C_0 + 2\,\mathrm{Re} \sum_{m\ge1} a^m K\, e^{imΦ},\qquad
    C_0 = R_{12} + R_*,\quad R_* = \frac{|t_{12}t_{21}|^2 R_{23}}{1 - R_{21}R_{23}},\quad
    K = R_* + \frac{\bar r_{12}\, t_{12} t_{21}}{r_{21}},

(derived from :math:`r = r_{12} + t_{12}t_{21}r_{23}e^{iΦ}/(1 - a e^{iΦ})`). For a dielectric
film under a real outer medium r₁₂ is real, :math:`\bar r_{12}/r_{21} = -1` and
:math:`t_{12}t_{21} = 1 - R_{12} = \sqrt{T_{12}T_{21}}`, so K is real and
:math:`C_m = |a|^m K = (\sqrt{R_{21}R_{23}})^m (R_* - \sqrt{T_{12}T_{21}})` as in the paper. Integrating
against :math:`S_j` gives eq. 4: :math:`C_0 \hat S(0) + \sum_m C_m [e^{imφ_2}\hat S(-mD) +
e^{-imφ_2}\hat S(mD)]`, computed for s and p separately, then averaged. It is exact (M → ∞)
for wavelength-independent indices (Belcour & Barla's assumption: a non-dispersive base
η₃ + iκ₃ and film η₂).
"""

from __future__ import annotations

import torch

from .. import _checks, _chunks
from ..optics.fresnel import admittance, interface, normal_wavenumber
from .sensitivity import FILM_COLOUR_ARGS, _sensitivity_width, sensitivity_kernel

__all__ = ["thin_film_xyz_fourier"]


# ---------------------------------------------------------------------------------------
# Belcour–Barla colour
# ---------------------------------------------------------------------------------------


_FILM = {k: FILM_COLOUR_ARGS[k] for k in ("n_film", "thickness", "n_substrate", "n_incident", "polarization")}


def check_film_above_incident(n_film, n_incident) -> None:
    """ValueError unless the (checked) real film index is ≥ the outer one: below it the wave in the
    film can be evanescent (TIR), and Belcour–Barla's series in the phase does not hold."""
    if _checks.value_checks_enabled() and bool((n_film < n_incident).any()):
        raise ValueError("n_film must be a real index >= n_incident (Belcour–Barla's series needs a "
                         "propagating wave in the film)")


@_checks.arguments(cos_theta=_checks.COSINE, **_FILM)
def thin_film_fourier_terms(cos_theta, n_film, thickness, n_substrate, *, n_incident=1.0,
                            polarization: str = "unpolarized"):
    r"""The eq. 4 series of a film for wavelength-independent indices.

    Returns ``(C0, a, K, D)``, each with a leading polarization axis (2 for
    ``"unpolarized"``: s then p; 1 otherwise) before the broadcast batch: ``C0`` (real),
    ``a = r21 r23`` (complex; ``|a| = √(R21 R23)``, ``arg a = φ2``), ``K`` (complex; real
    ``R* − √(T12 T21)`` for a dielectric film), and the path difference ``D = 2 η2 d cos θ2``
    (nm, real, no polarization axis). BB's ``C_m = |a|^m K``. See the module docstring.

    Example (summed at one wavelength, the series is the film's reflectance):
        >>> import math, torch, torchirid
        >>> c = torch.tensor([1.0, 0.5], dtype=torch.float64)  # cos θ
        >>> C0, a, K, D = thin_film_fourier_terms(c, 1.33, 300.0, complex(2.0, 0.5))  # d in nm
        >>> C0.shape, D.shape  # (s, p) × batch; D has no polarization axis
        (torch.Size([2, 2]), torch.Size([2]))
        >>> [round(v, 2) for v in D.tolist()]  # nm
        [798.0, 605.64]
        >>> m = torch.arange(1, 60, dtype=torch.float64)
        >>> phase = torch.exp(2j * math.pi * m * D[..., None] / 550.0)  # λ = 550 nm
        >>> R = (C0 + 2 * (K[..., None] * a[..., None] ** m * phase).real.sum(-1)).mean(0)  # s and p averaged
        >>> lam = torch.tensor(550.0, dtype=torch.float64)
        >>> torch.allclose(R, torchirid.thin_film_reflectance(lam, c, 1.33, 300.0, complex(2.0, 0.5)))
        True
    """
    check_film_above_incident(n_film, n_incident)
    return fourier_terms(cos_theta, n_film, thickness, n_substrate, n_incident, polarization)


def fourier_terms(c, nf, d, ns, n0, polarization):
    """:func:`thin_film_fourier_terms` on checked tensors (the kernel the colour functions call)."""
    dtype = c.dtype
    c = _checks.flush_grazing(c)
    cdt = _checks.complex_dtype(dtype)
    s2 = n0 * n0 * (1 - c * c)
    qf_real = torch.sqrt((nf * nf - s2).clamp_min(0.0))  # n_f >= n_0: real, > 0 unless n_f = n_0 at grazing
    q0, qf = (n0 * c).to(cdt), qf_real.to(cdt)
    qs = normal_wavenumber(ns.to(cdt), s2, n0.to(cdt), q0)
    pols = _checks.POLARIZATION_TERMS[polarization]
    C0s, As, Ks = [], [], []
    for pol in pols:
        e0, ef, es = (admittance(q, n.to(cdt), pol) for q, n in ((q0, n0), (qf, nf), (qs, ns)))
        r12 = interface(e0, ef)
        r21 = -r12
        r23 = interface(ef, es)
        tt = 1 - r12 * r12  # t12 t21 (admittance convention: the p scalings cancel)
        a = r21 * r23
        R12, R23, aa = r12.abs() ** 2, r23.abs() ** 2, a.abs() ** 2
        den = (1 - aa).clamp_min(torch.finfo(dtype).tiny)  # |a| = 1 only where t12 t21 = 0 too
        Rstar = tt.abs() ** 2 * R23 / den
        nz = R12 > 0
        # conj(r12) / r21 = −conj(r12)/r12: −1 for real r12 (its limit at r12 = 0, Brewster / n_f = n_0)
        safe = torch.where(nz, r12, torch.ones_like(r12))
        ratio = torch.where(nz, -safe.conj() / safe, -torch.ones_like(r12))
        C0s.append(R12 + Rstar)
        As.append(a)
        Ks.append(Rstar + ratio * tt)
    batch = _checks.broadcast_shapes(c.shape, nf.shape, d.shape, ns.shape, n0.shape)
    st = lambda xs: torch.stack([x.expand(batch) for x in xs])  # noqa: E731
    D = (2.0 * d * qf_real).expand(batch)
    return st(C0s), st(As), st(Ks), D


@_checks.arguments(cos_theta=_checks.COSINE, **FILM_COLOUR_ARGS)
def thin_film_xyz_fourier(cos_theta, n_film, thickness, n_substrate, *, n_incident=1.0, terms: int = 4,
                          observer: str = "CIE 1931 2", illuminant: str = "D65",
                          polarization: str = "unpolarized", sensitivity: str = "lut") -> torch.Tensor:
    r"""XYZ of a thin film by Belcour & Barla's Fourier series (Kneiphof et al. 2019, eq. 4–5).

    .. math:: \mathbf{XYZ} = C_0\hat S(0) + \sum_{m=1}^{M} C_m\left[e^{imφ_2}\hat S(-mD)
              + e^{-imφ_2}\hat S(mD)\right],\qquad D = 2η_2 d\cos θ_2,

    for s and p separately, then averaged; normalised as :func:`~torchirid.color.spectrum_to_xyz`
    (white Y = 1), so it converges (M → ∞, ``sensitivity="exact"``) to
    ``spectrum_to_xyz(thin_film_reflectance(λ, ...), λ)`` for wavelength-independent indices.

    Args:
        cos_theta: cosine of the incidence angle in the outer medium, in [0, 1]. Shape ``(*)``.
        n_film: real film index η₂ ≥ ``n_incident`` (non-dispersive).
        thickness: film thickness d in nm (≥ 0).
        n_substrate: base index η₃ + iκ₃ (κ ≥ 0; dielectric or conductor; non-dispersive).
        n_incident: real outer index η₁ (default 1).
        terms: M ≥ 0, the number of m terms kept (default 4, as every other thin-film colour
            function of :mod:`torchirid.ibl`; Belcour & Barla suggest 2–4, Kneiphof et al. use 2).
            Each term adds one Ŝ evaluation per colour; the error and cost per M are measured in
            docs/performance.md, "Thin-film colour: Belcour–Barla Fourier series vs exact integration".
        observer, illuminant: the sensitivity (see :func:`fourier_sensitivity`).
        polarization: ``"unpolarized"`` (default), ``"s"`` or ``"p"``.
        sensitivity: ``"lut"`` (the shipped table, 0 beyond |D| = 20 µm) or ``"exact"``
            (quadrature, ≈ 3,760 operations per term and colour).

    Returns:
        ``(*, 3)`` XYZ in the real dtype of the inputs; differentiable w.r.t. every input.

    Example:
        >>> import torch
        >>> xyz = thin_film_xyz_fourier(torch.tensor(1.0, dtype=torch.float64), 1.33, 300.0, 1.0, terms=4)
        >>> [round(v, 4) for v in xyz.tolist()]
        [0.0516, 0.0675, 0.0417]
    """
    check_film_above_incident(n_film, n_incident)
    args = (cos_theta, n_film, thickness, n_substrate, n_incident)
    batch = _checks.broadcast_shapes(*(t.shape for t in args), names=_ARGUMENTS)
    dtype, device = cos_theta.dtype, cos_theta.device
    # block by block over large batches (torchirid._chunks); per colour the Ŝ evaluations hold
    # P·M sensitivity values per colour, each _sensitivity_width() wide
    per_colour = 2 * max(terms, 1) * _sensitivity_width(sensitivity, observer, illuminant, dtype, device)
    return _chunks.evaluate(_fourier_xyz, args, batch, out_core=1, width=per_colour, terms=terms, observer=observer,
                            illuminant=illuminant, polarization=polarization, sensitivity=sensitivity)


_ARGUMENTS = ("cos_theta", "n_film", "thickness", "n_substrate", "n_incident")


def _fourier_xyz(cos_theta, n_film, thickness, n_substrate, n_incident, *, terms, observer, illuminant, polarization,
                 sensitivity):
    """The body of :func:`thin_film_xyz_fourier` on one block of colours."""
    C0, a, K, D = fourier_terms(cos_theta, n_film, thickness, n_substrate, n_incident, polarization)
    fn = sensitivity_kernel(sensitivity)
    white = fn(torch.zeros((), dtype=D.dtype, device=D.device), observer, illuminant).real
    xyz = C0.mean(0)[..., None] * white
    if terms:
        m = torch.arange(1, terms + 1, dtype=D.dtype, device=D.device)
        S = fn(D[..., None] * m, observer, illuminant)  # (*, M, 3)
        # a^m as |a|^m e^{imφ2} (no repeated complex products; |a|^m underflows harmlessly to 0)
        am = torch.polar(a.abs()[..., None] ** m, torch.angle(a)[..., None] * m)  # (P, *, M)
        coef = (am * K[..., None]).mean(0)  # polarization average
        # C_m e^{imφ2} Ŝ(−mD) + c.c. = 2 Re[a^m K conj(Ŝ(mD))]
        xyz = xyz + 2.0 * (coef[..., None] * S.conj()).real.sum(-2)
    return xyz
