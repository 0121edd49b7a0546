"""
A Bragg mirror's reflectance map and colour strip
=================================================

R(θ, λ) of Fourneau et al. 2024's Fig. 1 mirror — n1 = 1, n2 = 1.5, d1 = 125 nm, d2 = 375 nm,
N = 20 cells, in air — with the colour of the mirror against the angle underneath (CIE 1931 2°,
D65, sRGB). One call per quantity: the wavelengths and the angles broadcast.
"""

import os

import matplotlib.pyplot as plt
import torch

import torchirid

tiny = os.environ.get("TORCHIRID_GALLERY_TINY") == "1"
f64 = torch.float64
wavelength = torch.linspace(380.0, 780.0, 41 if tiny else 401, dtype=f64)
theta = torch.linspace(0.0, 89.0, 16 if tiny else 180, dtype=f64)
cos_theta = torch.cos(torch.deg2rad(theta))

# (A, 1) against (W,): the map in one call
R = torchirid.bragg_reflectance(wavelength, cos_theta[:, None], 1.0, 1.5, 125.0, 375.0, 20)
# the colour of each angle (spectral integration; method="auto" picks a faster one at ≤ 1 ΔE2000)
rgb = torchirid.xyz_to_srgb(torchirid.bragg_xyz(cos_theta, 1.0, 1.5, 125.0, 375.0, 20)).clamp(0, 1)

fig, (ax, strip) = plt.subplots(2, 1, figsize=(6, 4.4), sharex=True, gridspec_kw={"height_ratios": [5, 1]})
ax.imshow(R.T.numpy(), origin="lower", aspect="auto", cmap="magma",
          extent=[float(theta[0]), float(theta[-1]), float(wavelength[0]), float(wavelength[-1])])
ax.set_ylabel("wavelength λ (nm)")
ax.set_title("Bragg mirror R(θ, λ), N = 20")
strip.imshow(rgb[None].numpy(), aspect="auto", extent=[float(theta[0]), float(theta[-1]), 0, 1])
strip.set_yticks([])
strip.set_xlabel("incidence angle θ (°)")
fig.tight_layout()
plt.show()
