r"""Kneiphof et al. 2019 §4.2: thin-film colour filtered over a distribution of light directions.

Given the mean :math:`μ_{ω_i}` (a 3-vector, ``|μ| ≤ 1``, not renormalised) and the covariance
:math:`Σ_{ω_i}` (3 × 3) of the light directions that reach the viewer through a microfacet
lobe (in Kneiphof's renderer: from the nine moment channels of the prefiltered environment
map), the reflectance term of eq. 12 is approximated by

eq. 20–21 (projection on the view direction, exact for mean and variance):

.. math:: μ_{⟨ω_i,ω_o⟩} = ⟨ω_o, μ_{ω_i}⟩,\qquad σ^2_{⟨ω_i,ω_o⟩} = ω_o^T Σ_{ω_i} ω_o,

eq. 22 (the microfacet that mirrors ω_i into ω_o, h = (ω_i + ω_o)/|ω_i + ω_o|):

.. math:: \cos θ_1 = ⟨h, ω_i⟩ = \sqrt{(1 + ⟨ω_i, ω_o⟩)/2},

eq. 23–24 (Snell in the film): :math:`\cos θ_2 = \sqrt{1 + \frac{η_1^2}{2η_2^2}(⟨ω_i,ω_o⟩ - 1)}`,

eq. 25–26 (first-order Taylor propagation about the mean):

.. math:: μ_{\cos θ_2} ≈ \sqrt{1 + \frac{η_1^2}{2η_2^2}(μ_{⟨ω_i,ω_o⟩} - 1)},\qquad
          σ_{\cos θ_2} ≈ \frac{η_1^2}{4η_2^2}\,\frac{σ_{⟨ω_i,ω_o⟩}}{μ_{\cos θ_2}},

eq. 27–28 (D = 2η₂ d cos θ₂ is linear in cos θ₂): :math:`μ_D = 2η_2 d\,μ_{\cos θ_2}`,
:math:`σ_D = 2η_2 d\,σ_{\cos θ_2}`,

eq. 29 (D ~ N(μ_D, σ²_D); C*_m and φ₂* of eq. 4 taken at the mean, i.e. at
:math:`\cos θ_1^* = \sqrt{(1 + μ_{⟨ω_i,ω_o⟩})/2}`; M terms: the paper uses M = 2, the default here is 4 like
every Fourier thin-film colour of :mod:`torchirid.ibl` — pass ``terms=2`` for the paper's):

.. math:: \mathbf{XYZ} ≈ C_0^*\hat S(0) + \sum_{m=1}^{M} C_m^*\left[e^{imφ_2^*}\hat S(-mμ_D, m^2σ_D^2)
          + e^{-imφ_2^*}\hat S(mμ_D, m^2σ_D^2)\right],

with :math:`\hat S(μ, σ^2)` the Gaussian-prefiltered sensitivity of eq. 18, evaluated exactly by
:func:`~torchirid.ibl.sensitivity.prefiltered_fourier_sensitivity` (no 2-D table, so no interpolation error).
Choice: eq. 22 at the mean uses μ_⟨ωi,ωo⟩ of eq. 20 (the mean of the cosine, the same quantity
eq. 25 expands about), not the cosine of the normalised mean direction; the two agree to
second order in the spread and exactly for a delta light. Variances are carried as σ² (never
σ = √σ²) so that Σ = 0 stays differentiable.
"""

from __future__ import annotations

import math

import torch

from .. import _checks, _chunks
from .fourier import check_film_above_incident, fourier_terms
from .sensitivity import FILM_COLOUR_ARGS, _exact_prefiltered, _sensitivity_width, prefiltered_kernel

#: How eq. 29's Ŝ(μ, σ²) is evaluated: ``"exact"`` (quadrature over the spectrum, ≈ 3,760 nodes)
#: or ``"lut"`` (Kneiphof's 2-D table, bilinear: :func:`~torchirid.ibl.shipped_prefiltered_sensitivity_lut`).
FILTERED_SENSITIVITY_MODES = ("exact", "lut")


#: the arguments of the filtered thin-film colours (their ``sensitivity`` choices are eq. 29's)
_ARGS = {**FILM_COLOUR_ARGS, "sensitivity": _checks.choice(FILTERED_SENSITIVITY_MODES)}

__all__ = ["thin_film_xyz_filtered", "thin_film_xyz_gaussian_path"]


def _check_cov(t, name):
    if t.ndim < 2 or tuple(t.shape[-2:]) != (3, 3):
        raise ValueError(f"{name} must have shape (*, 3, 3); got {tuple(t.shape)}")


#: 3 × 3 covariances (*, 3, 3)
COVARIANCES = _checks.Arg(_checks.as_real, _check_cov, tensor=True)


@_checks.arguments(wo=_checks.VECTORS, light_mean=_checks.VECTORS, light_cov=COVARIANCES, **_ARGS)
def thin_film_xyz_filtered(wo, light_mean, light_cov, n_film, thickness, n_substrate, *,
                           n_incident=1.0, terms: int = 4, observer: str = "CIE 1931 2",
                           illuminant: str = "D65", polarization: str = "unpolarized",
                           sensitivity: str = "lut") -> torch.Tensor:
    r"""Thin-film XYZ averaged over a light-direction distribution (Kneiphof et al. 2019, eq. 20–29).

    See the module docstring for the chain eq. 20 → 29. For ``light_cov = 0`` and a unit
    ``light_mean`` it equals ``thin_film_xyz_fourier(⟨h, ω_i⟩, ..., sensitivity="exact")``.

    Args:
        wo: view direction ω_o, ``(*, 3)``, any frame (normalised here; must be non-zero).
        light_mean: mean light direction μ_ωi, ``(*, 3)``, same frame, norm ≤ 1 (the mean of
            unit vectors; not renormalised).
        light_cov: covariance Σ_ωi of the light directions, ``(*, 3, 3)`` (symmetric PSD;
            ω_oᵀΣω_o is clamped at 0 against rounding).
        n_film: real film index η₂ ≥ ``n_incident``. Shape ``(*)``.
        thickness: film thickness d in nm (≥ 0). Shape ``(*)``.
        n_substrate: base index η₃ + iκ₃ (non-dispersive, κ ≥ 0). Shape ``(*)``.
        n_incident: real outer index η₁ (default 1).
        terms: M ≥ 0, Fourier terms kept (default 4; the paper's is 2).
        observer, illuminant: the sensitivity (see :func:`~torchirid.ibl.fourier_sensitivity`).
        polarization: ``"unpolarized"`` (default), ``"s"`` or ``"p"``.
        sensitivity: ``"lut"`` (default: the shipped tables of Ŝ(D) and Ŝ(μ, σ²), interpolated) or
            ``"exact"`` (quadrature: the reference the tables are tested against).

    Returns:
        ``(*, 3)`` XYZ (white Y = 1), real dtype of the inputs, differentiable w.r.t. every input.

    Example:
        >>> import torch
        >>> wo = torch.tensor([0.6, 0.0, 0.8], dtype=torch.float64)
        >>> mu = torch.tensor([-0.6, 0.0, 0.8], dtype=torch.float64)  # mirror of wo about +z
        >>> xyz = thin_film_xyz_filtered(wo, 0.98 * mu, 1e-3 * torch.eye(3, dtype=torch.float64),
        ...                              1.3, 600.0, complex(2.0, 0.5))
        >>> [round(v, 4) for v in xyz.tolist()]
        [0.0562, 0.0533, 0.1243]
    """
    w, mu, cov, nf, d, ns, n0 = wo, light_mean, light_cov, n_film, thickness, n_substrate, n_incident
    dtype = w.dtype
    check_film_above_incident(nf, n0)
    with torch.no_grad():
        wn = torch.linalg.vector_norm(w, dim=-1)
        if bool((wn <= 0).any()):
            raise ValueError("wo must be a non-zero vector (the view direction)")
        mn = torch.linalg.vector_norm(mu, dim=-1)
        if bool((mn > 1.0 + 1e3 * torch.finfo(dtype).eps).any()):
            raise ValueError(f"light_mean must have norm <= 1 (a mean of unit directions); got max "
                             f"{mn.max().item():g}")
    batch = _checks.broadcast_shapes(w.shape[:-1], mu.shape[:-1], cov.shape[:-2], nf.shape, d.shape, ns.shape,
                                     n0.shape, names=("wo[..., 0]", "light_mean[..., 0]", "light_cov[..., 0, 0]",
                                                      "n_film", "thickness", "n_substrate", "n_incident"))
    # block by block over large batches (torchirid._chunks): per colour P × M sensitivity values
    width = 2 * max(terms, 1) * _sensitivity_width(sensitivity, observer, illuminant, dtype, w.device)
    return _chunks.evaluate(_filtered_xyz, (w, mu, cov, nf, d, ns, n0), batch, core=(1, 1, 2, 0, 0, 0, 0),
                            out_core=1, width=width, terms=terms, observer=observer, illuminant=illuminant,
                            polarization=polarization, sensitivity=sensitivity)


def _filtered_xyz(w, mu, cov, nf, d, n_substrate, n0, *, terms, observer, illuminant, polarization, sensitivity):
    """Eq. 20–29 of :func:`thin_film_xyz_filtered` on one block of validated colours."""
    dtype = w.dtype
    w = w / torch.linalg.vector_norm(w, dim=-1, keepdim=True)

    # eq. 20–21: the distribution of ⟨ω_i, ω_o⟩ (clamps: rounding only, |μ| ≤ 1 and Σ PSD)
    mean_c = (w * mu).sum(-1).clamp(-1.0, 1.0)
    var_c = (w[..., :, None] * cov * w[..., None, :]).sum((-1, -2)).clamp_min(0.0)
    # eq. 22 at the mean: cos θ1* = ⟨h, ω_i⟩ (safe sqrt: backscatter μ = −1 is grazing, cos θ1 = 0)
    cos1 = _checks.safe_sqrt(0.5 * (1.0 + mean_c))
    # C0*, a* = r21 r23 = |a| e^{iφ2*}, K* of eq. 4 at the mean direction
    C0, a, K, _ = fourier_terms(cos1, nf, d, n_substrate, n0, polarization)
    # eq. 25: μ_cosθ2 (= √(1 − η1²/η2² sin²θ1*), what thin_film_fourier_terms uses for D)
    k = (n0 * n0) / (2.0 * nf * nf)
    mean_c2 = _checks.safe_sqrt(1.0 + k * (mean_c - 1.0))  # > 0 unless η2 = η1 at grazing
    # eq. 26 squared: σ²_cosθ2 = (η1²/(4η2²))² σ²_⟨ωi,ωo⟩ / μ²_cosθ2 (tiny floor: the η2 = η1 grazing limit)
    var_c2 = (0.5 * k) ** 2 * var_c / (mean_c2 * mean_c2).clamp_min(torch.finfo(dtype).tiny)
    # eq. 27–28: μ_D = 2η2 d μ_cosθ2, σ²_D = (2η2 d)² σ²_cosθ2
    scale = 2.0 * nf * d
    mean_D = scale * mean_c2
    var_D = scale * scale * var_c2

    return _series_xyz(C0, a, K, mean_D, var_D, terms, observer, illuminant, sensitivity)


def _series_xyz(C0, a, K, mean_D, var_D, terms, observer, illuminant, sensitivity="exact"):
    """Eq. 29 from the series terms (polarization-leading C0, a, K) and D ~ N(mean_D, var_D)."""
    dtype, device = mean_D.dtype, mean_D.device
    fn = prefiltered_kernel(sensitivity)
    # eq. 29: Ŝ(0) is the white; Ŝ(−mμ, m²σ²) = conj Ŝ(mμ, m²σ²) (the Gaussian damping is real)
    zero = torch.zeros((), dtype=dtype, device=device)
    white = _exact_prefiltered(zero, zero, observer, illuminant).real
    xyz = C0.mean(0)[..., None] * white
    if terms:
        m = torch.arange(1, terms + 1, dtype=dtype, device=device)
        S = fn(mean_D[..., None] * m, var_D[..., None] * (m * m), observer, illuminant)  # (*, M, 3)
        am = torch.polar(a.abs()[..., None] ** m, torch.angle(a)[..., None] * m)  # (P, *, M)
        coef = (am * K[..., None]).mean(0)  # polarization average
        # C_m e^{imφ2} Ŝ(−mμ_D, ·) + c.c. = 2 Re[a^m K conj Ŝ(mμ_D, ·)]
        xyz = xyz + 2.0 * (coef[..., None] * S.conj()).real.sum(-2)
    return xyz


@_checks.arguments(cos_theta=_checks.COSINE, path_mean=_checks.REAL, path_var=_checks.nonnegative("nm^2"), **_ARGS)
def thin_film_xyz_gaussian_path(cos_theta, n_film, thickness, n_substrate, path_mean, path_var, *,
                                n_incident=1.0, terms: int = 4, observer: str = "CIE 1931 2",
                                illuminant: str = "D65", polarization: str = "unpolarized",
                                sensitivity: str = "lut") -> torch.Tensor:
    r"""Eq. 29 for a given Gaussian path difference D ~ N(μ_D, σ²_D), C*_m and φ₂* at ``cos_theta``.

    The last step of :func:`thin_film_xyz_filtered`, for callers that know μ_D and σ²_D by other
    means: Kneiphof et al. 2019 Fig. 7 (c, g) use the ground-truth moments
    (:func:`~torchirid.ibl.path_difference_moments`); :func:`~torchirid.ibl.thin_film_xyz_fitted`
    reads fitted ones from a table. ``path_var = 0`` gives Belcour–Barla's eq. 4 with
    D = ``path_mean``.

    Args:
        cos_theta: cos θ₁* (incidence on the facet) at which C*_m and φ₂* are evaluated, in [0, 1].
        n_film, thickness, n_substrate, n_incident, terms, observer, illuminant, polarization: as
            :func:`thin_film_xyz_filtered` (C*_m and φ₂* do not depend on the thickness; it is
            validated and broadcast like the rest, and a NaN thickness gives NaN); sensitivity:
            ``"exact"`` or ``"lut"``.
        path_mean: μ_D in nm; path_var: σ²_D in nm² (≥ 0). Broadcast with the rest.

    Returns:
        ``(*, 3)`` XYZ (white Y = 1).

    Example:
        >>> import torch
        >>> c = torch.tensor(0.9, dtype=torch.float64)
        >>> xyz = thin_film_xyz_gaussian_path(c, 1.3, 600.0, complex(2.0, 0.5), 1500.0, 40.0**2)
        >>> [round(v, 4) for v in xyz.tolist()]
        [0.0483, 0.0839, 0.0644]
    """
    check_film_above_incident(n_film, n_incident)
    C0, a, K, D = fourier_terms(cos_theta, n_film, thickness, n_substrate, n_incident, polarization)
    mD, vD = path_mean, path_var
    shape = _checks.broadcast_shapes(D.shape, mD.shape, vD.shape, names=("cos_theta, n_film, ...", "path_mean", "path_var"))
    P = C0.shape[0]
    def ex(t):  # (P, *t_batch) → (P, *shape): singleton axes after P for the batch axes t lacks
        return t.reshape(P, *(1,) * (len(shape) - (t.dim() - 1)), *t.shape[1:]).expand(P, *shape)

    xyz = _series_xyz(ex(C0), ex(a), ex(K), mD.expand(shape), vD.expand(shape), terms, observer, illuminant,
                      sensitivity)
    # the thickness does not enter, but a NaN thickness marks a bad sample: NaN in, NaN out
    return torch.where(D.isnan().expand(shape)[..., None], torch.full_like(xyz, math.nan), xyz)
