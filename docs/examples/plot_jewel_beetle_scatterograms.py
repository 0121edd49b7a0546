"""
Jewel-beetle scatterograms
==========================

Fourneau et al. 2024, Fig. 9's setting: the hemisphere of reflected directions (equidistant
projection) of the three jewel-beetle cuticle presets — one rough Bragg layer (α = 0.05) in air
over a black base — under a white environment and under a narrow beam at 45°
(:func:`torchirid.scatterogram`, the single-reflection model of eq. 34).
"""

import os

import matplotlib.pyplot as plt
import torch

import torchirid
from torchirid.presets import JEWEL_BEETLE_NAMES, jewel_beetle

tiny = os.environ.get("TORCHIRID_GALLERY_TINY") == "1"
resolution = 16 if tiny else 128
wavelength = torch.linspace(380.0, 780.0, 21 if tiny else 81, dtype=torch.float64)

fig, axes = plt.subplots(2, 3, figsize=(7.5, 5.2))
for column, name in enumerate(JEWEL_BEETLE_NAMES):
    for row, beam in enumerate([None, (45.0, 0.0)]):
        s = torchirid.scatterogram(jewel_beetle(name), incident_deg=beam, resolution=resolution, wavelength=wavelength,
                                   profile_angles=16 if tiny else None)
        xyz = s.xyz / s.xyz[..., 1].max().clamp_min(1e-12)  # each image exposed to its brightest pixel
        axes[row, column].imshow(torchirid.xyz_to_srgb(xyz).clamp(0, 1).numpy())
        axes[row, column].set_title(f"{name}, {'white environment' if beam is None else 'beam at 45°'}", fontsize=9)
        axes[row, column].axis("off")
fig.tight_layout()
plt.show()
