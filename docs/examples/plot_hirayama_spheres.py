"""
Spheres coated with multilayer films, smooth and rough (Hirayama et al. 2000, Fig. 8)
======================================================================================

Hirayama et al.'s Fig. 8: silicon and aluminium spheres coated with dielectric (n = 1.4,
1000 nm) | silver or gold (5 nm) | dielectric (1000 nm) — complex indices from the tabulated
metals — beside the bare spheres, on an ideally smooth surface (σ₀ = 0) and on rough ones
(σ₀ = 25, 50 nm, τ = 300 nm). The stacks are :func:`torchirid.presets.hirayama_stacks`
(:class:`torchirid.optics.FilmStack`; indices by ``torchirid.optics.film_stack.stack_indices()``). Each pixel
of an orthographic sphere is shaded spectrally (380–780 nm) in one batched call per stack:
the smooth reflectance k_r (:func:`torchirid.optics.film_reflectance`, eq. 5), the coherent specular
k_r of the rough surface (:func:`torchirid.optics.rough_multilayer_reflectance`, eq. 9–10) and its
directional-diffuse BRDF k_d (:func:`torchirid.optics.rough_multilayer_diffuse`, eq. 11–17), as in
eq. 8: ``P(λ) = k_r (a + E_lamp) + π k_d cos θ_l`` under a distant light, a uniform
environment a = 0.35 and the light's own mirror image (a disk of 3°). The light is D65 here
(Hirayama's was a fluorescent lamp; ``torchirid render-sphere`` renders with one), so the
spectra go to sRGB with :func:`torchirid.spectrum_to_xyz` and :func:`torchirid.xyz_to_srgb`,
and each panel is titled with the mean CIELAB chroma C*ab of the lit pixels
(:func:`torchirid.xyz_to_lab`), coated | bare: the films' interference colours survive, and
show more clearly, on the rough spheres.
"""

import math
import os

import matplotlib.pyplot as plt
import torch

import torchirid
from torchirid.optics import FilmStack
from torchirid.presets import hirayama_stacks
from torchirid.optics.film_stack import stack_indices

tiny = os.environ.get("TORCHIRID_GALLERY_TINY") == "1"
f32 = torch.float32                        # float32 is ample for colour and twice as fast
size = 20 if tiny else 64                  # sphere image side in pixels
wavelength = torch.arange(380.0, 781.0, 40.0 if tiny else 10.0, dtype=f32)
sigmas, tau = [0.0, 25.0, 50.0], 300.0     # rms roughness σ₀ and autocorrelation length τ (nm)
ambient, lamp_radius = 0.35, math.radians(3.0)

# per-pixel geometry of an orthographic unit sphere viewed along -z; the silhouette is
# antialiased by the disc's coverage of each pixel
c = (torch.arange(size, dtype=f32) + 0.5) / size * 2 - 1
y, x = torch.meshgrid(-c, c, indexing="ij")
r = torch.sqrt(x * x + y * y)
coverage = ((1 - r) * size / 2 + 0.5).clamp(0, 1)
drawn = coverage > 0
scale = 1 / r[drawn].clamp(min=1)                              # rim pixels: the normal at the rim
nx, ny = x[drawn] * scale, y[drawn] * scale
normal = torch.stack([nx, ny, torch.sqrt((1 - nx * nx - ny * ny).clamp(min=0))], -1)   # (P, 3)
light = torch.tensor([-0.45, 0.55, 0.70], dtype=f32)
light = light / light.norm()
view = torch.tensor([0.0, 0.0, 1.0], dtype=f32)
cos_v, cos_l = normal[:, 2], normal @ light
light_t, view_t = light - cos_l[:, None] * normal, view - cos_v[:, None] * normal      # tangent parts
cos_phi = ((light_t * view_t).sum(-1) / (light_t.norm(dim=-1) * view_t.norm(dim=-1)).clamp(min=1e-12)).clamp(-1, 1)
mirror = 2 * cos_v[:, None] * normal - view
lamp = ((mirror @ light) >= math.cos(lamp_radius)).to(f32) / math.sin(lamp_radius) ** 2   # same irradiance
lit = (cos_l > 0) & (lamp == 0) & (r[drawn] < 1)              # the pixels of the chroma statistics
cv, cl, cp = cos_v[:, None], cos_l.clamp(0, 1)[:, None], cos_phi[:, None]           # (P, 1) against (W,)
rough = torch.tensor(sigmas[1:], dtype=f32)[:, None, None]                          # (S, 1, 1)


def shade(stack):
    """sRGB (σ, H, W, 3) and mean chroma (σ,) of a sphere of ``stack`` for each σ₀."""
    n, d = stack_indices(stack, wavelength), torch.tensor(stack.thicknesses, dtype=f32)   # (W, L+2), (L,)
    smooth = torchirid.optics.film_reflectance(wavelength, cv, stack)[0]                      # (P, W)
    k_r = torchirid.optics.rough_multilayer_reflectance(wavelength, cv, n, d, rough, tau)     # (S, P, W)
    k_d = torchirid.optics.rough_multilayer_diffuse(wavelength, cl, cv, cp, n, d, rough, tau)
    spectrum = torch.cat([smooth[None], k_r]) * (ambient + lamp[:, None])
    spectrum[1:] += math.pi * k_d * cl                                                 # σ₀ > 0 only
    xyz = torchirid.spectrum_to_xyz(spectrum, wavelength)                              # (σ, P, 3), D65
    lab = torchirid.xyz_to_lab(xyz)
    image = torch.zeros(len(sigmas), size, size, 3)
    image[:, drawn] = torchirid.xyz_to_srgb(xyz).clamp(0, 1) * coverage[drawn][:, None]
    return image, lab[:, lit, 1:].norm(dim=-1).mean(-1)


rows = {"Si, dielectric | Ag | dielectric (a–c)": "fig8_abc_silicon_silver",
        "Al, dielectric | Ag | dielectric (d–f)": "fig8_def_aluminum_silver",
        "Al, dielectric | Au | dielectric (g–i)": "fig8_ghi_aluminum_gold"}
fig, axes = plt.subplots(3, 3, figsize=(9.6, 7.0), facecolor="black")
stacks = hirayama_stacks()
for i, (label, key) in enumerate(rows.items()):
    stack = stacks[key]
    coated, chroma_coated = shade(stack)
    bare, chroma_bare = shade(FilmStack([], stack.n_substrate))
    for j, sigma in enumerate(sigmas):
        ax = axes[i, j]
        ax.imshow(torch.cat([coated[j], bare[j]], 1).numpy())
        ax.set_xticks([size / 2, 3 * size / 2], ["coated", "bare"], color="white", fontsize=8)
        ax.set_yticks([])
        ax.set_title(f"σ₀ = {sigma:g} nm: C*ab {float(chroma_coated[j]):.1f} | {float(chroma_bare[j]):.1f}",
                     color="white", fontsize=9)
        ax.tick_params(length=0)
    axes[i, 0].set_ylabel(label, color="white", fontsize=8)
fig.suptitle(f"Hirayama et al. 2000, Fig. 8: coated | bare spheres, τ = {tau:g} nm, D65 light", color="white")
fig.tight_layout()
plt.show()
