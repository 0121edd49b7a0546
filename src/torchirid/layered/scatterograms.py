r"""Scatterograms: the hemisphere of reflected directions as an imaging scatterometer sees it
(Fourneau et al. 2024 §5, Fig. 9).

An imaging scatterometer (Schenck et al. 2013 [SWS13]; Stavenga's ellipsoidal-mirror design)
images every reflected direction ``ω_o`` of a small sample onto one point of a disc: the
surface normal at the centre, the horizon (θ = 90°) on the rim. :func:`scatterogram` renders
that disc for a layered Bragg structure under one of two illuminations:

* **narrow beam** from ``incident_deg = (θ_i, φ_i)`` (degrees): each pixel is the radiance
  reflected towards its direction per unit irradiance of a D65 beam,
  :math:`L_o(\omega_o) = f_r(\omega_i, \omega_o)\cos\theta_i` (sr⁻¹), as XYZ;
* **white environment** (``incident_deg=None``, Fig. 9: "a hemispherical sensor camera in a white
  environment"): uniform D65 radiance 1 from every direction, each pixel
  :math:`L_o(\omega_o) = \int_{\Omega^+} f_r(\omega_i, \omega_o)\cos\theta_i\,d\omega_i` — the
  directional albedo, so a perfect white Lambertian reflector has Y = 1 everywhere.

The angular mapping of the disc (``projection``; the paper does not state the one of Fig. 9,
and [SWS13]'s images are those of an ellipsoidal mirror): with ρ the distance of a pixel
from the centre (1 on the rim) and φ its polar angle,

==================  ==============================  ========================================
``projection``      ρ(θ)                            property
==================  ==============================  ========================================
``"equidistant"``   θ / 90°  (default)              the 5/30/60/90° circles equally spaced
``"orthographic"``  sin θ                           the view of the hemisphere from above
``"equal_area"``    √2 sin(θ / 2)                   pixel area ∝ solid angle (Lambert)
==================  ==============================  ========================================

Image axes: column → +x (φ = 0 to the right), row 0 at the top → +y up (φ = 90° at the top),
so a beam from φ_i reflects specularly towards φ_i + 180°. The structure's BRDF is
:func:`~torchirid.layered.single_reflection.single_reflection_brdf` (eq. 34), evaluated
exactly (or from its reflectance table with ``reflectance="lut"``).

Differentiability: the image is a differentiable function of every tensor parameter of the
layers (``n1, n2, d1, d2, alpha`` as 0-dim tensors with ``requires_grad``), of the incident
angles and of the wavelengths — pixels, quadrature nodes and colour conversion are all torch
operations, without thresholds that depend on them.

Display: :func:`scatterogram_srgb` turns one into an sRGB image (numpy, an exposure). The
figures (the grid of panels with the 5°, 30°, 60° and 90° circles of Fig. 9) and the PNG /
``.npz`` writers are in the application, :mod:`torchirid.app.figures.scatterograms`.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field

import numpy as np
import torch

from .. import _checks, _chunks
from .._quadrature import gauss_legendre01
from ..color import xyz_to_srgb
from ..color.convert import xyz_weights
from ..microfacet.ggx import ggx_vndf_pdf, sample_ggx_vndf
from . import _geometry
from .tables import REFLECTANCE_MODES, coating_reflectance, refract_into_host
from .single_reflection import single_reflection_brdf
from .structure import LayeredBragg

__all__ = [
    "PROJECTIONS",
    "Scatterogram",
    "projection_radius",
    "scatterogram",
    "scatterogram_directions",
    "scatterogram_srgb",
]

#: angular mappings of the hemisphere onto the unit disc (see the module docstring)
PROJECTIONS = ("equidistant", "orthographic", "equal_area")
#: default wavelength grid: 380–780 nm in 5 nm steps
DEFAULT_WAVELENGTHS = (380.0, 780.0, 81)
#: white environment, specular lobe of each layer: (Gauss–Legendre nodes in v, u₁ = 1 − (1 − v)⁴,
#: of Heitz's visible-normal map, uniform nodes in its azimuth u₂). Measured on the red
#: jewel-beetle preset (400–700 nm) against (256, 128) nodes: ≤ 2e-3 relative at every θ_o.
LOBE_NODES = (24, 16)
#: white environment with a Lambertian base: cosine-weighted hemisphere (GL in sin²θ_i, azimuths)
COSINE_NODES = (16, 32)

# the bodies of the functions the renders evaluate per block or per quadrature rule, on the
# arguments scatterogram checked once (the directions renormalised as the BRDF's check does)
_single_reflection_brdf = single_reflection_brdf.__wrapped__
_vndf = sample_ggx_vndf.__wrapped__
_vndf_pdf = ggx_vndf_pdf.__wrapped__


# ----------------------------------------------------------------------------------------
# the angular mapping
# ----------------------------------------------------------------------------------------
def _check_projection(projection) -> None:
    _checks.check_choice(projection, "projection", PROJECTIONS)


#: one of :data:`PROJECTIONS`
PROJECTION = _checks.choice(PROJECTIONS)


def projection_radius(theta_rad, projection: str = "equidistant") -> torch.Tensor:
    r"""Distance ρ ∈ [0, 1] from the disc's centre of the direction at polar angle ``theta_rad``.

    Args:
        theta_rad: polar angles θ in radians, [0, π/2] (tensor or number; float64 for numbers).
        projection: one of :data:`PROJECTIONS`.

    >>> round(float(projection_radius(math.radians(30.0))), 12)  # equidistant: 30°/90°
    0.333333333333
    >>> round(float(projection_radius(math.radians(30.0), "orthographic")), 12)
    0.5
    """
    _check_projection(projection)
    t = torch.as_tensor(theta_rad, dtype=theta_rad.dtype if isinstance(theta_rad, torch.Tensor) else torch.float64)
    if projection == "equidistant":
        return t / (math.pi / 2)
    if projection == "orthographic":
        return torch.sin(t)
    return math.sqrt(2.0) * torch.sin(t / 2)


def projection_theta(radius, projection: str = "equidistant") -> torch.Tensor:
    """The inverse of :func:`projection_radius`: polar angle θ (radians) at disc radius ρ ∈ [0, 1].

    >>> round(math.degrees(float(projection_theta(0.5, "orthographic"))), 9)
    30.0
    """
    _check_projection(projection)
    r = torch.as_tensor(radius, dtype=radius.dtype if isinstance(radius, torch.Tensor) else torch.float64)
    if projection == "equidistant":
        return r * (math.pi / 2)
    r = r.clamp(0.0, 1.0)  # guard: asin of rounding overshoot on the rim
    if projection == "orthographic":
        return torch.asin(r)
    return 2.0 * torch.asin(r / math.sqrt(2.0))


@_checks.arguments(resolution=_checks.integer(1), projection=PROJECTION, dtype=_checks.FLOAT_DTYPE)
def scatterogram_directions(resolution: int, *, projection: str = "equidistant", dtype=torch.float64,
                            device=None) -> tuple[torch.Tensor, torch.Tensor]:
    """The reflected direction of every pixel of a ``resolution × resolution`` scatterogram.

    Pixel ``(row, col)`` has its centre at ``x = (2 col + 1)/res − 1`` (right: +x),
    ``y = 1 − (2 row + 1)/res`` (up: +y); ρ = |(x, y)|, φ = atan2(y, x), θ from ρ by the
    projection. Valid pixels: ρ ≤ 1.

    Returns:
        ``(directions (H, W, 3), mask (H, W))``: unit vectors (z = the surface normal) for
        valid pixels, NaN outside; ``mask`` is True on valid pixels.

    >>> d, m = scatterogram_directions(4)  # the four corner pixels lie outside the disc
    >>> int(m.sum()), [round(v, 4) for v in d[1, 2].tolist()]
    (12, [0.3728, 0.3728, 0.8497])
    """
    c = (2.0 * torch.arange(resolution, dtype=dtype, device=device) + 1.0) / resolution - 1.0
    y, x = torch.meshgrid(-c, c, indexing="ij")
    rho = torch.sqrt(x * x + y * y)
    mask = rho <= 1.0
    theta = projection_theta(rho.clamp(max=1.0), projection)
    phi = torch.atan2(y, x)
    s = torch.sin(theta)
    d = torch.stack([s * torch.cos(phi), s * torch.sin(phi), torch.cos(theta)], -1)
    d = torch.where(mask.unsqueeze(-1), d, torch.full_like(d, float("nan")))
    return d, mask


# ----------------------------------------------------------------------------------------
# the result
# ----------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Scatterogram:
    """One rendered scatterogram.

    Attributes:
        xyz: ``(H, W, 3)`` CIE 1931 2° XYZ under D65 (white Y = 1), radiance per unit beam
            irradiance (beam, sr⁻¹) or per unit environment radiance (white); 0 outside the
            disc. Differentiable (see the module docstring).
        mask: ``(H, W)`` bool, True on the disc (θ_o ≤ 90°).
        directions: ``(H, W, 3)`` the reflected direction of each pixel (NaN outside).
        projection: the angular mapping (one of :data:`PROJECTIONS`).
        incident_deg: ``(θ_i, φ_i)`` in degrees for a narrow beam, None for the white environment.
        wavelength: ``(W,)`` the wavelengths (nm) of the spectral computation.
        title: a short label for figures.
        params: the parameters of the render, JSON-ready.

    Example (obtained from :func:`scatterogram`; a tiny 5 × 5 render under a normal beam):
        >>> import torch
        >>> from torchirid.layered import RoughBraggLayer, scatterogram
        >>> layer = RoughBraggLayer(n1=1.0, n2=1.5, d1=125.0, d2=375.0, cells=20, alpha=0.2)  # nm
        >>> sg = scatterogram(layer, incident_deg=(0.0, 0.0), resolution=5,
        ...                   wavelength=torch.linspace(380.0, 780.0, 41, dtype=torch.float64))  # nm
        >>> sg.xyz.shape, int(sg.mask.sum())  # 21 of the 25 pixels lie on the disc
        (torch.Size([5, 5, 3]), 21)
        >>> sg.projection, sg.incident_deg, sg.params["illumination"]
        ('equidistant', (0.0, 0.0), 'beam')
    """

    xyz: torch.Tensor
    mask: torch.Tensor
    directions: torch.Tensor
    projection: str
    incident_deg: tuple | None
    wavelength: torch.Tensor
    title: str = ""
    params: dict = field(default_factory=dict, repr=False)


# ----------------------------------------------------------------------------------------
# computation
# ----------------------------------------------------------------------------------------
def _dtype_device(structure: LayeredBragg, *args):
    """dtype/device from the tensors among the layer parameters and ``args``; float64 if none."""
    values = [getattr(layer, k) for layer in structure.layers for k in ("n1", "n2", "d1", "d2", "alpha")]
    tensors = [v for v in (*values, *args) if isinstance(v, torch.Tensor) and (v.is_floating_point() or v.is_complex())]
    if not tensors:
        return torch.float64, torch.device("cpu")
    return _checks.resolve_dtype_device(*tensors)


def _wavelengths(wavelength, dtype, device) -> torch.Tensor:
    if wavelength is None:
        lo, hi, n = DEFAULT_WAVELENGTHS
        return torch.linspace(lo, hi, n, dtype=dtype, device=device)
    lam = _checks.as_real(wavelength, "wavelength", dtype, device)
    if lam.dim() != 1 or lam.numel() < 2:
        raise ValueError(f"wavelength must be a 1-D tensor of >= 2 increasing wavelengths (nm); got shape "
                         f"{tuple(lam.shape)}")
    return lam


def _as_nodes(value, name, dtype=None, device=None) -> tuple[int, int]:
    ok = (isinstance(value, (tuple, list)) and len(value) == 2
          and all(isinstance(v, numbers.Integral) and not isinstance(v, bool) and v >= 1 for v in value))
    if not ok:
        raise ValueError(f"{name} must be a pair of integers >= 1; got {value!r}")
    return int(value[0]), int(value[1])


def _check_incident(value, name) -> None:
    if value is not None and (not isinstance(value, (tuple, list)) or len(value) != 2):
        raise ValueError(f"{name} must be None (white environment) or (theta_deg, phi_deg); got {value!r}")


#: a pair of node counts ≥ 1 (a quadrature rule's two axes)
NODE_PAIR = _checks.Arg(_as_nodes)
#: None (the white environment) or the beam's ``(θ_i, φ_i)`` in degrees (checked against the dtype later)
INCIDENT = _checks.Arg(None, _check_incident)


def _brdf_kwargs(structure: LayeredBragg, reflectance: str, transmissivity_angles) -> dict:
    kw = {"reflectance": reflectance}
    if transmissivity_angles is not None:
        kw["transmissivity_angles"] = transmissivity_angles
    elif len(structure.layers) == 1 and structure.base_albedo == 0:
        # eq. 34 uses τ only above the base or a lower layer: a single layer on a black base
        # needs none, so skip the (per-α) 361-angle table single_reflection_brdf builds anyway
        kw["transmissivity_angles"] = 2
    return kw


def _pairs_per_block(lam, count) -> int:
    """Direction pairs per call of the BRDF: pairs × wavelengths ≤ the block size of
    :mod:`torchirid._chunks` (``options(chunk_size=None)``: all ``count`` pairs at once)."""
    chunk = _chunks.get_chunk_size(lam.device)
    return max(1, count) if chunk is None else max(1, chunk // lam.numel())


def _brdf(structure, wi, wo, lam, kw) -> torch.Tensor:
    """single_reflection_brdf over the broadcast pairs (*, 3), block by block (bounded memory): its
    body, on unit directions above the surface that the render built (renormalised as its check
    would), the render's checked wavelengths and table sizes."""
    wi, wo = torch.broadcast_tensors(wi, wo)
    shape = wi.shape[:-1]
    wi, wo = wi.reshape(-1, 3), wo.reshape(-1, 3)
    step = _pairs_per_block(lam, wi.shape[0])
    unit = _geometry.unit
    out = [_single_reflection_brdf(lam, unit(wi[k:k + step]), unit(wo[k:k + step]), structure, **kw)
           for k in range(0, wi.shape[0], step)]
    return torch.cat(out, 0).reshape(*shape, lam.numel())


def _beam_xyz(structure, wi, wo, lam, kw, weights) -> torch.Tensor:
    """XYZ ``(pixels, 3)`` of ``f_r cos θi`` integrated against ``weights``, block by block (each
    block's spectra are reduced at once: the (pixels, W) spectra never exist whole)."""
    wo = wo.reshape(-1, 3)
    step = _pairs_per_block(lam, wo.shape[0])
    out = [(_brdf(structure, wi, wo[k:k + step], lam, kw) * wi[2]) @ weights for k in range(0, wo.shape[0], step)]
    return torch.cat(out, 0) if out else torch.zeros(0, 3, dtype=lam.dtype, device=lam.device)


_WARP = 4


def _unit_square(nodes, dtype, device, warp: int = 1):
    """Product rule on [0, 1]²: Gauss–Legendre in u₁, uniform (periodic) midpoints in u₂.

    ``warp = k > 1``: Gauss–Legendre in v with u₁ = 1 − (1 − v)^k, crowding the nodes towards
    u₁ = 1 — for the visible-normal map, GGX's tail where ω_i crosses the horizon (a kink at
    1 − u₁ ~ α² that plain Gauss–Legendre in u₁ resolves slowly).
    """
    n1, n2 = nodes
    x1, w1 = gauss_legendre01(n1, dtype, device)
    if warp > 1:
        w1 = w1 * warp * (1.0 - x1) ** (warp - 1)
        x1 = 1.0 - (1.0 - x1) ** warp
    x2 = (torch.arange(n2, dtype=dtype, device=device) + 0.5) / n2
    u = torch.stack(torch.broadcast_tensors(x1[:, None], x2[None, :]), -1).reshape(-1, 2)
    w = (w1[:, None] / n2).expand(n1, n2).reshape(-1)
    return u, w


def _lobe_density(o_h, i, i_h, alphas, n_incident, coated):
    """Σ_l of the density (per outer solid angle of ω_i) of each layer's lobe rule at ``i``."""
    h = i_h + o_h
    h = h / torch.linalg.vector_norm(h, dim=-1, keepdim=True).clamp_min(torch.finfo(h.dtype).tiny)
    od = (o_h * h).sum(-1).clamp_min(torch.finfo(h.dtype).tiny)
    total = 0.0
    for a in alphas:
        total = total + _vndf_pdf(o_h, h, a) / (4.0 * od)
    if coated:  # dω_i' → dω_i: n² cos θ_i' dω_i' = cos θ_i dω_i
        total = total * i[..., 2] / (n_incident * n_incident * i_h[..., 2].clamp_min(torch.finfo(h.dtype).tiny))
    return total


def _white_profile(structure, theta_o, lam, kw, lobe_nodes, cosine_nodes) -> torch.Tensor:
    r"""Directional albedo :math:`\int f_r\cos\theta_i\,d\omega_i` (P, W) at the polar angles
    ``theta_o`` (P,) (φ_o = 0; the structures are isotropic).

    Deterministic multiple-importance quadrature: one rule per layer over its visible normals
    of ω_o' (Heitz's map of [0, 1]², Gauss–Legendre × uniform azimuths; ω_i' = reflect(ω_o', m),
    refracted out through the coating), plus a cosine-weighted rule when the base is
    Lambertian; the balance heuristic splits the integrand between the rules, so each rule
    integrates ∫ g q_k / Σ_j q_j, and their sum is ∫ g.
    """
    dtype, device = lam.dtype, lam.device
    n = structure.n_coating
    coated = bool(structure.coated)
    alphas = [_geometry.layer_alpha(layer, dtype, device) for layer in structure.layers]  # (tensors: the GGX bodies)
    wo = torch.stack([torch.sin(theta_o), torch.zeros_like(theta_o), torch.cos(theta_o)], -1)  # (P, 3)
    o_h = refract_into_host(wo, n) if coated else wo
    o_h = o_h.unsqueeze(-2)  # (P, 1, 3)
    wo_b = wo.unsqueeze(-2)
    tiny = torch.finfo(dtype).tiny
    total = 0.0
    for a in alphas:  # one lobe rule per layer
        u, w = _unit_square(lobe_nodes, dtype, device, _WARP)
        m = _vndf(o_h, a, u)  # (P, Q, 3)
        i_h = 2.0 * (o_h * m).sum(-1, keepdim=True) * m - o_h
        ok = i_h[..., 2] > 0
        i = i_h
        if coated:
            i, exits = _geometry.refract_out(i_h, n)
            ok = ok & exits
        # guard: directions below the horizon (or trapped by TIR) get weight 0; feed a safe normal
        safe = torch.zeros_like(i)
        safe[..., 2] = 1.0
        i = torch.where(ok.unsqueeze(-1), i, safe)
        i_h = torch.where(ok.unsqueeze(-1), i_h, safe)
        q = _lobe_density(o_h, i, i_h, alphas, n, coated)
        if structure.base_albedo > 0:
            q = q + i[..., 2] / math.pi
        g = _brdf(structure, i, wo_b, lam, kw) * i[..., 2].unsqueeze(-1)  # (P, Q, W)
        weight = torch.where(ok, w / q.clamp_min(tiny), torch.zeros_like(q))
        total = total + (g * weight.unsqueeze(-1)).sum(-2)
    if structure.base_albedo > 0:  # cosine-weighted rule for the Lambertian base
        u, w = _unit_square(cosine_nodes, dtype, device)
        s = torch.sqrt(u[:, 0])
        phi = 2.0 * math.pi * u[:, 1]
        i = torch.stack([s * torch.cos(phi), s * torch.sin(phi), torch.sqrt(1.0 - u[:, 0])], -1)
        i = i.expand(theta_o.shape[0], *i.shape)  # (P, Q, 3)
        i_h = refract_into_host(i, n) if coated else i
        q = _lobe_density(o_h, i, i_h, alphas, n, coated) + i[..., 2] / math.pi
        g = _brdf(structure, i, wo_b, lam, kw) * i[..., 2].unsqueeze(-1)
        total = total + (g * (w / q.clamp_min(tiny)).unsqueeze(-1)).sum(-2)
    if coated:  # the coating's specular Dirac reflects the white environment: + F(θ_o)
        total = total + coating_reflectance.__wrapped__(wo[:, 2].clamp(0.0, 1.0), float(n)).unsqueeze(-1)
    return total


def _interp_profile(values, theta_nodes, theta):
    """Linear interpolation of ``values`` (P, C) on uniform ``theta_nodes`` (P,) at ``theta`` (K,)."""
    P = theta_nodes.shape[0]
    t = (theta / theta_nodes[-1]).clamp(0.0, 1.0) * (P - 1)
    i0 = t.detach().floor().clamp(0, P - 2).long()
    f = (t - i0.to(t.dtype)).unsqueeze(-1)
    return values[i0] * (1 - f) + values[i0 + 1] * f


@_checks.arguments(structure=_geometry.STRUCTURE, resolution=_checks.integer(1), projection=PROJECTION,
                   reflectance=_checks.choice(REFLECTANCE_MODES), lobe_nodes=NODE_PAIR, cosine_nodes=NODE_PAIR,
                   profile_angles=_checks.integer(2) | None, incident_deg=INCIDENT,
                   transmissivity_angles=_checks.integer(2) | None)
def scatterogram(
    structure,
    *,
    incident_deg=None,
    resolution: int = 256,
    wavelength=None,
    projection: str = "equidistant",
    reflectance: str = "exact",
    profile_angles: int | None = None,
    lobe_nodes: tuple[int, int] = LOBE_NODES,
    cosine_nodes: tuple[int, int] = COSINE_NODES,
    transmissivity_angles: int | None = None,
    title: str = "",
) -> Scatterogram:
    r"""Render the scatterogram of a layered Bragg structure (Fourneau et al. 2024 §5, Fig. 9).

    Args:
        structure: a :class:`~torchirid.layered.structure.LayeredBragg` (or one
            :class:`~torchirid.layered.structure.RoughBraggLayer`); its layer parameters may be
            0-dim tensors with ``requires_grad``.
        incident_deg: ``(θ_i, φ_i)`` in degrees (numbers or 0-dim tensors; θ_i ∈ [0, 90]) for
            a narrow D65 beam from that direction; ``None`` (default) for the uniform white
            (D65) environment of Fig. 9.
        resolution: pixels per side of the square image.
        wavelength: ``(W,)`` increasing wavelengths in nm (default 380–780 nm, 5 nm steps);
            its dtype (or the layer tensors') sets the precision, float64 otherwise.
        projection: the angular mapping, one of :data:`PROJECTIONS` (see the module docstring).
        reflectance: ``"exact"`` (default) or ``"lut"``: the mirrors' reflectance from a per-call
            angle table (faster; see :func:`~torchirid.layered.single_reflection_brdf`).
        profile_angles: white environment only. The structures are isotropic, so the white
            image depends on θ_o alone: it is computed at ``profile_angles`` polar angles
            uniform on [0°, 90°] (default ``min(resolution + 1, 181)``: about two per pixel
            along a radius, at most 0.5° apart) and interpolated linearly to the pixels.
        lobe_nodes, cosine_nodes: white environment only, the quadrature per θ_o (see
            ``LOBE_NODES``, ``COSINE_NODES``; the cosine rule only with a base).
        transmissivity_angles: passed to ``single_reflection_brdf`` (default: its own, or 2
            for a single layer over a black base, which uses no transmissivity).
        title: a label kept with the result (figure titles).

    Returns:
        a :class:`Scatterogram` (``xyz`` of shape ``(resolution, resolution, 3)``; 0 outside
        the disc). Narrow beam: :math:`f_r(\omega_i,\omega_o)\cos\theta_i` of each pixel's
        ``ω_o`` (sr⁻¹) integrated against the CIE 1931 2° CMFs × D65, normalised so that a
        flat spectrum 1 has Y = 1. White environment: the directional albedo
        :math:`\int f_r\cos\theta_i\,d\omega_i` likewise (+ the coating's Fresnel
        reflectance F(θ_o) when ``n_incident ≠ 1``; the narrow beam omits that Dirac peak).

    Raises:
        ValueError: a bad argument, named (before any work).

    Example (the green jewel-beetle area, normal incidence: the specular peak is green):
        >>> from torchirid.presets import jewel_beetle
        >>> sg = scatterogram(jewel_beetle("green"), incident_deg=(0.0, 0.0), resolution=9)
        >>> x, y, z = sg.xyz[4, 4].tolist()
        >>> [round(v, 2) for v in (x, y, z)], y > max(x, z)
        ([2.44, 4.7, 2.45], True)
    """
    if profile_angles is None:
        profile_angles = min(resolution + 1, 181)
    dtype, device = _dtype_device(structure, wavelength, *(incident_deg or ()))
    lam = _wavelengths(wavelength, dtype, device)
    weights = xyz_weights(lam)  # validates the wavelengths: (W, 3), white Y = 1
    lam = _geometry.wavelengths(lam, dtype, device)  # in nm, finite: the grid of the BRDF's body
    kw = _brdf_kwargs(structure, reflectance, transmissivity_angles)
    directions, mask = scatterogram_directions.__wrapped__(resolution, projection=projection, dtype=dtype,
                                                           device=device)
    wo = directions[mask]  # (K, 3)

    if incident_deg is None:
        theta_nodes = torch.linspace(0.0, math.pi / 2, profile_angles, dtype=dtype, device=device)
        # guard: the visible-normal map needs cos θ_o > 0; the last node sits 1e-6 rad inside the rim
        theta_eval = theta_nodes.clamp(max=math.pi / 2 - 1e-6)
        profile = _white_profile(structure, theta_eval, lam, kw, lobe_nodes, cosine_nodes) @ weights  # (P, 3)
        theta_o = torch.acos(wo[:, 2].clamp(-1.0, 1.0))
        values = _interp_profile(profile, theta_nodes, theta_o)
        params_incident = None
    else:
        th = _checks.as_real(incident_deg[0], "incident_deg theta", dtype, device)
        ph = _checks.as_real(incident_deg[1], "incident_deg phi", dtype, device)
        if th.dim() != 0 or ph.dim() != 0:
            raise ValueError("incident_deg must hold two scalars (theta_deg, phi_deg)")
        with torch.no_grad():
            if not bool((th >= 0) & (th <= 90)):
                raise ValueError(f"incident_deg theta must lie in [0, 90] degrees; got {float(th):g}")
        t, p = torch.deg2rad(th), torch.deg2rad(ph)
        wi = torch.stack([torch.sin(t) * torch.cos(p), torch.sin(t) * torch.sin(p), torch.cos(t)])
        values = _beam_xyz(structure, wi, wo, lam, kw, weights)
        params_incident = (float(th.detach()), float(ph.detach()))

    flat = torch.zeros(resolution * resolution, 3, dtype=values.dtype, device=device)
    idx = mask.reshape(-1).nonzero().squeeze(-1)
    xyz = flat.index_copy(0, idx, values).reshape(resolution, resolution, 3)
    params = {
        "illumination": "white" if incident_deg is None else "beam",
        "incident_deg": params_incident,
        "projection": projection,
        "resolution": resolution,
        "reflectance": reflectance,
        "wavelength_nm": [float(lam[0]), float(lam[-1]), int(lam.numel())],
        "base_albedo": float(structure.base_albedo),
        "layers": [layer.numbers() | {"n2": _json_index(layer.numbers()["n2"])} for layer in structure.layers],
    }
    if incident_deg is None:
        params.update(profile_angles=profile_angles, lobe_nodes=list(lobe_nodes), cosine_nodes=list(cosine_nodes))
    return Scatterogram(xyz, mask, directions, projection, params_incident, lam, title, params)


def _json_index(n):
    return [n.real, n.imag] if isinstance(n, complex) else n


# ----------------------------------------------------------------------------------------
# display image (the figures and the files are in torchirid.app.figures.scatterograms)
# ----------------------------------------------------------------------------------------
def _exposure_of(sg: Scatterogram, exposure) -> float:
    if isinstance(exposure, str):
        if exposure != "auto":
            raise ValueError(f"exposure must be a number > 0 or 'auto'; got {exposure!r}")
        peak = float(sg.xyz[..., 1].detach().max())
        return 1.0 / peak if peak > 0 else 1.0
    if isinstance(exposure, bool) or not isinstance(exposure, numbers.Real) or not exposure > 0:
        raise ValueError(f"exposure must be a number > 0 or 'auto'; got {exposure!r}")
    return float(exposure)


def scatterogram_srgb(sg: Scatterogram, exposure="auto") -> np.ndarray:
    """The display image ``(H, W, 3)`` in [0, 1]: ``exposure × xyz`` → sRGB (D65), clipped;
    black outside the disc. ``exposure="auto"`` maps the brightest pixel's Y to 1.

    Example:
        >>> import torch
        >>> from torchirid.layered import RoughBraggLayer, scatterogram
        >>> layer = RoughBraggLayer(n1=1.0, n2=1.5, d1=125.0, d2=375.0, cells=20, alpha=0.2)  # nm
        >>> sg = scatterogram(layer, incident_deg=(0.0, 0.0), resolution=5,
        ...                   wavelength=torch.linspace(380.0, 780.0, 41, dtype=torch.float64))  # nm
        >>> img = scatterogram_srgb(sg)  # a numpy array, ready for imshow / imsave
        >>> img.shape, img.dtype.name, float(img.min()), float(img.max())
        ((5, 5, 3), 'float64', 0.0, 1.0)
        >>> img[0, 0].tolist()  # a corner: outside the disc
        [0.0, 0.0, 0.0]
    """
    e = _exposure_of(sg, exposure)
    rgb = xyz_to_srgb(sg.xyz.detach().to(torch.float64) * e).clamp(0.0, 1.0)
    rgb = torch.where(sg.mask.unsqueeze(-1), rgb, torch.zeros_like(rgb))
    return rgb.cpu().numpy()
