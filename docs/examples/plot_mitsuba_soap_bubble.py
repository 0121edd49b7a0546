"""
A soap bubble under a sky, rendered in Mitsuba 3
================================================

A free-standing soap film (η = 1.33 in air on both sides: ``n_substrate = n_incident = 1``) on
a unit sphere, as the ``torchirid_thin_film`` BSDF of :func:`torchirid.mitsuba.register`:
smooth, so it reflects the film's R in the mirror direction and transmits its T straight
through (a free-standing film does not bend the light), both from outside and from inside the
bubble. Its thickness is a Mitsuba texture of nm values (a ``bitmap`` with ``raw = True``,
bilinearly interpolated): the film drains, from about 200 nm at the top to 900 nm at the
bottom, with swirls of about ±100 nm, so the top shows the gold and magenta of the first orders
and the bottom the pale pinks and greens of high orders.

The light is the library's synthetic sky (:func:`torchirid.ibl.synthetic_environment`: a blue
gradient and a sun) over a darkened, grass-green ground, so that the bubble — seen slightly
from above, against the ground — shows the sky in its reflection; a diffuse sphere behind it
is seen through the film and through its back wall. Rendered with Mitsuba's ``path``
integrator in the ``llvm_ad_spectral`` variant (the film's R and T at each path's four
sampled wavelengths, in Dr.Jit float64 arithmetic), or, where Dr.Jit has no LLVM backend, in
``scalar_spectral`` at a small size. The thickness map is drawn beside the render.
"""

import math
import os
import time

import matplotlib.pyplot as plt
import mitsuba as mi
import numpy as np
import torch

import torchirid.mitsuba
from torchirid.color import linear_srgb_to_srgb
from torchirid.ibl import synthetic_environment
from torchirid.mitsuba.scenes import default_variant, render, sphere_scene

tiny = os.environ.get("TORCHIRID_GALLERY_TINY") == "1"
variant = default_variant()   # llvm_ad_spectral where Dr.Jit has its LLVM backend (libLLVM 19), else scalar_spectral
llvm = variant.startswith("llvm")
torchirid.mitsuba.register(variant)
size = 24 if tiny else (200 if llvm else 48)     # image side in pixels
spp = 8 if tiny else (256 if llvm else 16)

# the film's thickness over the sphere's (u, v): u the azimuth / 2π, v the polar angle / π (v = 0 at the
# top, +z). Drained towards the top, with swirls: smooth random waves, periodic in u, warped by two more
# such fields, fading out at the poles (where u degenerates).
H, W = 128, 256
v = (np.arange(H) + 0.5)[:, None] / H
u = (np.arange(W) + 0.5)[None, :] / W
rng = np.random.default_rng(7)


def waves(u, v, count, top):
    """A sum of ``count`` plane waves of integer frequency in u (≤ top), amplitude 1/frequency."""
    total = 0.0
    for _ in range(count):
        m, k = rng.integers(1, top + 1) * rng.choice([-1, 1]), rng.uniform(0.5, top)
        total = total + np.sin(2 * np.pi * (m * u + k * v) + rng.uniform(0, 2 * np.pi)) / math.hypot(m, k)
    return total


swirl = waves(u + 0.04 * waves(u, v, 8, 5), v + 0.06 * waves(u, v, 8, 5), 10, 7)
swirl = swirl / np.abs(swirl).max() * np.sin(np.pi * v) ** 1.5
thickness = 200.0 + 700.0 * np.clip(v + 0.07 * swirl, 0.0, 1.0) ** 1.3 + 50.0 * swirl   # nm
film = {"type": "torchirid_thin_film", "n_film": 1.33, "n_substrate": 1.0, "n_incident": 1.0,
        "thickness": {"type": "bitmap", "data": mi.TensorXf(thickness[..., None].astype(np.float32)),
                      "raw": True}}

# the synthetic sky (z-up, row 0 the zenith) with its grey ground darkened to grass
env = synthetic_environment(64, 128, sun_direction=(0.45, 0.55, 0.70)).numpy()
env[32:] = [0.03, 0.05, 0.02]
ball = {"type": "sphere", "center": [-3.0, -1.0, -0.7], "radius": 0.45,
        "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.75, 0.25, 0.08]}}}
scene = sphere_scene(film, environment=env, size=size, spp=spp, integrator="path", max_depth=8,
                     elevation_deg=12.0, azimuth_deg=0.0, distance=4.2, fov_deg=38.0, extra={"ball": ball})
start = time.perf_counter()
image = render(scene, spp=spp, seed=1)
seconds = time.perf_counter() - start
print(f"{mi.variant()}: {size}×{size} pixels, {spp} spp in {seconds:.1f} s")

fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(9.6, 4.6), width_ratios=[1.0, 1.1], layout="constrained")
ax0.imshow(linear_srgb_to_srgb(torch.from_numpy(image).double()).clamp(0, 1).numpy())
ax0.set_title(f"soap film η = 1.33 in air ({mi.variant()}, {spp} spp)", fontsize=10)
ax0.axis("off")
im = ax1.imshow(thickness, extent=[0, 360, 180, 0], aspect="auto", cmap="viridis")
ax1.set_xlabel("azimuth φ (°)")
ax1.set_ylabel("polar angle θ from the top (°)")
ax1.set_title("film thickness texture", fontsize=10)
fig.colorbar(im, ax=ax1, label="thickness d (nm)")
plt.show()
