r"""Reflectance of a single thin film by Airy summation.

A film of index :math:`n_f` and thickness :math:`d` lies between a real outer medium
:math:`n_0` and a possibly absorbing substrate :math:`n_s`.  Summing the multiple
reflections inside the film (Kobayashi et al., eq. 4–7; Fourneau et al. 2024, eq. 10):

.. math::

    r = \frac{r_{01} + r_{12}\, e^{2iφ}}{1 + r_{01} r_{12}\, e^{2iφ}}, \qquad
    φ = \frac{2π}{λ} n_f d \cos θ_f, \qquad R = |r|^2,

with Fresnel amplitudes :math:`r_{01}` (outer → film) and :math:`r_{12}` (film → substrate).
At :math:`d = 0` the formula is exactly the bare outer/substrate Fresnel reflectance, since
:math:`(r_{01} + r_{12})/(1 + r_{01} r_{12}) = r_{02}`; the dependence on d is smooth.
"""

from __future__ import annotations

import math

import torch

from .. import _autograd, _checks, _chunks
from .fresnel import _normal_wavenumber, interface, nudge_critical

__all__ = ["thin_film_reflectance"]


@_autograd.inference_when_small  # (a few points without a gradient: no autograd bookkeeping)
@_checks.arguments(wavelength=_checks.WAVELENGTH, cos_theta=_checks.COSINE, n_film=_checks.INDEX,
                   thickness=_checks.THICKNESS, n_substrate=_checks.INDEX, n_incident=_checks.INCIDENT_INDEX,
                   polarization=_checks.POLARIZATION)
def thin_film_reflectance(
    wavelength,
    cos_theta,
    n_film,
    thickness,
    n_substrate,
    *,
    n_incident=1.0,
    polarization: str = "unpolarized",
) -> torch.Tensor:
    r"""Reflectance R of a thin film on a substrate (Airy summation).

    Args:
        wavelength: vacuum wavelength λ in nm (> 0). Shape ``(*)``.
        cos_theta: cosine of the incidence angle in the outer medium, in [0, 1].
        n_film: film index ``n + iκ`` (κ ≥ 0).
        thickness: film thickness d in nm (≥ 0).
        n_substrate: substrate index ``n + iκ`` (κ ≥ 0, metals allowed).
        n_incident: real index of the outer (incident) medium, default 1 (air).
        polarization: ``"s"``, ``"p"`` or ``"unpolarized"`` (mean of s and p).

    Returns:
        R in [0, 1] with the broadcast shape of all arguments and their real dtype.

    Example (soap film, n = 1.33, 300 nm, in air at normal incidence, λ = 550 nm):
        >>> import torch, torchirid
        >>> R = torchirid.thin_film_reflectance(torch.tensor(550.0, dtype=torch.float64), 1.0, 1.33, 300.0, 1.0)
        >>> round(float(R), 6)
        0.07543
    """
    args = (wavelength, cos_theta, n_film, thickness, n_substrate, n_incident)
    batch = _checks.broadcast_shapes(*(a.shape for a in args), names=_ARGUMENTS)
    # block by block over large batches when no gradient is wanted (torchirid._chunks)
    return _chunks.evaluate(_thin_film_core, args, batch, polarization=polarization)


_ARGUMENTS = ("wavelength", "cos_theta", "n_film", "thickness", "n_substrate", "n_incident")


def _thin_film_core(lam, c, nf, d, ns, n0, *, polarization):
    """:func:`thin_film_reflectance` on validated tensors (one block of the batch): the Airy sum
    written out for one film, s and p on a leading axis (the division form of Hirayama's recursion,
    :func:`~torchirid.optics.transfer.recursion`, for L = 1, op for op)."""
    c = _checks.flush_grazing(c)
    cdt = _checks.complex_dtype(lam.dtype)
    n0 = n0.real if n0.is_complex() else n0
    n02 = n0 * n0
    s2 = n02 * torch.rsub(c * c, 1)  # Snell invariant (n0 sin θ0)^2 (rsub: 1 − c² without torch's Python wrapper)
    q0 = (n0 * c).to(cdt)  # exact in the incident medium (no sqrt at grazing)
    nf2, ns2 = nf * nf, ns * ns
    qf = _normal_wavenumber(nf, nf2, s2, n0, q0)
    if not _checks.known_nonzero(qf):
        qf = nudge_critical(qf, nf, c > 0)  # film exactly at its critical angle
    qs = _normal_wavenumber(ns, ns2, s2, n0, q0)
    # e^{2iφ}, φ = 2π q_f d / λ: only the decaying exponential (Im φ ≥ 0) is formed
    e2 = torch.exp((4j * math.pi) * qf * d / lam)
    pols = _checks.POLARIZATION_TERMS[polarization]
    nd = max(lam.ndim, c.ndim, nf.ndim, d.ndim, ns.ndim, n0.ndim)  # the batch's dims
    eta0 = _admittances(q0, n02, pols, nd)
    etaf = _admittances(qf, nf2, pols, nd)
    etas = _admittances(qs, ns2, pols, nd)
    r01 = interface(eta0, etaf)
    ge2 = interface(etaf, etas) * e2
    den = 1 + r01 * ge2
    if not _checks.known_nonzero(den):
        # guard: with a critical film nudged, 0/0 remains only at grazing incidence, where a zero- or
        # half-wave film sits between media that both look like the incident one (η = 0): the film
        # is invisible and nothing is reflected
        degenerate = den == 0
        gamma = torch.where(degenerate, torch.zeros_like(den),
                            (r01 + ge2) / torch.where(degenerate, torch.ones_like(den), den))
    else:
        gamma = (r01 + ge2) / den
    if gamma.numel() <= _autograd.SMALL_CALL:  # |r|² per polarization: few ops on a few points
        R = torch.view_as_real(gamma).square().sum(-1)
    else:  # (a reduction over re, im is slow on a large batch)
        R = gamma.real ** 2 + gamma.imag ** 2
    if len(pols) > 1:
        R = R.sum(0) * 0.5  # (the mean of the two, without mean's cost on a few elements)
    return R.clamp(0, 1)  # |r|² ≤ 1 up to an ulp


def _admittances(q, n2, pols, nd):
    """η = q (s) or q / n² (p) of one medium (``n2`` its squared index); for ``pols = ("s", "p")``
    both, stacked on a new leading axis and aligned to a batch of ``nd`` dims."""
    if pols == ("s",):
        return q
    p = q / n2
    if len(pols) == 1:
        return p
    eta = torch.stack((q.expand(p.shape) if q.shape != p.shape else q, p))
    return eta if p.ndim == nd else eta.reshape(2, *([1] * (nd - p.ndim)), *p.shape)
