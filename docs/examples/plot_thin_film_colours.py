"""
Thin-film colours against thickness and angle
=============================================

The colour of a soap film (n = 1.33, in air) and of an oil film on water (n = 1.47 on 1.33) for
thicknesses 0–1000 nm and incidence angles 0–80°: each pixel integrates the exact Airy
reflectance over 380–780 nm (CIE 1931 2°, D65) and is shown in sRGB, brightened 2× — films
reflect a few percent.
"""

import os

import matplotlib.pyplot as plt
import torch

import torchirid

tiny = os.environ.get("TORCHIRID_GALLERY_TINY") == "1"
f64 = torch.float64
wavelength = torch.linspace(380.0, 780.0, 81 if tiny else 401, dtype=f64)
thickness = torch.linspace(0.0, 1000.0, 20 if tiny else 400, dtype=f64)
theta = torch.linspace(0.0, 80.0, 8 if tiny else 120, dtype=f64)
cos_theta = torch.cos(torch.deg2rad(theta))

fig, axes = plt.subplots(1, 2, figsize=(8, 3.6), sharey=True)
for ax, (label, n_film, n_base) in zip(axes, [("soap film 1.33 in air", 1.33, 1.0), ("oil 1.47 on water 1.33", 1.47, 1.33)]):
    # (A, 1, 1) angles × (1, T, 1) thicknesses × (W,) wavelengths → (A, T, W)
    R = torchirid.thin_film_reflectance(wavelength, cos_theta[:, None, None], n_film, thickness[None, :, None], n_base)
    rgb = torchirid.xyz_to_srgb(2.0 * torchirid.spectrum_to_xyz(R, wavelength)).clamp(0, 1)
    ax.imshow(rgb.numpy(), origin="lower", aspect="auto",
              extent=[float(thickness[0]), float(thickness[-1]), float(theta[0]), float(theta[-1])])
    ax.set_title(label)
    ax.set_xlabel("thickness d (nm)")
axes[0].set_ylabel("incidence angle θ (°)")
fig.tight_layout()
plt.show()
