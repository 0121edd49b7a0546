"""
Growing a broadband anti-reflection coating with needles
========================================================

Bare glass reflects about 4 % of visible light. This example designs a TiO₂ / SiO₂ coating
that brings R over 400–700 nm (normal incidence) close to 0, without fixing the number of
layers in advance: the **needle method** (``method="needle"``, Tikhonravov et al. 1996) starts
from a single 100 nm SiO₂ film and repeatedly inserts the zero-thickness film (of either
material, at any depth) whose growth lowers the merit fastest, then refines every thickness by
exact gradients, until no needle helps or ``max_layers`` is reached. The merit is the RMS of R
over the band (``p = 2``).

Thin films are hard to make. With ``Problem(min_thickness=5.0)`` the needle stage keeps every
layer at least 5 nm thick while it refines (only the needle just inserted may start thinner;
if it does not grow past 5 nm it is removed and the rest refined again). The dotted curve is
the same search without that limit. The last panel is the tolerance analysis of the final
coating: 2000 coatings with σ = 1 nm thickness errors, against a specification of RMS R ≤
0.4 %.
"""

import os

import matplotlib.pyplot as plt
import numpy as np
import torch

import torchirid
from torchirid import design

tiny = os.environ.get("TORCHIRID_GALLERY_TINY") == "1"
band = np.linspace(400.0, 700.0, 11 if tiny else 31)  # nm
target = design.SpectralTarget("R", band, value=0.0, p=2)

# 1. needles without a thickness limit: from one film that may be either material (the palette of
#    the needles), 0–200 nm
start = design.Problem([design.Layer(["SiO2", "TiO2"], (0.0, 200.0))], [target],
                       n_incident=1.0, n_substrate="glass", max_layers=6 if tiny else 10)
grown = design.optimise(start, method="needle", seed=0)
print(f"needles: {len(grown.layers)} layers, RMS R {100 * grown.merit:.3f} %, "
      f"thinnest {min(grown.thicknesses):.1f} nm, {grown.seconds:.1f} s")

# 2. the same search, every layer at least 5 nm thick
makeable = design.Problem(start.layers, [target], n_incident=1.0, n_substrate="glass",
                          max_layers=start.max_layers, min_thickness=5.0)
coating = design.optimise(makeable, method="needle", seed=0)
print(f"≥ 5 nm: {len(coating.layers)} layers, RMS R {100 * coating.merit:.3f} %, {coating.seconds:.1f} s")
for layer in coating.layers:
    print(f"  {layer['material']:>4} {layer['thickness_nm']:6.1f} nm")


def reflectance(d, wavelength):
    """R at normal incidence of a design at ``wavelength`` (nm), with torchirid.multilayer."""
    media = [d.problem.n_incident, *d.materials, d.problem.n_substrate]
    indices = torch.stack([torchirid.refractive_index(m, wavelength) for m in media], dim=-1)
    R, _ = torchirid.multilayer(wavelength, 1.0, indices, torch.tensor(d.thicknesses, dtype=torch.float64))
    return R


wavelength = torch.linspace(380.0, 780.0, 81 if tiny else 401, dtype=torch.float64)
n_glass = torchirid.refractive_index("glass", wavelength).real
bare = ((n_glass - 1) / (n_glass + 1)) ** 2
limit = 0.004
tol = design.tolerance(coating, sigma=1.0, samples=200 if tiny else 2000, seed=0, merit_limit=limit)
print(f"σ = 1 nm: yield {100 * tol.yield_fraction:.1f} % ± {100 * tol.standard_error:.1f} % (RMS R ≤ 0.4 %)")

fig, (ax, hx) = plt.subplots(1, 2, figsize=(10, 3.6), gridspec_kw={"width_ratios": [1.6, 1]})
ax.axvspan(band[0], band[-1], color="0.92")
ax.plot(wavelength.numpy(), 100 * bare.numpy(), color="0.4", label="bare glass")
ax.plot(wavelength.numpy(), 100 * reflectance(grown, wavelength).numpy(), ":", color="C1",
        label=f"needles, {len(grown.layers)} layers")
ax.plot(wavelength.numpy(), 100 * reflectance(coating, wavelength).numpy(), color="C0",
        label=f"every layer ≥ 5 nm, {len(coating.layers)} layers")
ax.set_xlabel("wavelength (nm)")
ax.set_ylabel("reflectance R (%)")
ax.set_ylim(0, 5)
ax.set_title("TiO$_2$/SiO$_2$ anti-reflection coating on glass, 0°")
ax.legend(fontsize=8)

hx.hist(100 * tol.merits, bins=40, color="C0")
hx.axvline(100 * tol.nominal, color="k", lw=1, label="as designed")
hx.axvline(100 * limit, color="C3", lw=1, ls="--", label="specification")
hx.set_xlabel("RMS R over 400–700 nm (%)")
hx.set_ylabel("draws")
hx.set_title(f"σ = 1 nm errors: yield {100 * tol.yield_fraction:.0f} %")
hx.legend(fontsize=8)
fig.tight_layout()
plt.show()
