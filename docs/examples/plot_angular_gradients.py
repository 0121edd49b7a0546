"""
Angular colour gradients of Bragg mirrors: the exact colour and the fast approximations
=======================================================================================

Fourneau et al. 2024's Fig. 4: the colour of Bragg mirrors of n1 = 1 and n2 = 1.5 with N = 20
cells, in air, against the incidence angle θ — one row per mirror (period Λ = d1 + d2 of 244,
500 and 988 nm, ratio d1/Λ from 0.1 to 0.9), next to a thin film (a slab of n = 1.5 and
thickness Λ in air; :func:`torchirid.thin_film_reflectance` integrated by
:func:`torchirid.spectrum_to_xyz`). The mirrors' colours come from :func:`torchirid.bragg_xyz`:
the converged spectral integration (``method="spectral"``, the reference), the library's
piecewise-constant spectrum (``"piecewise"``, s = 8 fringe-averaged boxes), the paper's
subdivided approximation (s = 3 with its weights) and the fringe-averaged envelope
(``"envelope"``). Each fast panel is titled with its ΔE2000 against the reference
(:func:`torchirid.color.delta_e_2000`), mean and 95th percentile over the panel. CIE 1931 2°, D65,
sRGB clipped to [0, 1]. One call per method covers the whole grid: Λ, d1/Λ and θ broadcast.

The short periods (Λ = 244 nm) have only one or two reflectance fringes in 380–780 nm, outside
the fast methods' measured domain: :func:`torchirid.bragg_xyz` warns about them (silenced
here, the ΔE shows it) and ``method="auto"`` would pick the spectral integration there.
"""

import os
import warnings

import matplotlib.pyplot as plt
import torch

import torchirid

tiny = os.environ.get("TORCHIRID_GALLERY_TINY") == "1"
f64 = torch.float64
n1, n2, cells = 1.0, 1.5, 20
periods = torch.tensor([244.0, 500.0, 988.0], dtype=f64)
ratios = torch.tensor([0.1, 0.3, 0.5, 0.7, 0.9], dtype=f64)
theta = torch.linspace(0.0, 90.0, 8 if tiny else 76, dtype=f64)
cos_theta = torch.cos(torch.deg2rad(theta)).clamp(0, 1)      # cos 90° is 6e-17: clip rounding

# the grid as broadcasting tensors: Λ (L, 1, 1) × d1/Λ (1, R, 1) × θ (A,) → colours (L, R, A, 3)
d1 = ratios[None, :, None] * periods[:, None, None]
d2 = periods[:, None, None] - d1
methods = {
    "reference (spectral)": {"method": "spectral"},
    "piecewise (s = 8)": {"method": "piecewise"},
    "paper's sub. (s = 3)": {"method": "piecewise", "subdivisions": 3, "weights": "paper"},
    "envelope": {"method": "envelope"},
}
with warnings.catch_warnings():
    warnings.filterwarnings("ignore", message=r"bragg_xyz\(method=.*fewer than", category=RuntimeWarning)
    xyz = {name: torchirid.bragg_xyz(cos_theta, n1, n2, d1, d2, cells, **options)
           for name, options in methods.items()}

# the thin film of each period: its spectrum (L, A, W) on 0.2 nm steps, then XYZ (L, A, 3)
wavelength = torch.linspace(380.0, 780.0, 201 if tiny else 2001, dtype=f64)
R_film = torchirid.thin_film_reflectance(wavelength, cos_theta[:, None], n2, periods[:, None, None], n1,
                                         n_incident=n1)
film = torchirid.spectrum_to_xyz(R_film, wavelength)

L, Rn, A = len(periods), len(ratios), len(theta)
rows = L * Rn                                                 # one image row per mirror
reference = torchirid.xyz_to_lab(xyz["reference (spectral)"])
extent = [-45.0 / (A - 1), 90.0 + 45.0 / (A - 1), rows, 0]    # pixel centres on the angles

fig, axes = plt.subplots(1, 5, figsize=(12.5, 5.2), sharey=True, gridspec_kw={"width_ratios": [0.8, 1, 1, 1, 1]})
axes[0].imshow(torchirid.xyz_to_srgb(film).clamp(0, 1).numpy(), aspect="auto", interpolation="nearest",
               extent=extent)
axes[0].set_title(f"thin film, n = {n2:g}, d = Λ", fontsize=10)
axes[0].set_yticks([Rn * (i + 0.5) for i in range(L)], [f"Λ = {p:g} nm" for p in periods.tolist()])
for ax, (name, colour) in zip(axes[1:], xyz.items()):
    ax.imshow(torchirid.xyz_to_srgb(colour).clamp(0, 1).reshape(rows, A, 3).numpy(), aspect="auto",
              interpolation="nearest", extent=extent)
    de = torchirid.color.delta_e_2000(torchirid.xyz_to_lab(colour), reference)
    title = name if colour is xyz["reference (spectral)"] else (
        f"{name}\nΔE2000 mean {float(de.mean()):.2f}, p95 {float(de.quantile(0.95)):.1f}")
    ax.set_title(title, fontsize=10)
    for i in range(1, L):
        ax.axhline(Rn * i, color="white", lw=2)
for ax in axes:
    ax.set_xticks([0, 30, 60, 90])
    ax.set_xlabel("incidence angle θ (°)")
# the d1/Λ of each row, on the right of the last panel
right = axes[-1].secondary_yaxis("right")
right.set_yticks([i + 0.5 for i in range(rows)], [f"{r:g}" for r in ratios.tolist()] * L, fontsize=7)
right.set_ylabel("d1/Λ (rows of each period)")
fig.suptitle(f"Bragg mirrors n1 = {n1:g}, n2 = {n2:g}, N = {cells} in air: colour (D65, sRGB) against the "
             "incidence angle (after Fourneau et al. 2024, Fig. 4)", fontsize=11)
fig.tight_layout()
plt.show()
