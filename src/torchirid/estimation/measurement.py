r"""Forward model of a hyperspectral measurement of a film on a substrate.

A camera band of centre λ_b and width w does not sample R at λ_b: it integrates R over its
passband. For a *box* passband of full width w,

.. math:: R_b = \frac{1}{w} \int_{λ_b - w/2}^{λ_b + w/2} R(λ)\, dλ
          \approx \sum_q ω_q\, R(λ_b + δ_q)

with Gauss–Legendre nodes δ_q and weights ω_q (exact for polynomials of degree 2Q−1 in λ);
a *gaussian* passband of full width at half maximum w uses Gauss–Hermite nodes instead.
R is the Airy reflectance of the film (Kobayashi et al. eq. 4–7, :func:`torchirid.thin_film_reflectance`).

``polarization`` defaults to ``"unpolarized"`` (the mean of the s and p reflectances), as in the
rest of the library. Kobayashi et al.'s camera sees only the s wave through a polarizer (§5.1):
their setup is ``polarization="s"``.

For the fits there is also a closed form for a *lossless* film on a lossless substrate
(real indices): with the real Fresnel amplitudes r₀₁, r₁₂ of eq. 6/7 and the film phase
Δ = 4π d √(n_f² − n₀² sin²θ)/λ (eq. 2–3, 8),

.. math:: R = \frac{a + b\cos Δ}{e + b\cos Δ}, \quad a = r_{01}^2 + r_{12}^2,\;
          b = 2 r_{01} r_{12},\; e = 1 + r_{01}^2 r_{12}^2,

(eq. 4–5 written out) whose terms a, b, e and the phase rate k = Δ/d depend on the film
index, the angle and λ but **not** on d — so a whole cube is a few multiply-adds and one
cosine per sample (:func:`airy_terms`, :func:`reflectance_from_terms`).
"""

from __future__ import annotations

import math

import numpy as np
import torch

from .. import _checks
from ..optics.thin_film import thin_film_reflectance

__all__ = [
]

PASSBANDS = ("box", "gaussian")


def band_nodes(bandwidth: float, nodes: int = 3, passband: str = "box", *, dtype=torch.float64, device=None):
    """Quadrature offsets (nm) and weights of a band's passband, both ``(Q,)``, weights sum to 1.

    ``"box"``: Gauss–Legendre on [−w/2, w/2]; ``"gaussian"``: Gauss–Hermite for a Gaussian
    of FWHM w. ``bandwidth = 0`` (point sampling) returns one node at 0. ``device`` None: the CPU.

    >>> off, wts = band_nodes(4.0, 2)
    >>> [round(v, 4) for v in off.tolist()], [round(v, 3) for v in wts.tolist()]
    ([-1.1547, 1.1547], [0.5, 0.5])
    """
    _checks.check_choice(passband, "passband", PASSBANDS)
    nodes = _checks.check_int(nodes, "nodes")
    bw = float(bandwidth)
    if not math.isfinite(bw) or bw < 0:
        raise ValueError(f"bandwidth must be >= 0 nm and finite; got {bandwidth!r}")
    if bw == 0.0:
        x, w = np.zeros(1), np.ones(1)
    elif passband == "box":
        x, w = np.polynomial.legendre.leggauss(nodes)
        x, w = x * bw / 2, w / 2
    else:
        x, w = np.polynomial.hermite_e.hermegauss(nodes)  # weight exp(-x²/2)
        sigma = bw / (2.0 * math.sqrt(2.0 * math.log(2.0)))
        x, w = x * sigma, w / w.sum()
    device = torch.device("cpu") if device is None else device
    return (torch.as_tensor(x, dtype=dtype, device=device), torch.as_tensor(w, dtype=dtype, device=device))


def _film_index(n_film, lam):
    return n_film(lam) if callable(n_film) else n_film


def band_reflectance(
    wavelength,
    cos_theta,
    n_film,
    thickness,
    n_substrate,
    *,
    bandwidth: float = 4.0,
    passband: str = "box",
    nodes: int = 8,
    n_incident=1.0,
    polarization: str = "unpolarized",
) -> torch.Tensor:
    r"""Band-integrated reflectance of a film on a substrate, as a hyperspectral camera sees it.

    Args:
        wavelength: band centres λ_b in nm (> 0), shape ``(*)``.
        cos_theta: cosine of the incidence angle, broadcasting with ``wavelength``.
        n_film: film index (``n + iκ``, broadcasting), or a callable ``λ ↦ n(λ)`` (nm) for a
            dispersive film, evaluated at every quadrature node.
        thickness: film thickness d in nm (≥ 0), broadcasting.
        n_substrate: substrate index (``n + iκ``) or a callable of λ.
        bandwidth: full passband width w in nm (box) or FWHM (gaussian); 0 = point sampling.
        passband: ``"box"`` or ``"gaussian"``.
        nodes: quadrature nodes Q per band (8 integrates 4 nm bands of a 1 µm film to ~1e-9).
        n_incident: real index of the incident medium.
        polarization: ``"unpolarized"``, ``"s"`` (Kobayashi et al.'s setup) or ``"p"``.

    Returns:
        R_b with the broadcast shape of the arguments, their real dtype.

    Example (MgF₂ 400 nm on PET, s wave, 10°, the 4 nm band at 548 nm):
        >>> import math, torch
        >>> c = math.cos(math.radians(10.0))
        >>> R = band_reflectance(torch.tensor(548.0, dtype=torch.float64), c, 1.37, 400.0, 1.64, polarization="s")
        >>> round(float(R), 5)
        0.06085
    """
    _checks.check_polarization(polarization)
    dtype, device = _checks.resolve_dtype_device(
        wavelength, cos_theta, thickness, *(x for x in (n_film, n_substrate) if not callable(x))
    )
    lam = _checks.as_real(wavelength, "wavelength", dtype, device)
    _checks.check_wavelength(lam)
    off, wts = band_nodes(bandwidth, nodes, passband, dtype=dtype, device=device)
    if bool((lam.detach().min() - off.abs().max()) <= 0):
        raise ValueError("wavelength - bandwidth/2 must stay > 0 nm")

    def node(x, name, real=True):
        if callable(x):
            return x
        t = (_checks.as_real if real else _checks.as_index)(x, name, dtype, device)
        return t[..., None]

    lam_q = lam[..., None] + off
    c = node(cos_theta, "cos_theta")
    d = node(thickness, "thickness")
    nf = node(n_film, "n_film", real=False)
    ns = node(n_substrate, "n_substrate", real=False)
    R = thin_film_reflectance(
        lam_q, c, _film_index(nf, lam_q), d, _film_index(ns, lam_q), n_incident=n_incident, polarization=polarization
    )
    return (R * wts).sum(-1)


def airy_terms(wavelength, cos_theta, n_film, n_substrate, *, n_incident=1.0, polarization: str = "unpolarized"):
    r"""Terms (a, b, e, k) of the lossless closed form :math:`R = (a + b\cos kd)/(e + b\cos kd)`.

    All indices must be real (lossless film and substrate, no total internal reflection in
    the substrate). Each output has the broadcast shape of the inputs with a leading
    polarization axis (1 for ``"s"``/``"p"``, 2 for ``"unpolarized"``, whose R is the mean).
    k = 4π√(n_f² − n₀² sin²θ)/λ in rad/nm (eq. 2–3 with Snell's law, eq. 8).

    Example (k for n_f = 1.5 at normal incidence, λ = 500 nm, is 4π·1.5/500):
        >>> import torch
        >>> a, b, e, k = airy_terms(torch.tensor(500.0, dtype=torch.float64), 1.0, 1.5, 1.64)
        >>> round(float(k[0]) * 500 / (4 * 3.141592653589793), 12)
        1.5
    """
    pols = _checks.polarization_terms(polarization)
    dtype, device = _checks.resolve_dtype_device(wavelength, cos_theta, n_film, n_substrate)
    lam = _checks.as_real(wavelength, "wavelength", dtype, device)
    c = _checks.as_real(cos_theta, "cos_theta", dtype, device)
    nf = _checks.as_real(n_film, "n_film", dtype, device)
    ns = _checks.as_real(n_substrate, "n_substrate", dtype, device)
    n0 = _checks.as_real(n_incident, "n_incident", dtype, device)
    _checks.check_cosine(c)
    s2 = n0 * n0 * (1 - c * c)
    q0 = n0 * c
    qf = (nf * nf - s2).clamp_min(0).sqrt()
    qs = (ns * ns - s2).clamp_min(0).sqrt()
    out = []
    for pol in pols:
        if pol == "s":
            r01 = (q0 - qf) / (q0 + qf)
            r12 = (qf - qs) / (qf + qs)
        else:
            r01 = (nf * nf * q0 - n0 * n0 * qf) / (nf * nf * q0 + n0 * n0 * qf)
            r12 = (ns * ns * qf - nf * nf * qs) / (ns * ns * qf + nf * nf * qs)
        out.append((r01 * r01 + r12 * r12, 2 * r01 * r12, 1 + (r01 * r12) ** 2))
    k = (4 * math.pi) * qf / lam
    a, b, e = (torch.stack(torch.broadcast_tensors(*t, k)[:-1]) for t in zip(*out))
    k = k.expand(a.shape[1:])[None].expand(a.shape)
    return a, b, e, k


def reflectance_from_terms(a, b, e, k, thickness) -> torch.Tensor:
    """R = mean over the polarization axis (dim 0) of (a + b cos kd)/(e + b cos kd).

    Example:
        >>> import torch
        >>> t = airy_terms(torch.tensor(548.0, dtype=torch.float64), 0.9848, 1.37, 1.64, polarization="s")
        >>> round(float(reflectance_from_terms(*t, 400.0)), 4)
        0.0609
    """
    cb = b * torch.cos(k * thickness)
    return ((a + cb) / (e + cb)).mean(0)


def band_variance(bandwidth: float, passband: str = "box") -> float:
    """Variance (nm²) of a passband: w²/12 for a box of width w, (w/2.3548)² for a Gaussian of FWHM w.

    >>> round(band_variance(4.0), 6)
    1.333333
    """
    _checks.check_choice(passband, "passband", PASSBANDS)
    bw = float(bandwidth)
    if not math.isfinite(bw) or bw < 0:
        raise ValueError(f"bandwidth must be >= 0 nm and finite; got {bandwidth!r}")
    if passband == "box":
        return bw * bw / 12.0
    return (bw / (2.0 * math.sqrt(2.0 * math.log(2.0)))) ** 2


def band_terms(wavelength, cos_theta, n_film, n_substrate, *, bandwidth: float = 4.0, passband: str = "box",
               n_incident=1.0, polarization: str = "unpolarized"):
    r"""Terms (a, b, e, k, h) of the fast band model :func:`band_reflectance_fast` (lossless film).

    (a, b, e, k) are :func:`airy_terms` at the band centre (``n_film`` may be a callable of λ
    in nm, e.g. a dispersion model), and h = ½ σ² (∂k/∂λ)² with σ² the passband variance
    (:func:`band_variance`), ∂k/∂λ by forward-mode autograd (it includes the dispersion).

    Example:
        >>> import torch
        >>> t = band_terms(torch.tensor([500.0], dtype=torch.float64), 1.0, 1.5, 1.64)
        >>> [tuple(x.shape) for x in t]  # (polarization: s and p, then the broadcast shape)
        [(2, 1), (2, 1), (2, 1), (2, 1), (2, 1)]
    """
    _checks.check_polarization(polarization)
    dtype, device = _checks.resolve_dtype_device(wavelength, cos_theta, *(x for x in (n_film, n_substrate) if not callable(x)))
    lam = _checks.as_real(wavelength, "wavelength", dtype, device)
    _checks.check_wavelength(lam)
    var = band_variance(bandwidth, passband)

    def terms(l):
        return airy_terms(l, cos_theta, _film_index(n_film, l), _film_index(n_substrate, l), n_incident=n_incident,
                          polarization=polarization)

    (a, b, e, k), (_, _, _, kp) = torch.func.jvp(terms, (lam,), (torch.ones_like(lam),))
    return a, b, e, k, 0.5 * var * kp * kp


def band_reflectance_fast(terms, thickness) -> torch.Tensor:
    r"""Band-integrated reflectance to second order in the bandwidth, one cosine per sample.

    With Δ = k d the film phase at the band centre and R(Δ) = 1 − (e − a)/(e + b cos Δ) the
    lossless Airy reflectance (module docstring), averaging over a passband of variance σ²
    (phase slope ∂Δ/∂λ = d ∂k/∂λ, so the phase variance is d²(∂k/∂λ)²σ²) gives

    .. math:: R_b ≈ R(Δ) + h d^2 R''(Δ), \qquad
              R'' = -(e - a)\, b\, \big(\cos Δ\, g^2 + 2 b \sin^2 Δ\, g^3\big),\; g = 1/(e + b\cos Δ),

    the Taylor expansion of the passband average in the phase (the Fresnel terms change
    slowly and are taken at the centre). The neglected term is of fourth order in σ d ∂k/∂λ;
    the tests compare with the 8-node quadrature of :func:`band_reflectance`. The mean
    over the leading polarization axis is returned.

    Example:
        >>> import torch
        >>> w = torch.tensor([548.0], dtype=torch.float64)
        >>> R = band_reflectance_fast(band_terms(w, 0.9848, 1.37, 1.64, polarization="s"), 400.0)
        >>> round(float(R), 5)
        0.06085
    """
    a, b, e, k, h = terms
    D = k * thickness
    u, s = torch.cos(D), torch.sin(D)
    g = 1 / (e + b * u)
    E = e - a
    R2 = -E * b * g * g * (u + 2 * b * s * s * g)
    return (1 - E * g + h * thickness * thickness * R2).mean(0)
