r"""Environment-lit thin-film shading: Kneiphof et al. 2019 eq. 12 with a prefiltered map (§4, §5).

Kneiphof's eq. 12 factors the reflected radiance of a GGX surface whose facets carry a thin
film into three integrals,

.. math:: L_o(ω_o) ≈ \underbrace{\int \tilde ρ\,⟨n, ω_i⟩\,dω_i}_{A(\cos θ_o,\,α)}\;
          \underbrace{\int p_{L_i} L_i\,dω_i}_{\bar L(ω_r,\,α)}\;
          \underbrace{\int p_R\,R(⟨h, ω_i⟩)\,dω_i}_{\text{reflectance term}},

- :math:`A` — the prefiltered BRDF with a constant reflectance term (eq. 10, 12): Karis'
  split-sum table with F ≡ 1, i.e. scale + bias of :func:`~torchirid.ibl.shipped_dfg_lut`
  (:math:`F_0 A + B` at :math:`F_0 = 1`);
- :math:`\bar L` — the prefiltered environment map of :func:`~torchirid.ibl.prefilter_environment`
  read at the ideal reflection direction :math:`ω_r = 2⟨ω_o, n⟩n - ω_o` (split sum: the lobe is
  taken with :math:`ω_o = n = ω_r`);
- the reflectance term, by ``method``:

  * ``"fitted"`` (default) — the fitted light-mixture table of
    :func:`~torchirid.ibl.thin_film_xyz_fitted` (K = 5 Gaussians in cos θ₁ = ⟨h, ω_i⟩, fitted to
    *uniform* light in the true GGX lobe of (ω_o, n, α)) **moved into the light the lobe gathers**.
    cos θ₁ = √((1 + ⟨ω_i, ω_o⟩)/2) depends on the light direction only through ⟨ω_i, ω_o⟩, whose
    mean and variance under the prefiltered light are ⟨μ, ω_o⟩ and ω_oᵀΣω_o (the nine moment
    channels at ω_r); the same two numbers under uniform light in the same split-sum lobe follow
    in closed form from α (the lobe's own moments, ``_lobe_moments``). Both are taken to cos θ₁
    by the delta method — means m_light, m_lobe and spreads σ_light, σ_lobe — and each component
    is mapped by c̄ₖ' = m_light + s (c̄ₖ − m_lobe), sₖ' = s·sₖ with s = σ_light/σ_lobe (≤ 3).
    Under uniform light (s = 1, m_light = m_lobe) this is the table itself (a constant map:
    within ΔE2000 0.05 of it, the prefilter's texel quadrature against the closed form); under a
    point light (s = 0) every component sits at the light's own half vector, the exact colour.
    In between the table keeps the lobe's skewed shape and per-component C*, φ₂*, which one
    Gaussian (Kneiphof) cannot;
  * ``"kneiphof"`` — eq. 20–29 (:func:`~torchirid.ibl.thin_film_xyz_filtered`) with
    :math:`ω_o` = the view direction and the light mean μ_ωi and covariance Σ_ωi read from the
    nine prefiltered moment channels at :math:`ω_r` (§4.2, "computed from the prefiltered moments at
    runtime");
  * ``"belcour_barla"`` (the paper's "original") — eq. 4 at the ideal reflection,
    cos θ₁ = ⟨n, ω_o⟩ (:func:`~torchirid.ibl.thin_film_xyz_fourier`).

**The reference** (``method="reference"``, given the map itself instead of a prefiltered one):
eq. 11 summed over every texel t of the map, with no split and no moment,

.. math:: L_o = \sum_t f_r(ω_t, ω_o)\,⟨n, ω_t⟩^+\,Ω_t\; L_t,\qquad
          f_r = \frac{D(h)\,G_1(ω_t)\,G_1(ω_o)}{4⟨n,ω_t⟩⟨n,ω_o⟩}\;\mathrm{RGB}[R](⟨h, ω_t⟩),

the library's GGX microfacet BRDF (:func:`~torchirid.microfacet.microfacet_brdf`: separable
Smith G, the G of the DFG and mixture tables) with the film's exact reflectance at the half
vector: :func:`~torchirid.optics.thin_film_reflectance` at ``REFERENCE_NODES`` = 129 values of
cos θd uniform in [0, 1] per pixel, integrated to XYZ under D65 on 360–830 nm at 5 nm
(:func:`~torchirid.color.spectrum_to_xyz`'s weights), taken to linear sRGB and interpolated
linearly in cos θd (within ΔE2000 0.015 of 513 nodes on 1 nm for the gallery's soap film,
d ≤ 800 nm). Each texel is a constant radiance L_t over its exact solid angle Ω_t (the
prefilter's quadrature); black texels are skipped. Colour rule: **the RGB product** — the
film's linear-sRGB reflectance (the spectral integral, white = (1, 1, 1)) times the texel's
RGB, channel by channel, what the split-sum methods assume and what an RGB renderer computes
(Mitsuba's ``*_rgb`` variants with a BSDF returning that RGB); a spectral renderer that
upsamples the map's RGB differs from it by the upsampling. Pixels × texels work, block by
block over pixels (:mod:`torchirid._chunks`); differentiable w.r.t. the map, the geometry and
the film (≈ 2 s for the gallery's 1800 pixels × 2048 texels on 2 cores).

**Orientation** (for comparing with a renderer). Directions are in the map's frame of
:mod:`torchirid.ibl.prefilter`: **+z up**; map row 0 = zenith (θ from +z, texel centres
(i + ½)π/H); column j at azimuth φ = (j + ½)2π/W **from +x towards +y** (φ = 0 is +x;
counter-clockwise seen from above, a right-handed frame). Mitsuba 3's ``envmap`` emitter
reads its bitmap with **+y up** and u = atan2(x, −z)/2π (u = 0 is −z, u = ¼ is +x: clockwise
seen from above), so the same array in Mitsuba is the *mirror image* of this frame. To render
the same scene in Mitsuba with the scene (normals, camera, ``view``) in torchirid's z-up
coordinates, give the emitter the map with its **columns reversed** and the rotation
``to_world`` = [[0, 0, −1], [−1, 0, 0], [0, 1, 0]]:
``{"type": "envmap", "bitmap": mi.Bitmap(env.flip(1).numpy()), "to_world":
mi.ScalarTransform4f([[0, 0, -1, 0], [-1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 0, 1]])}``
(checked against ``mitsuba.load_dict(...).eval`` in tests/ibl/test_shading.py). Equivalently, in
Mitsuba's own y-up world with the reversed map and no ``to_world``, a torchirid vector (x, y, z)
is Mitsuba's (−y, z, −x). Mitsuba's ``envmap`` interpolates its bitmap bilinearly where this
reference holds each texel constant: compare on maps upsampled by repetition (each texel
k × k times) or smooth maps, or expect differences of the order of one texel's blur. So set up,
a converged Mitsuba render (``llvm_ad_rgb``, the ``torchirid_thin_film`` plugin, an orthographic
sensor on the same image plane, the reference averaged over each pixel's footprint) agrees with
the reference within the render's own noise on the gallery's sphere under the three generated
maps (ΔE2000 mean ≤ 0.19, the summed radiance within 0.13 % per channel:
``benchmarks/ibl_mitsuba_check.py``, docs/performance.md; tests/mitsuba/test_mitsuba_environment.py).

The environment is linear RGB (sRGB primaries, as the map), so the reflectance term's XYZ
(white Y = 1 under D65) is taken to linear sRGB (:func:`~torchirid.color.xyz_to_linear_srgb`,
the D65 white → (1, 1, 1)) and multiplies :math:`\bar L` channel by channel — the renderer's
RGB product. ``output="xyz"`` converts that product back to XYZ.

Lookup. The radiance and moment maps are interpolated bilinearly on the equirectangular output
grid (periodic in φ, clamped at the texel centres nearest the poles) and linearly in α between
the prefiltered roughness levels (α must lie within them). Moments are interpolated before the
covariance is formed (a mixture's moments are the mixture of its moments), so |μ| ≤ 1 holds.

Accuracy (tests/ibl/test_shading.py). Under a constant environment :math:`L_i ≡ c` the
prefiltered radiance is c exactly, and the result differs from the converged ground truth
:math:`c\,A\,\mathrm{XYZ}_{\text{uniform}}` (:func:`~torchirid.ibl.thin_film_xyz_uniform` times
its albedo) by the split-sum moments (an isotropic lobe about ω_r instead of the true p_R) plus
eq. 20–29's own approximation. At d = 600 nm, η₂ = 1.3, base 2 + 0.5i, θo ∈ {0°, 30°,
60°, 75°} × α ∈ {0.1, 0.3, 0.5} (α = 0.3 interpolated between levels 0.25 and 0.5; a 32 × 64
map prefiltered to 16 × 32) the test holds it within ΔE2000 11 (max) and 4.5 (mean), closer
on average than eq. 20–29 fed the exact moments (:func:`~torchirid.ibl.uniform_light_moments`)
and than ``method="belcour_barla"`` (the measured values: the test's docstring). (That the
split-sum moments beat the exact ones here is a cancellation of the two approximations at
grazing, not a general property.) The albedo from the shipped 64² DFG table agrees with the
converged lobe quadrature to 1e-3 (tested).
"""

from __future__ import annotations

import math

import torch

from .. import _checks, _chunks
from .._quadrature import gauss_legendre01
from ..color.convert import linear_srgb_to_xyz, xyz_to_linear_srgb, xyz_weights_kernel
from ..microfacet.ggx import ggx_d_kernel, smith_g1_kernel
from ..optics.thin_film import thin_film_reflectance
from .dfg import shipped_dfg_lut
from .filtered import _ARGS, thin_film_xyz_filtered
from .fitted import fitted_xyz_in_light
from .fourier import thin_film_xyz_fourier
from .prefilter import PrefilteredEnvironment, equirect_directions, light_moments_to_mean_cov

__all__ = ["shade_thin_film_environment", "SHADING_METHODS"]

#: Methods of :func:`shade_thin_film_environment`: the split sum with the fitted light mixture
#: moved into the environment's light (default), Kneiphof's eq. 20–29 with the prefiltered moments,
#: Belcour–Barla's eq. 4 at the ideal reflection direction; and the texel-sum reference.
SHADING_METHODS = ("fitted", "kneiphof", "belcour_barla", "reference")
#: the methods a renderer runs (the split sum over a prefiltered map); "reference" sums texels
SPLIT_SUM_METHODS = ("fitted", "kneiphof", "belcour_barla")
#: the reference's film table: nodes uniform in cos θd, and its wavelength grid (nm: first, last, step)
REFERENCE_NODES = 129
REFERENCE_WAVELENGTH = (360.0, 830.0, 5.0)
#: Gauss–Legendre nodes of the GGX lobe's closed-form light moments (:func:`_lobe_moments`)
_LOBE_NODES = 128
#: Colour space of the result.
SHADING_OUTPUTS = ("rgb", "xyz")


def _safe_norm2(x, y):
    """√(x² + y²) with a zero (not NaN) gradient at the origin (the poles of the map); NaN propagates."""
    return _checks.safe_sqrt(x * x + y * y)


def _lookup(pre: PrefilteredEnvironment, r: torch.Tensor, alpha: torch.Tensor, extra=None) -> torch.Tensor:
    """Trilinear read of (radiance, moments) ``(*, 12)`` at direction r ``(*, 3)`` (unit) and α ``(*)``;
    ``extra`` ``(A, H, W, C)``: more channels on the same grid, read alongside (``(*, 12 + C)``)."""
    vals = torch.cat([pre.radiance, pre.moments] + ([] if extra is None else [extra]), -1).to(r.dtype)
    order = torch.argsort(pre.alphas)
    vals, levels = vals[order], pre.alphas[order].to(r.dtype)
    A, H, W = vals.shape[:3]
    theta = torch.atan2(_safe_norm2(r[..., 0], r[..., 1]), r[..., 2])  # [0, π]
    phi = torch.remainder(torch.atan2(r[..., 1], r[..., 0]), 2.0 * math.pi)
    # rows: texel centres at (i + ½)π/H; beyond the first/last centre the edge row is used
    x = (theta * (H / math.pi) - 0.5).clamp(0.0, H - 1.0)
    # (indices of NaN directions: any valid texel; their NaN weights make the result NaN)
    i0 = x.detach().nan_to_num(0.0).floor().clamp(max=max(H - 2, 0)).long()
    ti = x - i0
    i1 = (i0 + 1).clamp(max=H - 1)
    # columns: periodic in φ
    y = phi * (W / (2.0 * math.pi)) - 0.5
    j0f = y.detach().nan_to_num(0.0).floor()
    tj = y - j0f
    j0 = torch.remainder(j0f.long(), W)
    j1 = torch.remainder(j0 + 1, W)
    # roughness levels: linear in α between the sorted levels
    if A == 1:
        k0 = torch.zeros_like(i0)
        tk = torch.zeros_like(alpha)
    else:
        k0 = (torch.searchsorted(levels, alpha.detach().contiguous(), right=True) - 1).clamp(0, A - 2)
        tk = (alpha - levels[k0]) / (levels[k0 + 1] - levels[k0])
    k1 = (k0 + 1).clamp(max=A - 1)
    k0, k1, i0, i1, j0, j1 = torch.broadcast_tensors(k0, k1, i0, i1, j0, j1)
    ti, tj, tk = (t[..., None] for t in (ti, tj, tk))

    def plane(k):
        top = torch.lerp(vals[k, i0, j0], vals[k, i0, j1], tj)
        bottom = torch.lerp(vals[k, i1, j0], vals[k, i1, j1], tj)
        return torch.lerp(top, bottom, ti)

    return torch.lerp(plane(k0), plane(k1), tk)


def _lobe_moments(alphas: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """``(a, b)`` ``(A,)``: E[⟨l, R⟩] and E[⟨l, R⟩²] of the prefilter's lobe weight D(h)⟨R, l⟩⁺/4
    under uniform light (module docstring of :mod:`torchirid.ibl.prefilter`), in closed form.

    Over the half vector h (⟨R, h⟩ = c, ⟨l, R⟩ = 2c² − 1) the weight is D(c)·c·(2c² − 1)⁺ per unit
    solid angle of h: with h drawn from GGX's D·cos density (tan²θh = α²u/(1 − u), u uniform) it
    is (2c² − 1)⁺ per unit u, zero beyond u = 1/(1 + α²). Gauss–Legendre in u on [0, 1/(1 + α²)]
    (smooth there). The texel sums of :func:`~torchirid.ibl.prefilter_environment` on a constant map
    agree to < 1e-3 in a and in the spread for α ≥ 0.05 on 32 × 64 maps.
    """
    x, wq = gauss_legendre01(_LOBE_NODES, dtype=alphas.dtype, device=alphas.device)
    a2 = (alphas * alphas)[:, None]
    u = x / (1.0 + a2)
    c2 = (1.0 - u) / (1.0 - u + a2 * u)
    g = (2.0 * c2 - 1.0).clamp_min(0.0) * wq
    total = g.sum(-1)
    return (g * (2.0 * c2 - 1.0)).sum(-1) / total, (g * (2.0 * c2 - 1.0) ** 2).sum(-1) / total


def _lobe_moment_maps(pre: PrefilteredEnvironment, dtype, device) -> torch.Tensor:
    """The nine moment channels of uniform light on the prefiltered grid, ``(A, Ho, Wo, 9)``:
    E[l] = a R, E[l lᵀ] = b R Rᵀ + ((1 − b)/2)(I − R Rᵀ) (read with the same interpolation as the map's)."""
    R = pre.directions.to(dtype=dtype, device=device)
    a, b = _lobe_moments(pre.alphas.to(dtype=dtype, device=device))
    a, b = a[:, None, None], b[:, None, None]
    e = 0.5 * (1.0 - b)
    x, y, z = R.unbind(-1)
    second = [(b - e) * p * q + (e if k < 3 else 0.0)
              for k, (p, q) in enumerate(((x, x), (y, y), (z, z), (x, y), (y, z), (z, x)))]
    return torch.cat([a[..., None] * R, torch.stack(second, -1)], -1)


def _cos_theta1_stats(moments: torch.Tensor, view: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Mean and spread of cos θ1 = ⟨h, l⟩ = √((1 + ⟨l, ω_o⟩)/2) from nine moment channels (delta method)."""
    mean, cov = light_moments_to_mean_cov(moments)
    m = (mean * view).sum(-1)
    var = torch.einsum("...i,...ij,...j->...", view, cov, view)
    c = _checks.safe_sqrt(0.5 * (1.0 + m))
    safe = torch.where(c > 0, c, torch.ones_like(c))
    return c, torch.where(c > 0, _checks.safe_sqrt(var) / (4.0 * safe), torch.zeros_like(c))


def _reference_block(n, v, a, nf, d, ns, n0, *, light, weight, radiance, wavelength, xyz_weights, polarization):
    """The texel-sum reference on one block of pixels: ``(*, 3)`` linear sRGB (module docstring)."""
    shape = _checks.broadcast_shapes(n.shape[:-1], v.shape[:-1], a.shape, nf.shape, d.shape, ns.shape, n0.shape)
    n, v = n.expand(*shape, 3).reshape(-1, 3), v.expand(*shape, 3).reshape(-1, 3)
    a, nf, d, ns, n0 = (t.expand(shape).reshape(-1, 1) for t in (a, nf, d, ns, n0))
    dtype = n.dtype
    # the film's linear sRGB reflectance on REFERENCE_NODES values of cos θd, per pixel: (P, N, 3)
    nodes = torch.linspace(0.0, 1.0, REFERENCE_NODES, dtype=dtype, device=n.device)
    spectra = _reflectance(wavelength, nodes[None, :, None], nf[..., None], d[..., None], ns[..., None],
                           n_incident=n0[..., None], polarization=polarization)
    film = xyz_to_linear_srgb(spectra @ xyz_weights)
    cos_i = n @ light.T  # (P, T)
    cos_o = (n * v).sum(-1, keepdim=True)
    two = (2.0 + 2.0 * (v @ light.T)).clamp_min(0.0)  # |l + v|²
    norm = torch.sqrt(two)
    cos_d = (0.5 * norm).clamp(0.0, 1.0)  # ⟨h, l⟩
    cos_h = (cos_i + cos_o) / torch.where(norm > 0, norm, torch.ones_like(norm))
    # f·⟨n, l⟩·dω = D G1(l) G1(v) / (4⟨n, v⟩)·dω (separable Smith G, the library's microfacet BRDF)
    f = ggx_d_kernel(cos_h, a) * smith_g1_kernel(cos_i.clamp_min(0.0), a) * smith_g1_kernel(cos_o, a) / (4.0 * cos_o)
    f = torch.where((cos_i <= 0) | (norm <= 0), torch.zeros_like(f), f) * weight  # (NaN propagates)
    # linear interpolation of the film's table at cos θd (indices of NaN entries: any node)
    u = cos_d * (REFERENCE_NODES - 1)
    i = u.detach().nan_to_num(0.0).floor().clamp(0, REFERENCE_NODES - 2).long()
    t = (u - i)[..., None]
    idx = i + REFERENCE_NODES * torch.arange(n.shape[0], device=n.device)[:, None]
    flat = film.reshape(-1, 3)
    rgb = torch.lerp(flat[idx], flat[idx + 1], t)  # (P, T, 3)
    out = torch.einsum("pt,ptc,tc->pc", f, rgb, radiance)
    return out.reshape(*shape, 3)


_reflectance = thin_film_reflectance.__wrapped__.__wrapped__  # (below the small-call and check decorators)


def _reference(env, n, v, a, nf, d, ns, n0, *, observer, polarization):
    """Eq. 11 summed over every texel of ``env`` for each pixel, in linear sRGB (module docstring)."""
    dtype, device = n.dtype, n.device
    h, w = env.shape[:2]
    light, omega = equirect_directions(h, w, dtype=dtype, device=device)
    light, omega, radiance = light.reshape(-1, 3), omega.reshape(-1), env.reshape(-1, 3)
    lit = ~(radiance == 0).all(-1)  # black texels add nothing (NaN ones are kept: they propagate)
    light, omega, radiance = light[lit], omega[lit], radiance[lit]
    first, last, step = REFERENCE_WAVELENGTH
    wavelength = torch.arange(first, last + 0.5 * step, step, dtype=dtype, device=device)
    weights = xyz_weights_kernel(wavelength, observer, "D65")
    shape = _checks.broadcast_shapes(n.shape[:-1], v.shape[:-1], a.shape, nf.shape, d.shape, ns.shape, n0.shape)
    return _chunks.evaluate(_reference_block, (n, v, a, nf, d, ns, n0), shape, core=(1, 1, 0, 0, 0, 0, 0),
                            out_core=1, width=8 * max(light.shape[0], 1), grad_inputs=(env,), light=light,
                            weight=omega, radiance=radiance, wavelength=wavelength, xyz_weights=weights,
                            polarization=polarization)


def _as_source(v, name, dtype, device):
    return v if isinstance(v, PrefilteredEnvironment) else _checks.as_real(v, name, dtype, device)


def _check_source(v, name):
    if not isinstance(v, PrefilteredEnvironment) and (v.ndim != 3 or v.shape[-1] != 3 or v.shape[0] < 1
                                                        or v.shape[1] < 1):
        raise ValueError(f"{name} must be a PrefilteredEnvironment (from prefilter_environment) or, for "
                         f"method='reference', an (H, W, 3) environment map; got shape {tuple(v.shape)}")


#: a PrefilteredEnvironment, or an equirectangular map (H, W, 3) for the texel-sum reference
SOURCE = _checks.Arg(_as_source, _check_source)


@_checks.arguments(prefiltered=SOURCE,
                   method=_checks.choice(SHADING_METHODS), output=_checks.choice(SHADING_OUTPUTS),
                   normal=_checks.VECTORS, view=_checks.VECTORS, alpha=_checks.REAL,
                   **{k: a for k, a in _ARGS.items() if k != "illuminant"})
def shade_thin_film_environment(prefiltered, normal, view, alpha, n_film, thickness,
                                n_substrate, *, n_incident=1.0, method: str = "fitted", terms: int = 4,
                                observer: str = "CIE 1931 2", polarization: str = "unpolarized",
                                sensitivity: str = "lut", output: str = "rgb", dfg=None) -> torch.Tensor:
    r"""Radiance reflected by a rough thin-film surface under an environment (Kneiphof eq. 12, or the reference).

    :math:`L_o = A(⟨n, ω_o⟩, α)\;\bar L(ω_r, α) ⊙ \mathrm{RGB}[\text{reflectance term}]`, ω_r =
    reflect(ω_o, n): the split-sum albedo (DFG at F ≡ 1) × the prefiltered radiance × the
    thin-film colour of the light the lobe gathers (module docstring); ``method="reference"``
    instead sums eq. 11 over every texel of the map with the exact BRDF. All directions are in
    the environment map's world frame (equirectangular convention of
    :mod:`torchirid.ibl.prefilter`: +z up, φ from +x towards +y; Mitsuba's frame: module docstring).

    Args:
        prefiltered: a :class:`~torchirid.ibl.PrefilteredEnvironment` (A ≥ 1 roughness levels);
            for ``method="reference"`` the environment map itself, ``(H, W, 3)`` linear RGB (≥ 0).
        normal: surface normal n, ``(*, 3)`` (normalised here; non-zero).
        view: direction towards the viewer ω_o, ``(*, 3)`` (normalised here; ⟨n, ω_o⟩ > 0).
        alpha: GGX roughness, ``(*)``, within the prefiltered levels [min α, max α] and ≤ 1
            (the DFG table's range); interpolated linearly between levels. The reference takes
            any α > 0.
        n_film: real film index η₂ ≥ ``n_incident`` (the reference: any real index); thickness: film thickness d in nm (≥ 0);
            n_substrate: base η₃ + iκ₃ (non-dispersive) — each ``(*)``.
        n_incident: real outer index η₁ (default 1).
        method: a key of :data:`SHADING_METHODS`:

            * ``"fitted"`` (default): the fitted light-mixture table
              (:func:`~torchirid.ibl.thin_film_xyz_fitted`) moved into the light the lobe
              gathers, read from the prefiltered moments — the most accurate of the three
              split-sum methods under uniform light and under each measured environment
              (module docstring; docs/performance.md, "Thin-film IBL under environment maps");
            * ``"kneiphof"``: eq. 20–29 with the prefiltered moments;
            * ``"belcour_barla"``: eq. 4 at the ideal reflection, cos θ₁ = ⟨n, ω_o⟩;
            * ``"reference"``: the texel sum (slow: pixels × texels; module docstring).
        terms: Fourier terms M ≥ 0 (default 4; the paper's is 2). Not used by the reference.
        observer: colour-matching functions of the reflectance term (illuminant fixed to D65,
            the white of the sRGB primaries the map is in).
        polarization: ``"unpolarized"`` (default), ``"s"`` or ``"p"``.
        sensitivity: ``"lut"`` (default) or ``"exact"`` — how Ŝ(μ, σ²) / Ŝ(D) is evaluated (the
            shipped tables, or quadrature). Not used by the reference.
        output: ``"rgb"`` (default: linear sRGB radiance, the map's units) or ``"xyz"``.
        dfg: split-sum :class:`~torchirid.lut.LUT` from :func:`~torchirid.ibl.dfg_lut`; default
            :func:`~torchirid.ibl.shipped_dfg_lut`. Not used by the reference.

    Returns:
        ``(*, 3)`` radiance in the map's units (``(*)`` = broadcast of the geometry and film
        inputs), real dtype of the inputs, differentiable w.r.t. the directions, α, the film
        parameters and the maps.

    Example:
        >>> import torch
        >>> from torchirid.ibl import prefilter_environment
        >>> env = torch.ones(16, 32, 3, dtype=torch.float64)
        >>> pre = prefilter_environment(env, [0.2, 0.4], resolution=8)
        >>> n = torch.tensor([0.0, 0.0, 1.0], dtype=torch.float64)
        >>> v = torch.tensor([0.6, 0.0, 0.8], dtype=torch.float64)
        >>> rgb = shade_thin_film_environment(pre, n, v, 0.3, 1.3, 600.0, complex(2.0, 0.5))
        >>> [round(c, 3) for c in rgb.tolist()]
        [0.045, 0.06, 0.086]
        >>> ref = shade_thin_film_environment(env, n, v, 0.3, 1.3, 600.0, complex(2.0, 0.5), method="reference")
        >>> [round(c, 3) for c in ref.tolist()]  # the texel sum over the map itself
        [0.045, 0.061, 0.086]
    """
    n, v, a = normal, view, alpha
    dtype, device = n.dtype, n.device
    reference = method == "reference"
    if reference != (not isinstance(prefiltered, PrefilteredEnvironment)):
        raise ValueError("method='reference' sums the texels of the environment map: pass the (H, W, 3) map, "
                         "not a PrefilteredEnvironment" if reference else
                         f"method={method!r} reads a prefiltered map: pass prefilter_environment(env, alphas), "
                         "not the (H, W, 3) map (or use method='reference')")
    with torch.no_grad():
        nn_, vn = torch.linalg.vector_norm(n, dim=-1), torch.linalg.vector_norm(v, dim=-1)
        if bool((nn_ <= 0).any()):
            raise ValueError("normal must be a non-zero vector")
        if bool((vn <= 0).any()):
            raise ValueError("view must be a non-zero vector (towards the viewer)")
        if reference:
            if bool((prefiltered < 0).any()):
                raise ValueError("prefiltered must be >= 0 (the environment map's radiance)")
            if bool((a <= 0).any()):
                raise ValueError("alpha must be > 0 (GGX roughness)")
        else:
            levels = prefiltered.alphas.to(dtype=dtype, device=device)
            tol = 1e-6 * float(levels.max())  # rounding of α read back from a LUT / float32
            lo, hi = float(levels.min()), float(levels.max())
            if bool(((a < lo - tol) | (a > hi + tol)).any()):
                raise ValueError(f"alpha must lie within the prefiltered roughness levels [{lo:g}, {hi:g}]")
            if bool(((a <= 0) | (a > 1)).any()):
                raise ValueError("alpha must be in (0, 1] (GGX roughness; the DFG table's range)")
    n = n / torch.linalg.vector_norm(n, dim=-1, keepdim=True)
    v = v / torch.linalg.vector_norm(v, dim=-1, keepdim=True)
    cos_o = (n * v).sum(-1)
    with torch.no_grad():
        if bool((cos_o <= 0).any()):
            raise ValueError("view must be in the hemisphere of normal (<normal, view> > 0); mask "
                             "back-facing points before shading")
    if reference:
        rgb = _reference(prefiltered.to(dtype=dtype, device=device), n, v, a, n_film, thickness, n_substrate,
                         n_incident, observer=observer, polarization=polarization)
        return linear_srgb_to_xyz(rgb) if output == "xyz" else rgb
    cos_o = cos_o.clamp(max=1.0)
    r = 2.0 * cos_o[..., None] * n - v  # ω_r = reflect(ω_o, n), unit
    shape = _checks.broadcast_shapes(r.shape[:-1], a.shape)
    r, a_ = r.expand(*shape, 3), a.expand(shape)
    lobe = _lobe_moment_maps(prefiltered, dtype, device) if method == "fitted" else None
    looked = _lookup(prefiltered, r, a_.clamp(lo, hi), lobe)
    radiance, moments = looked[..., :3], looked[..., 3:12]
    # eq. 12, first factor: the split-sum albedo at F ≡ 1 (scale + bias)
    table = shipped_dfg_lut(dtype=dtype, device=device) if dfg is None else dfg.to(dtype=dtype, device=device)
    ab = table(cos_theta_o=cos_o.expand(shape), alpha=a_)
    albedo = ab[..., 0] + ab[..., 1]
    # eq. 12, third factor
    kw = dict(n_incident=n_incident, terms=terms, observer=observer, illuminant="D65", polarization=polarization,
              sensitivity=sensitivity)
    # (the colour functions' bodies: their arguments are checked above, the derived ones by construction)
    if method == "kneiphof":
        mean, cov = light_moments_to_mean_cov(moments)
        xyz = thin_film_xyz_filtered.__wrapped__(v, mean, cov, n_film, thickness, n_substrate, **kw)
    elif method == "fitted":
        vv = v.expand(*shape, 3)
        m_light, sd_light = _cos_theta1_stats(moments, vv)
        m_lobe, sd_lobe = _cos_theta1_stats(looked[..., 12:], vv)
        xyz = fitted_xyz_in_light(cos_o.expand(shape), a_, n_film, thickness, n_substrate, m_light, sd_light,
                                  m_lobe, sd_lobe, **kw)
    else:
        xyz = thin_film_xyz_fourier.__wrapped__(cos_o, n_film, thickness, n_substrate, **kw)
    rgb = xyz_to_linear_srgb(xyz) * radiance * albedo[..., None]
    if output == "xyz":
        return linear_srgb_to_xyz(rgb)
    return rgb
