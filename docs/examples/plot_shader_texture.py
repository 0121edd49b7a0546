"""
A shader texture fitted by autograd, and exported for a renderer
================================================================

A 16 × 64 RGB texture of a soap film over (√cos θ, d) whose texel values minimise the
CIEDE2000 error of the **linearly interpolated** texture (what a GPU's filtering returns)
against the exact colour, next to the same texture holding the exact colour at its texels
(:func:`torchirid.realtime.fit_texture`). The fitted one is exported as raw float32 + a JSON
sidecar for a shader (:func:`torchirid.export.export_lut`); the GLSL that reads it is
:func:`torchirid.realtime.glsl_source`.
"""

import os
import tempfile

import matplotlib.pyplot as plt
import torch

from torchirid.color import delta_e_2000, linear_srgb_to_xyz, xyz_to_lab
from torchirid.export import export_lut
from torchirid.realtime import exact_colour, fit_texture, lookup

tiny = os.environ.get("TORCHIRID_GALLERY_TINY") == "1"
film = {"n_film": 1.33, "n_substrate": 1.0}
ranges = ((0.05, 1.0), (100.0, 800.0))
fit = fit_texture("thin_film", (6, 16) if tiny else (16, 64), ranges, film, samples=1000 if tiny else 20000,
                  validation=1000 if tiny else 10000, iterations=5 if tiny else 60)
print("ΔE2000 on independent samples:", fit.errors)

# error maps over a dense grid of (cos θ, d)
f64 = torch.float64
cos, d = torch.meshgrid(torch.linspace(0.05, 1.0, 30 if tiny else 200, dtype=f64),
                        torch.linspace(100.0, 800.0, 40 if tiny else 400, dtype=f64), indexing="ij")
points = torch.stack([cos, d], -1)
lab = lambda rgb: xyz_to_lab(linear_srgb_to_xyz(rgb))  # noqa: E731
truth = lab(exact_colour("thin_film", points, film))
fig, axes = plt.subplots(1, 2, figsize=(8, 3.4), sharey=True)
for ax, (label, lut) in zip(axes, [("sampled texels", fit.sampled), ("fitted texels", fit.lut)]):
    de = delta_e_2000(lab(lookup(lut, "thin_film", points)), truth)
    im = ax.imshow(de.numpy(), origin="lower", aspect="auto", vmin=0, vmax=3, cmap="viridis",
                   extent=[100, 800, 0.05, 1.0])
    ax.set_title(f"{label}: mean ΔE2000 {float(de.mean()):.2f}")
    ax.set_xlabel("thickness d (nm)")
axes[0].set_ylabel("cos θ")
fig.colorbar(im, ax=axes, label="ΔE2000")
plt.show()

with tempfile.TemporaryDirectory() as out:
    written = export_lut(fit.lut, os.path.join(out, "soap_film"), format="raw")
    print("exported:", [os.path.basename(str(p)) for p in written])
