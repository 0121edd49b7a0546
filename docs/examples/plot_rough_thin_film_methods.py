"""
A rough thin film under uniform light: Belcour–Barla, Kneiphof and the fitted table
===================================================================================

The reflectance term of a GGX surface with a film (η₂ = 1.3, base 2 + 0.5i, Kneiphof et al.'s
Fig. 2 material) under uniform white light, over the viewing angle θo and the thickness d at
α = 0.25: the converged reference (:func:`torchirid.ibl.thin_film_xyz_uniform`), Belcour–Barla's
Fourier colour at the mirror direction (:func:`torchirid.ibl.thin_film_xyz_fourier`),
Kneiphof's filtered colour with the light's moments (:func:`torchirid.ibl.thin_film_xyz_filtered`)
and torchirid's fitted light-mixture table (:func:`torchirid.ibl.thin_film_xyz_fitted`), each
titled with its mean ΔE2000 against the reference.
"""

import os

import matplotlib.pyplot as plt
import torch

import torchirid
from torchirid.color import delta_e_2000, xyz_to_lab
from torchirid.ibl import (thin_film_xyz_filtered, thin_film_xyz_fitted, thin_film_xyz_fourier, uniform_light_moments,
                           thin_film_xyz_uniform)

tiny = os.environ.get("TORCHIRID_GALLERY_TINY") == "1"
n = 6 if tiny else 48
f64 = torch.float64
theta = (torch.arange(n, dtype=f64) + 0.5) * 90.0 / n
cos = torch.cos(torch.deg2rad(theta))[:, None]                       # (n, 1): rows θo
d = ((torch.arange(n, dtype=f64) + 0.5) * 1000.0 / n)[None, :]       # (1, n): columns d
alpha, n_film, base = 0.25, 1.3, complex(2.0, 0.5)

options = {"bins": 256, "nodes": 24} if tiny else {}
colours = {"reference": thin_film_xyz_uniform(cos, alpha, n_film, d, base, **options)}
colours["Belcour–Barla"] = thin_film_xyz_fourier(cos, n_film, d, base, sensitivity="exact")
albedo, mean, cov = uniform_light_moments(cos, torch.tensor(alpha, dtype=f64))
wo = torch.stack([torch.sqrt(1 - cos * cos), torch.zeros_like(cos), cos], -1).expand(n, n, 3)
colours["Kneiphof"] = thin_film_xyz_filtered(wo, mean, cov, n_film, d, base)
colours["fitted table"] = thin_film_xyz_fitted(cos, alpha, n_film, d, base)

reference = xyz_to_lab(colours["reference"].expand(n, n, 3))
fig, axes = plt.subplots(1, 4, figsize=(11, 3.2), sharey=True)
for ax, (name, xyz) in zip(axes, colours.items()):
    xyz = xyz.expand(n, n, 3)
    de = delta_e_2000(xyz_to_lab(xyz), reference)
    ax.imshow(torchirid.xyz_to_srgb(2.0 * xyz).clamp(0, 1).numpy(), origin="lower", aspect="auto",
              extent=[0, 1000, 0, 90])
    ax.set_title(name if name == "reference" else f"{name}: ΔE {float(de.mean()):.2f}", fontsize=10)
    ax.set_xlabel("thickness d (nm)")
axes[0].set_ylabel("viewing angle θo (°)")
fig.tight_layout()
plt.show()
