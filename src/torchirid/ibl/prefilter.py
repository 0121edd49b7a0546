r"""Environment prefiltering for image-based lighting of thin films (Kneiphof et al. 2019 §4.2).

Equirectangular convention (every function here): an environment map is a tensor ``(H, W, 3)``
of linear RGB radiance; row ``i`` holds the polar angle from +z (up)
:math:`θ_i = (i + ½)π/H` (row 0 = zenith, row H−1 = nadir) and column ``j`` the azimuth
:math:`φ_j = (j + ½)2π/W` measured from +x towards +y, so the texel's direction is
:math:`(\sin θ\cos φ, \sin θ\sin φ, \cos θ)`. Its solid angle is exact,
:math:`(\cos θ_{i-½} − \cos θ_{i+½})\,2π/W` (they sum to 4π).

Prefiltering (Karis 2013 split sum, n = v = R): for each roughness α and output direction R the
lobe weight of a light direction l is the GGX half-vector density turned into a density over l,
:math:`w(l) = D(h)\,⟨R, h⟩/(4⟨R, h⟩)\,⟨R, l⟩^+ = D(h)\,⟨R, l⟩^+/4`,
:math:`h = (R + l)/|R + l|`, :math:`⟨R, h⟩ = \sqrt{(1 + ⟨R, l⟩)/2}`. Then

- prefiltered radiance :math:`\bar L(R) = ∫ w L\,dω / ∫ w\,dω` (3 channels);
- Kneiphof's nine moment channels, the moments of l under :math:`w(l)\,Y(L(l))` (Y = Rec. 709
  luminance of the radiance), :math:`E[x], E[y], E[z], E[x^2], E[y^2], E[z^2], E[xy], E[yz], E[zx]`
  — :func:`light_moments_to_mean_cov` turns them into the light mean μ_ωi and covariance Σ_ωi
  consumed by :func:`~torchirid.ibl.thin_film_xyz_filtered`. Where the lobe sees no light
  (∫ w Y dω = 0) the moments fall back to those of the lobe alone.

Integration is deterministic: a sum over every texel with its solid angle (outputs × texels,
in blocks of output directions, :mod:`torchirid._chunks`), so the result is reproducible and differentiable w.r.t. the map. It resolves lobes
wider than about a texel; for α below roughly the texel size (≈ π/H rad) the result tends to
the nearest texels rather than a mirror lookup.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np
import torch

from .. import _checks, _chunks
from .._io import check_readable, file_error, read_exr, reading
from ..lut import LUT
from ..microfacet.ggx import ggx_d_kernel

__all__ = [
    "PrefilteredEnvironment",
    "read_environment",
    "prefilter_environment",
    "synthetic_environment",
]

PREFILTERED_ENVIRONMENT_BUILDER = "torchirid.ibl.prefilter:PrefilteredEnvironment.to_lut"
MOMENT_CHANNELS = ("x", "y", "z", "xx", "yy", "zz", "xy", "yz", "zx")
_LUMA = (0.2126, 0.7152, 0.0722)  # Rec. 709 / sRGB primaries, linear luminance Y
_ENV_SUFFIXES = (".exr", ".hdr")


def _check_float_dtype(dtype):
    if dtype not in (torch.float64, torch.float32):
        raise ValueError(f"dtype must be torch.float64 or torch.float32; got {dtype!r}")


def equirect_directions(height: int, width: int, *, dtype: torch.dtype = torch.float64,
                        device=None) -> tuple[torch.Tensor, torch.Tensor]:
    """Unit direction and solid angle of every texel of an equirectangular map (module convention).

    Args:
        height, width: map size H, W (≥ 1).
        dtype: ``torch.float64`` or ``torch.float32``; device: where to build them.

    Returns:
        ``(directions (H, W, 3), solid_angles (H, W))`` in sr; the solid angles sum to 4π.

    Example:
        >>> d, w = equirect_directions(4, 8)
        >>> round(float(w.sum()), 6), [round(v, 4) for v in d[0, 0].tolist()]
        (12.566371, [0.3536, 0.1464, 0.9239])
    """
    _checks.check_int(height, "height", 1)
    _checks.check_int(width, "width", 1)
    _check_float_dtype(dtype)
    i = torch.arange(height, dtype=torch.float64, device=device)
    j = torch.arange(width, dtype=torch.float64, device=device)
    theta = (i + 0.5) * (math.pi / height)
    phi = (j + 0.5) * (2.0 * math.pi / width)
    st, ct = torch.sin(theta)[:, None], torch.cos(theta)[:, None]
    d = torch.stack([st * torch.cos(phi), st * torch.sin(phi), ct.expand(-1, width)], -1)
    edges = torch.cos(torch.arange(height + 1, dtype=torch.float64, device=device) * (math.pi / height))
    omega = ((edges[:-1] - edges[1:]) * (2.0 * math.pi / width))[:, None].expand(-1, width)
    return d.to(dtype), omega.to(dtype).contiguous()


#: scenes of :func:`synthetic_environment`
SYNTHETIC_SCENES = ("sky", "sun_sky", "indoor")
# CIE standard clear sky (CIE S 011/E:2003, type 12: "standard clear sky, low turbidity"):
# gradation a, b and indicatrix c, d, e of L(θ, γ)/L_z = f(γ)φ(θ) / (f(θ_s)φ(0))
_CIE_CLEAR = (-1.0, -0.32, 10.0, -3.0, 0.45)
# the indoor scene: (centre θ°, centre φ°, half-size θ°, half-size φ°, RGB radiance) of its sources
_INDOOR_LIGHTS = ((12.0, 60.0, 7.0, 22.0, (24.0, 22.0, 19.0)),      # ceiling panel (neutral white)
                  (30.0, 250.0, 6.0, 10.0, (30.0, 24.0, 15.0)),     # ceiling spot (warm)
                  (78.0, 150.0, 14.0, 24.0, (6.0, 7.0, 8.5)),       # window (daylight)
                  (95.0, 320.0, 5.0, 6.0, (40.0, 26.0, 12.0)))      # table lamp shade (incandescent)


def _sun_disc(d, s, radius, radiance, colour, conserve):
    """Mask and radiance of the sun's texels: centres within ``radius`` of ``s``, else the nearest
    texel; with ``conserve`` the disc's power 2π(1 − cos r)·radiance is spread over them."""
    cos_to_sun = (d * s).sum(-1)
    disc = cos_to_sun >= math.cos(radius)
    if not bool(disc.any()):
        disc = cos_to_sun == cos_to_sun.max()
    sun = radiance * torch.tensor(colour, dtype=torch.float64)
    if conserve:
        _, omega = equirect_directions(d.shape[0], d.shape[1], dtype=torch.float64)
        sun = sun * (2.0 * math.pi * (1.0 - math.cos(radius)) / float(omega[disc].sum()))
    return disc, sun


def _cie_clear_sky(d, s):
    """Relative luminance of the CIE clear sky at the directions ``d`` for the sun at ``s`` (z up)."""
    a, b, c, dd, e = _CIE_CLEAR
    z = d[..., 2].clamp(min=1e-3)
    gamma = torch.arccos((d * s).sum(-1).clamp(-1.0, 1.0))
    zs = math.acos(min(max(float(s[2]), -1.0), 1.0))

    def f(g):
        return 1.0 + c * (torch.exp(dd * g) - math.exp(dd * math.pi / 2)) + e * torch.cos(g) ** 2

    phi = 1.0 + a * torch.exp(b / z)
    return f(gamma) * phi / (f(torch.tensor(zs, dtype=d.dtype)) * (1.0 + a * math.exp(b)))


def synthetic_environment(height: int = 64, width: int = 128, *, dtype: torch.dtype = torch.float64,
                          sun_direction=(0.5, 0.3, 0.8124), sun_radius: float = 0.06,
                          sun_radiance: float = 200.0, sky: bool = True, scene: str = "sky") -> torch.Tensor:
    """A generated environment (linear RGB radiance, module convention), so IBL runs out of the box.

    Three scenes (``scene=``, ``SYNTHETIC_SCENES``; nothing is downloaded):

    * ``"sky"`` (default): a blue gradient from the horizon (0.9, 0.95, 1.0) to the zenith
      (0.25, 0.45, 1.0), a grey ground 0.2 below the horizon, and a sun: texels whose centre lies
      within ``sun_radius`` rad (default 0.06 ≈ 3.4°) of ``sun_direction`` (normalised; default
      ≈ 36° from the zenith, azimuth 31°) get ``sun_radiance`` × (1, 0.95, 0.85); if no texel
      centre falls in the disc the nearest texel is lit, so the sun never vanishes on coarse maps.
    * ``"sun_sky"``: the CIE standard clear sky (CIE S 011, type 12: brighter around the sun and
      towards the horizon, zenith luminance 1) coloured from blue at the zenith to white at the
      sun and the horizon, a ground of albedo 0.2 below the horizon, and a sun disc of
      ``sun_radius`` and ``sun_radiance`` × (1, 0.95, 0.85) whose **power is kept**: the disc's
      2π(1 − cos r)·radiance is spread over the texels that hold it (the nearest one on a
      coarse map), so a small bright sun has the same irradiance on any map size. Pass a small
      radius and a large radiance for a real sun (the benchmark's: 0.03 rad, 2000).
    * ``"indoor"``: a room — a warm grey ceiling (0.35), walls (0.25, 0.23, 0.2) and a dark
      wooden floor (0.12, 0.08, 0.05) — lit by four bright rectangular sources in (θ, φ): a
      ceiling panel, a warm ceiling spot, a daylight window in a wall and an incandescent
      lamp shade just below the horizon (``_INDOOR_LIGHTS``; radiance 6–40, a few percent of
      the sphere). The ``sun_*`` and ``sky`` arguments do not apply.

    Args:
        height, width: map size (≥ 1). dtype: float64 or float32.
        sun_direction: (3,) direction towards the sun (non-zero).
        sun_radius: angular radius in rad, > 0. sun_radiance: ≥ 0.
        sky: False gives the sun alone on black (for tests; ``"sky"`` and ``"sun_sky"``).
        scene: ``"sky"`` (default), ``"sun_sky"`` or ``"indoor"``.

    Returns:
        ``(H, W, 3)`` radiance, CPU.

    Example:
        >>> env = synthetic_environment(16, 32)
        >>> tuple(env.shape), round(float(env.max()), 1)
        ((16, 32, 3), 200.0)
        >>> [tuple(synthetic_environment(16, 32, scene=s).shape) for s in ("sun_sky", "indoor")]
        [(16, 32, 3), (16, 32, 3)]
    """
    _check_float_dtype(dtype)
    _checks.check_choice(scene, "scene", SYNTHETIC_SCENES)
    d, _ = equirect_directions(height, width, dtype=torch.float64)
    if scene == "indoor":
        return _indoor(d).to(dtype)
    s = torch.as_tensor(sun_direction, dtype=torch.float64)
    if s.shape != (3,) or not bool(torch.isfinite(s).all()) or float(s.norm()) == 0.0:
        raise ValueError(f"sun_direction must be a finite non-zero (3,) vector; got {sun_direction!r}")
    if not (math.isfinite(sun_radius) and sun_radius > 0):
        raise ValueError(f"sun_radius must be > 0 (rad); got {sun_radius!r}")
    if not (math.isfinite(sun_radiance) and sun_radiance >= 0):
        raise ValueError(f"sun_radiance must be >= 0; got {sun_radiance!r}")
    s = s / s.norm()
    z = d[..., 2:3]
    env = torch.zeros(height, width, 3, dtype=torch.float64)
    if sky and scene == "sky":
        horizon = torch.tensor([0.9, 0.95, 1.0], dtype=torch.float64)
        zenith = torch.tensor([0.25, 0.45, 1.0], dtype=torch.float64)
        t = z.clamp(0.0, 1.0) ** 0.5
        env = torch.where(z >= 0, (1 - t) * horizon + t * zenith, torch.full_like(env, 0.2))
    elif sky:
        lum = _cie_clear_sky(d, s)[..., None]
        # colour: deep blue where the sky is darkest, white where it is bright (sun, horizon)
        white = (lum.clamp(0.0, 4.0) / 4.0) ** 0.5
        blue = torch.tensor([0.35, 0.55, 1.0], dtype=torch.float64)
        colour = (1 - white) * blue + white
        colour = colour / (colour @ torch.as_tensor(_LUMA, dtype=torch.float64))[..., None]
        ground = 0.2 * float(torch.where(z[..., 0] >= 0, lum[..., 0], torch.zeros_like(lum[..., 0])).mean())
        env = torch.where(z >= 0, lum * colour, torch.full_like(env, ground))
    disc, sun = _sun_disc(d, s, sun_radius, sun_radiance, (1.0, 0.95, 0.85), conserve=scene == "sun_sky")
    env = torch.where(disc[..., None], sun, env)
    return env.to(dtype)


def _indoor(d):
    """The ``"indoor"`` scene of :func:`synthetic_environment` at the directions ``d`` (H, W, 3)."""
    z = d[..., 2:3]
    env = torch.where(z > 0.8, torch.tensor([0.35, 0.34, 0.32], dtype=torch.float64),
                      torch.where(z > -0.25, torch.tensor([0.25, 0.23, 0.2], dtype=torch.float64),
                                  torch.tensor([0.12, 0.08, 0.05], dtype=torch.float64)))
    theta = torch.rad2deg(torch.arccos(z[..., 0].clamp(-1.0, 1.0)))
    phi = torch.rad2deg(torch.remainder(torch.atan2(d[..., 1], d[..., 0]), 2.0 * math.pi))
    for t0, p0, dt, dp, rgb in _INDOOR_LIGHTS:
        dphi = torch.remainder(phi - p0 + 180.0, 360.0) - 180.0
        inside = ((theta - t0).abs() <= dt) & (dphi.abs() <= dp)
        env = torch.where(inside[..., None], torch.tensor(rgb, dtype=torch.float64), env)
    return env


@dataclass(frozen=True)
class PrefilteredEnvironment:
    """Result of :func:`prefilter_environment` (A roughness levels, an Ho × Wo output grid).

    Attributes:
        alphas: ``(A,)`` GGX roughness of each level.
        directions: ``(Ho, Wo, 3)`` output directions R (= n = v), module convention.
        radiance: ``(A, Ho, Wo, 3)`` prefiltered RGB radiance.
        moments: ``(A, Ho, Wo, 9)`` light-direction moments, channel order ``MOMENT_CHANNELS``.

    Example (obtained from :func:`prefilter_environment`; two roughness levels, a 4 × 8 grid):
        >>> import torch
        >>> alphas = torch.tensor([0.2, 0.6], dtype=torch.float64)
        >>> pre = prefilter_environment(synthetic_environment(8, 16), alphas, resolution=4)
        >>> pre.radiance.shape, pre.moments.shape
        (torch.Size([2, 4, 8, 3]), torch.Size([2, 4, 8, 9]))
        >>> mean, cov = pre.mean_cov()
        >>> cov.shape
        torch.Size([2, 4, 8, 3, 3])
        >>> back = PrefilteredEnvironment.from_lut(pre.to_lut())  # through a LUT, e.g. a file
        >>> torch.equal(back.moments, pre.moments)
        True
    """

    alphas: torch.Tensor
    directions: torch.Tensor
    radiance: torch.Tensor
    moments: torch.Tensor

    def mean_cov(self) -> tuple[torch.Tensor, torch.Tensor]:
        """``(mean (A, Ho, Wo, 3), cov (A, Ho, Wo, 3, 3))`` of the light directions."""
        return light_moments_to_mean_cov(self.moments)

    def to_lut(self, *, parameters=None) -> "LUT":
        """The maps as one :class:`~torchirid.lut.LUT`: axes ``alpha`` (A ≥ 2 levels), ``theta``
        and ``phi`` (radians, texel centres of the module convention), channels ``(12,)`` =
        R, G, B radiance then the nine moments (``MOMENT_CHANNELS``). Save it with
        ``.write(path)``, export it for shaders with :func:`torchirid.export.export_lut`
        (OpenEXR or raw float32 + JSON), read it back with :meth:`from_lut`.
        ``parameters``: extra JSON metadata (e.g. the environment's file name).

        φ is periodic but a LUT axis is not: :meth:`LUT.interp <torchirid.lut.LUT.interp>`
        clamps within half a texel of φ = 0 and 2π (reading the edge column, up to ~14 % off
        there on a 32 × 64 sky) where :func:`~torchirid.ibl.shade_thin_film_environment`
        wraps. Sample the exported texture with REPEAT wrapping in φ (GL_REPEAT on the S axis),
        or pad one column on each side before interpolating in Python.
        """
        if self.alphas.numel() < 2:
            raise ValueError("to_lut needs at least 2 roughness levels (a LUT axis has >= 2 nodes); "
                             "prefilter with more alphas")
        order = torch.argsort(self.alphas)
        ho, wo = self.directions.shape[:2]
        dt, dev = self.radiance.dtype, self.radiance.device
        theta = (torch.arange(ho, dtype=dt, device=dev) + 0.5) * (math.pi / ho)
        phi = (torch.arange(wo, dtype=dt, device=dev) + 0.5) * (2.0 * math.pi / wo)
        values = torch.cat([self.radiance, self.moments], -1)[order]
        return LUT(values, {"alpha": self.alphas[order], "theta": theta, "phi": phi},
                   builder=PREFILTERED_ENVIRONMENT_BUILDER, parameters=dict(parameters or {}),
                   units={"alpha": "1", "theta": "rad", "phi": "rad",
                          "values": "radiance (linear RGB, as the map) then moments of l (1)"})

    @classmethod
    def from_lut(cls, lut: "LUT") -> "PrefilteredEnvironment":
        """Inverse of :meth:`to_lut` (refuses a LUT from another builder)."""
        if not isinstance(lut, LUT) or lut.builder != PREFILTERED_ENVIRONMENT_BUILDER:
            raise ValueError("lut must be a LUT written by PrefilteredEnvironment.to_lut")
        v = lut.values
        ho, wo = v.shape[1], v.shape[2]
        R, _ = equirect_directions(ho, wo, dtype=v.dtype, device=v.device)
        return cls(alphas=lut.axes["alpha"], directions=R, radiance=v[..., :3], moments=v[..., 3:])


def light_moments_to_mean_cov(m) -> tuple[torch.Tensor, torch.Tensor]:
    """Light-direction mean and covariance from the nine moment channels (Kneiphof et al. 2019 §4.2).

    Args:
        m: ``(*, 9)`` = E[x], E[y], E[z], E[x²], E[y²], E[z²], E[xy], E[yz], E[zx].

    Returns:
        ``(mean (*, 3), cov (*, 3, 3))``, cov = E[l lᵀ] − μ μᵀ (symmetric; PSD up to rounding
        and interpolation, which :func:`~torchirid.ibl.thin_film_xyz_filtered` tolerates).

    Example:
        >>> mu, cov = light_moments_to_mean_cov(torch.tensor([0., 0., 1., 0., 0., 1., 0., 0., 0.]))
        >>> mu.tolist(), float(cov.abs().max())
        ([0.0, 0.0, 1.0], 0.0)
    """
    dtype, device = _checks.resolve_dtype_device(m)
    t = _checks.as_real(m, "m", dtype, device)
    if t.ndim == 0 or t.shape[-1] != 9:
        raise ValueError(f"m must have shape (*, 9) (the nine moment channels); got {tuple(t.shape)}")
    mean = t[..., 0:3]
    xx, yy, zz, xy, yz, zx = (t[..., k] for k in range(3, 9))
    second = torch.stack([torch.stack([xx, xy, zx], -1),
                          torch.stack([xy, yy, yz], -1),
                          torch.stack([zx, yz, zz], -1)], -2)
    return mean, second - mean[..., :, None] * mean[..., None, :]


def _resolution(resolution):
    if isinstance(resolution, int) and not isinstance(resolution, bool):
        resolution = (resolution, 2 * resolution)
    if (not isinstance(resolution, (tuple, list)) or len(resolution) != 2
            or any(isinstance(r, bool) or not isinstance(r, int) or r < 1 for r in resolution)):
        raise ValueError(f"resolution must be an integer >= 1 (height; width = 2·height) or a pair "
                         f"(height, width) of integers >= 1; got {resolution!r}")
    return tuple(resolution)


def prefilter_environment(env, alphas, *, resolution=(32, 64)) -> PrefilteredEnvironment:
    r"""GGX-prefiltered radiance and light-direction moments of an equirectangular map (split sum, n = v = R).

    See the module docstring for the lobe weight :math:`w(l) = D(h)⟨R,l⟩^+/4` and the moments.

    Args:
        env: ``(H, W, 3)`` linear RGB radiance (≥ 0; NaN propagates), module convention. Its
            dtype (float32/float64) and device are kept.
        alphas: GGX roughness, a scalar or ``(A,)``, each > 0 (resolved down to ~π/H rad).
        resolution: output grid, ``(Ho, Wo)`` or an int Ho (Wo = 2·Ho); default (32, 64).

    Returns:
        :class:`PrefilteredEnvironment` (radiance ``(A, Ho, Wo, 3)``, moments ``(A, Ho, Wo, 9)``).
        Cost: A · Ho·Wo · H·W kernel evaluations.

    Example:
        >>> pre = prefilter_environment(torch.ones(8, 16, 3, dtype=torch.float64), 0.5, resolution=4)
        >>> round(float(pre.radiance.max()), 6), round(float(pre.radiance.min()), 6)
        (1.0, 1.0)
    """
    dtype, device = _checks.resolve_dtype_device(env, alphas)
    e = _checks.as_real(env, "env", dtype, device)
    if e.ndim != 3 or e.shape[-1] != 3 or e.shape[0] < 1 or e.shape[1] < 1:
        raise ValueError(f"env must have shape (H, W, 3) (linear RGB, equirectangular); got {tuple(e.shape)}")
    with torch.no_grad():
        if bool((e < 0).any()):
            raise ValueError("env must be >= 0 (radiance)")
    a = _checks.as_real(alphas, "alphas", dtype, device)
    if a.ndim > 1:
        raise ValueError(f"alphas must be a scalar or 1-D; got shape {tuple(a.shape)}")
    a = a.reshape(-1)
    if a.numel() == 0:
        raise ValueError("alphas must not be empty")
    _checks.check_positive(a, "alphas", unit="(GGX roughness)")
    ho, wo = _resolution(resolution)
    h, w = e.shape[0], e.shape[1]
    l, omega = equirect_directions(h, w, dtype=dtype, device=device)
    l, omega, L = l.reshape(-1, 3), omega.reshape(-1), e.reshape(-1, 3)
    R, _ = equirect_directions(ho, wo, dtype=dtype, device=device)
    R = R.reshape(-1, 3)
    luma = L @ torch.as_tensor(_LUMA, dtype=dtype, device=device)
    x, y, z = l.unbind(-1)
    basis = torch.stack([x, y, z, x * x, y * y, z * z, x * y, y * z, z * x], -1)  # (T, 9)
    rad_out, mom_out = [], []
    for k in range(a.numel()):
        # block by block over the output directions (torchirid._chunks): every texel per direction
        rad, mom = _chunks.evaluate(_prefilter_block, (R,), (R.shape[0],), core=(1,), out_core=1, width=l.shape[0],
                                    grad_inputs=(e, a), alpha=a[k], l=l, omega=omega, L=L, luma=luma, basis=basis)
        rad_out.append(rad.reshape(ho, wo, 3))
        mom_out.append(mom.reshape(ho, wo, 9))
    return PrefilteredEnvironment(alphas=a, directions=R.reshape(ho, wo, 3),
                                  radiance=torch.stack(rad_out), moments=torch.stack(mom_out))


def _prefilter_block(R, *, alpha, l, omega, L, luma, basis):
    """Radiance ``(C, 3)`` and light moments ``(C, 9)`` of the output directions ``R`` ``(C, 3)``."""
    c = (R @ l.T).clamp(-1.0, 1.0)  # ⟨R, l⟩, (C, T)
    front = c > 0
    cos_h = torch.sqrt((1.0 + c.clamp_min(0.0)) * 0.5)  # ⟨R, h⟩ (the back half is weighted 0)
    wgt = torch.where(front, ggx_d_kernel(cos_h, alpha) * c * 0.25, torch.zeros_like(c)) * omega
    total = wgt.sum(-1, keepdim=True)  # > 0: every R has texels in its front hemisphere
    rad = (wgt @ L) / total
    wy = wgt * luma
    ty = wy.sum(-1, keepdim=True)
    lit = ty > 0
    # a lobe that sees no light falls back to the lobe's own moments (no 0/0)
    m_lit = (wy @ basis) / torch.where(lit, ty, torch.ones_like(ty))
    m_lobe = (wgt @ basis) / total
    return rad, torch.where(lit, m_lit, m_lobe)


_ENV_WHAT = "environment map"
_RGBE_MAGIC = (b"#?RADIANCE", b"#?RGBE")


def _read_hdr(path) -> np.ndarray:
    """Radiance RGBE (.hdr) → (H, W, 3) float64 linear RGB; flat or new-style RLE scanlines, -Y H +X W."""
    p = check_readable(path, _ENV_WHAT, magic=_RGBE_MAGIC, kind="a Radiance .hdr file ('#?RADIANCE' / '#?RGBE')")
    with reading(p, _ENV_WHAT):
        return _decode_rgbe(p.read_bytes(), p)


def _decode_rgbe(data: bytes, p) -> np.ndarray:
    def bad(why):
        return file_error(_ENV_WHAT, p, why)

    pos = 0
    while True:  # header lines until an empty line
        end = data.find(b"\n", pos)
        if end < 0:
            raise bad("is truncated (the .hdr header does not end)")
        line = data[pos:end].strip()
        pos = end + 1
        if not line:
            break
        if line.startswith(b"FORMAT=") and line != b"FORMAT=32-bit_rle_rgbe":
            raise bad(f"only FORMAT=32-bit_rle_rgbe is supported; got {line.decode(errors='replace')}")
    end = data.find(b"\n", pos)
    parts = data[pos:end if end >= 0 else len(data)].split()
    if not parts:
        raise bad("is truncated (no '-Y H +X W' resolution line after the .hdr header)")
    if len(parts) != 4 or parts[0] != b"-Y" or parts[2] != b"+X":
        raise bad(f"only the standard '-Y H +X W' .hdr orientation is supported; got {parts!r}")
    try:
        height, width = int(parts[1]), int(parts[3])
    except ValueError as exc:
        raise bad(f"has a bad .hdr resolution line {parts!r}") from exc
    if height < 1 or width < 1:
        raise bad(f"has a bad .hdr size {height} x {width}")
    pos = end + 1 if end >= 0 else len(data)
    # the fewest bytes a scanline can take (flat: 4 per pixel; new-style RLE: a 4-byte marker,
    # then per channel one 2-byte run per 127 pixels): refuse a header promising more pixels than
    # the file can hold before allocating them
    rle = 8 <= width < 32768
    least = min(4 * width, 4 + 8 * -(-width // 127)) if rle else 4 * width
    if height * least > len(data) - pos:
        raise bad(f"is truncated: {len(data) - pos} bytes of pixel data cannot hold the {height} x {width} pixels "
                  f"of its header")
    buf = np.frombuffer(data, dtype=np.uint8)
    out = np.empty((height, width, 4), dtype=np.uint8)
    try:
        for row in range(height):
            if rle and buf[pos] == 2 and buf[pos + 1] == 2 and not (buf[pos + 2] & 0x80):
                if (int(buf[pos + 2]) << 8 | int(buf[pos + 3])) != width:
                    raise bad(f"has a wrong RLE width in .hdr scanline {row}")
                pos += 4
                for ch in range(4):
                    x = 0
                    while x < width:
                        count = int(buf[pos])
                        pos += 1
                        if count > 128:  # a run
                            count -= 128
                            if count > width - x:
                                raise bad(f"has an RLE run overflowing .hdr scanline {row}")
                            out[row, x:x + count, ch] = buf[pos]
                            pos += 1
                        else:  # literal bytes
                            if count == 0 or count > width - x:
                                raise bad(f"has a bad RLE count in .hdr scanline {row}")
                            if pos + count > buf.size:
                                raise IndexError
                            out[row, x:x + count, ch] = buf[pos:pos + count]
                            pos += count
                        x += count
            else:  # flat (uncompressed) scanline
                if pos + 4 * width > buf.size:
                    raise IndexError
                px = buf[pos:pos + 4 * width].reshape(width, 4)
                if bool(((px[:, 0] == 1) & (px[:, 1] == 1) & (px[:, 2] == 1)).any()):
                    raise bad("uses the old-style .hdr run-length encoding (not supported)")
                out[row] = px
                pos += 4 * width
    except IndexError as exc:
        raise bad("is truncated (the .hdr pixel data end early)") from exc
    e = out[..., 3].astype(np.int32)
    scale = np.where(e == 0, 0.0, np.ldexp(1.0, e - 136))  # Radiance colr_color: (m + ½)·2^(e−136)
    return (out[..., :3].astype(np.float64) + 0.5) * scale[..., None]


def read_environment(path, *, dtype: torch.dtype = torch.float64) -> torch.Tensor:
    """Read a user's equirectangular environment map as linear RGB radiance ``(H, W, 3)`` (CPU).

    ``.exr`` (OpenEXR, channels R, G, B or Y; needs the optional ``openexr`` package; non-finite
    texels and texels with A ≤ 0 are set to 0) or ``.hdr`` (Radiance RGBE, flat or new-style RLE,
    standard ``-Y H +X W`` orientation; the EXPOSURE header is ignored). The map is taken to be
    in the module's equirectangular convention (row 0 = zenith +z).

    Raises:
        ValueError: another suffix; an empty, truncated, damaged or foreign file; an EXR without
            R, G, B (or Y) channels; an unsupported .hdr variant (the message names the file).
        FileNotFoundError: no file at ``path``.
        ImportError: an ``.exr`` path without the ``openexr`` package.

    Example (a 2 × 4 Radiance file written on the spot, then prefiltered):
        >>> import os, tempfile
        >>> header = b"#?RADIANCE\\nFORMAT=32-bit_rle_rgbe\\n\\n-Y 2 +X 4\\n"
        >>> texels = bytes([128, 128, 128, 129]) * 8  # RGBE: radiance (128 + ½)/128 each
        >>> with tempfile.TemporaryDirectory() as folder:
        ...     path = os.path.join(folder, "sky.hdr")
        ...     with open(path, "wb") as f:
        ...         _ = f.write(header + texels)
        ...     env = read_environment(path)
        >>> env.shape, env.dtype
        (torch.Size([2, 4, 3]), torch.float64)
        >>> round(float(env.mean()), 4)
        1.0039
        >>> prefilter_environment(env, 0.5, resolution=2).radiance.shape
        torch.Size([1, 2, 4, 3])
    """
    _check_float_dtype(dtype)
    suffix = os.path.splitext(os.fspath(path))[1].lower()
    if suffix == ".exr":
        rgb, _ = read_exr(path, what=_ENV_WHAT)
    elif suffix == ".hdr":
        rgb = _read_hdr(path)
    else:
        raise ValueError(f"path must end in one of {', '.join(_ENV_SUFFIXES)} (OpenEXR or Radiance RGBE); "
                         f"got {os.fspath(path)!r}")
    return torch.from_numpy(np.ascontiguousarray(rgb)).to(dtype)

