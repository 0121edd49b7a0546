"""
Hirayama's coated metal spheres, rendered in Mitsuba 3
======================================================

Hirayama et al.'s Fig. 8 stacks (2000; :func:`torchirid.presets.hirayama_stacks`): silicon and
aluminium spheres coated with dielectric (n = 1.4, 1000 nm) | silver or gold (5 nm) |
dielectric (1000 nm), as the ``torchirid_multilayer`` BSDF of :func:`torchirid.mitsuba.register`
(``materials`` and ``thicknesses`` from the preset's :class:`~torchirid.optics.FilmStack`,
``n_substrate`` its substrate; the metals and silicon are the library's tabulated indices,
interpolated by the plugin on a 1 nm table). Twelve spheres, each rendered alone under the library's
synthetic sky (:func:`torchirid.ibl.synthetic_environment`); each row a stack, the columns:
the bare substrate, the coated sphere smooth, and coated on the paper's two rough surfaces.

The paper's rough surfaces (σ₀ = 25 and 50 nm, τ = 300 nm) are a Gaussian height field under
the films, in He and Torrance's wave optics: a coherent specular part that survives at these
σ₀ (e^{-g} ≈ 0.7 at 25 nm and 550 nm, normal incidence) plus a directional-diffuse lobe. The
plugin's rough geometry is a GGX microfacet surface (geometric optics: the film's reflectance at
each microfacet, no coherent part), so each σ₀ is mapped to the slope statistics of the same
height field: a Gaussian autocorrelation of length τ has the per-axis rms slope √2 σ₀/τ, i.e.
the Beckmann roughness α = 2σ₀/τ (0.17 and 0.33), used as GGX's α. The renders are therefore the
microfacet counterpart of Hirayama's spheres, blurrier than his coherent highlights
(``plot_hirayama_spheres.py`` shades his eq. 8–17 themselves). The films' interference colours
— the 5 nm metal makes the two 1000 nm dielectrics a Fabry–Pérot pair with fringes every
~50–100 nm of wavelength — survive the roughness, as in the paper.

Rendered with Mitsuba's ``path`` integrator in ``llvm_ad_spectral`` (``scalar_spectral`` at a
small size where Dr.Jit has no LLVM backend).
"""

import gc
import os
import time

import matplotlib.pyplot as plt
import mitsuba as mi
import torch

import torchirid.mitsuba
from torchirid.color import linear_srgb_to_srgb
from torchirid.mitsuba.scenes import default_variant, render, sphere_scene
from torchirid.presets import hirayama_stacks

tiny = os.environ.get("TORCHIRID_GALLERY_TINY") == "1"
variant = default_variant()   # llvm_ad_spectral where Dr.Jit has its LLVM backend (libLLVM 19), else scalar_spectral
llvm = variant.startswith("llvm")
torchirid.mitsuba.register(variant)
size = 12 if tiny else (72 if llvm else 16)      # pixels per sphere image
spp = 4 if tiny else (64 if llvm else 4)
tau = 300.0
columns = {"bare": None, "coated, smooth": 0.0, "σ₀ = 25 nm": 25.0, "σ₀ = 50 nm": 50.0}   # σ₀ (nm)
rows = {"Si | A | Ag | A (a–c)": "fig8_abc_silicon_silver",
        "Al | A | Ag | A (d–f)": "fig8_def_aluminum_silver",
        "Al | A | Au | A (g–i)": "fig8_ghi_aluminum_gold"}


def bsdf(stack, sigma):
    """The plugin's parameters of a FilmStack: its layers (or none: the bare substrate, a
    0 nm layer of air) and GGX α = 2σ₀/τ for a rough surface."""
    layers = stack.layers if sigma is not None else (("air", 0.0),)
    spec = {"type": "torchirid_multilayer", "materials": ",".join(m for m, _ in layers),   # strings: Mitsuba's
            "thicknesses": ",".join(f"{d:g}" for _, d in layers), "n_substrate": stack.n_substrate}   # dicts take no lists
    if sigma:
        spec["alpha"] = 2.0 * sigma / tau
    return spec


stacks = hirayama_stacks()
fig, axes = plt.subplots(3, 4, figsize=(8.4, 6.6), layout="constrained")
start = time.perf_counter()
for i, (label, key) in enumerate(rows.items()):
    for j, (title, sigma) in enumerate(columns.items()):
        scene = sphere_scene(bsdf(stacks[key], sigma), size=size, spp=spp, integrator="path", max_depth=3,
                             elevation_deg=20.0, azimuth_deg=20.0)
        image = render(scene, spp=spp, seed=1)
        del scene
        gc.collect()  # a symbolic call traces every live BSDF: keep only this scene's alive
        ax = axes[i, j]
        ax.imshow(linear_srgb_to_srgb(0.75 * torch.from_numpy(image).double()).clamp(0, 1).numpy())
        ax.set_xticks([])
        ax.set_yticks([])
        if i == 0:
            ax.set_title(title if sigma is None or sigma == 0 else f"{title}: α = {2 * sigma / tau:.2f}", fontsize=10)
        if j == 0:
            ax.set_ylabel(label, fontsize=9)
print(f"{mi.variant()}: 12 spheres of {size}×{size} pixels, {spp} spp in {time.perf_counter() - start:.1f} s")
fig.suptitle(f"Hirayama et al. 2000, Fig. 8 stacks (A: n = 1.4, 1000 nm; metal 5 nm); GGX α = 2σ₀/τ, "
             f"τ = {tau:g} nm", fontsize=10)
plt.show()
