"""
A soap film under an environment map: Belcour–Barla, Kneiphof and the fitted table
==================================================================================

A slightly rough sphere (GGX α = 0.25) coated with a soap film (η₂ = 1.33 on air, the front
face of a bubble) whose thickness grows from 100 nm at the top to 800 nm at the bottom, lit by
an environment map and shaded with Kneiphof et al.'s split sum (eq. 12): the map prefiltered
by :func:`torchirid.ibl.prefilter_environment`, the albedo from
:func:`torchirid.ibl.shipped_dfg_lut`, and three reflectance terms — Belcour–Barla's Fourier
colour at the mirror direction, Kneiphof's filtered colour with the map's light moments, and
torchirid's fitted light-mixture table (:func:`torchirid.ibl.thin_film_xyz_fitted`) moved into
the light the lobe gathers (the default) — :func:`torchirid.ibl.shade_thin_film_environment` with
``method="belcour_barla"``, ``"kneiphof"`` and ``"fitted"``.

There is no HDR photograph in the repository: the map is the library's synthetic sky
(:func:`torchirid.ibl.synthetic_environment`: a blue gradient, a grey ground and a sun), and a
photograph would go through :func:`torchirid.ibl.read_environment`. The reference is the
library's own, ``shade_thin_film_environment(env, ..., method="reference")``: eq. 11 summed over
every texel of the map with the exact BRDF — GGX with the film's spectral reflectance
(:func:`torchirid.thin_film_reflectance`, taken to linear RGB like the map) at each texel's half
vector. The bottom row shows each method's per-pixel CIEDE2000 against it, the panel titles their
means over the sphere. ``benchmarks/ibl_environment.py`` measures the same sphere under a sun and
sky and an indoor map too (docs/performance.md).
"""

import os

import matplotlib.pyplot as plt
import torch

import torchirid
from torchirid.color import delta_e_2000, linear_srgb_to_xyz, xyz_to_lab
from torchirid.ibl import prefilter_environment, shade_thin_film_environment, synthetic_environment

tiny = os.environ.get("TORCHIRID_GALLERY_TINY") == "1"
f64 = torch.float64
size = 12 if tiny else 48                        # sphere image: size × size pixels
map_h = 16 if tiny else 32                       # environment: map_h × 2·map_h texels
alpha, n_film, n_base = 0.25, 1.33, 1.0
# Ŝ, the colour-matching functions' Fourier transform: its exact quadrature costs ~5 ms a colour; the 2-D
# table a shader reads takes ~3 s to build once and agrees with it to < 0.01 ΔE00 here
sensitivity = "exact" if tiny else "lut"

env = synthetic_environment(map_h, 2 * map_h, sun_radius=0.12, sun_radiance=40.0)
pre = prefilter_environment(env, [alpha, 0.5], resolution=(map_h // 2, map_h))

# an orthographic camera on the sun's side, slightly above the horizon: the sun's highlight in the upper half
view = torch.tensor([0.8, 0.48, 0.36], dtype=f64)
view = view / view.norm()
right = torch.linalg.cross(torch.tensor([0.0, 0.0, 1.0], dtype=f64), view)
right = right / right.norm()
up = torch.linalg.cross(view, right)
s = (torch.arange(size, dtype=f64) + 0.5) / size * 2.0 - 1.0
x, y = s[None, :].expand(size, size), -s[:, None].expand(size, size)   # image rows top → bottom
inside = x * x + y * y < 0.97                    # the sphere's pixels (grazing rim left out)
z = torch.sqrt((1.0 - x * x - y * y).clamp_min(0.0))
normal = (x[..., None] * right + y[..., None] * up + z[..., None] * view)[inside]  # (P, 3)
thickness = 100.0 + 700.0 * (1.0 - y[inside]) / 2.0                              # (P,) nm

# the three methods (eq. 12): albedo × prefiltered radiance × RGB of the reflectance term
rgb = {name: shade_thin_film_environment(pre, normal, view, alpha, n_film, thickness, n_base, method=method,
                                        sensitivity=sensitivity)
       for name, method in (("Belcour–Barla", "belcour_barla"), ("Kneiphof", "kneiphof"), ("fitted (default)", "fitted"))}

# the reference: eq. 11 summed over every texel of the map with the exact BRDF (P pixels × T texels)
reference = shade_thin_film_environment(env, normal, view, alpha, n_film, thickness, n_base, method="reference")

exposure = 0.8 / float(linear_srgb_to_xyz(reference)[:, 1].quantile(0.98))
lab_ref = xyz_to_lab(exposure * linear_srgb_to_xyz(reference))


def image(values, background=1.0):  # (P, C) on the sphere → (size, size, C)
    out = torch.full((size, size, values.shape[-1]), background, dtype=f64)
    out[inside] = values
    return out.numpy()


fig, axes = plt.subplots(2, 4, figsize=(11, 5.8), layout="constrained")
axes[1, 0].imshow(torchirid.xyz_to_srgb(0.8 * linear_srgb_to_xyz(env)).clamp(0, 1).numpy(),
                  extent=[0, 360, 180, 0], aspect="auto")
axes[1, 0].set_title("environment (synthetic sky)", fontsize=10)
axes[1, 0].set_xlabel("azimuth φ (°)")
axes[1, 0].set_ylabel("polar angle θ (°)")
for ax, (name, value) in zip(axes[0], {"reference (texel sum)": reference, **rgb}.items()):
    xyz = exposure * linear_srgb_to_xyz(value)
    ax.imshow(image(torchirid.xyz_to_srgb(xyz).clamp(0, 1)))
    ax.axis("off")
    if name in rgb:
        de = delta_e_2000(xyz_to_lab(xyz), lab_ref)
        ax.set_title(f"{name}: mean ΔE00 {float(de.mean()):.1f}", fontsize=10)
        print(f"{name}: mean ΔE2000 {float(de.mean()):.2f}, max {float(de.max()):.1f}")
        panel = axes[1, list(rgb).index(name) + 1]
        im = panel.imshow(image(de[:, None], torch.nan)[..., 0], cmap="magma", vmin=0, vmax=20)
        panel.set_title(f"ΔE00 of {name}", fontsize=10)
        panel.axis("off")
    else:
        ax.set_title(name, fontsize=10)
fig.colorbar(im, ax=axes[1, 1:].tolist(), shrink=0.8, label="CIEDE2000")
fig.suptitle(f"soap film η₂ = {n_film} on air, d = 100 nm (top) → 800 nm (bottom), GGX α = {alpha}", fontsize=11)
plt.show()
