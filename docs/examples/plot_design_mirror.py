"""
Designing a dielectric mirror
=============================

:func:`torchirid.design.optimise` finds the thicknesses of 15 alternating TiO₂ / SiO₂ films on
glass (each free in 10–200 nm, dispersive indices from refractiveindex.info) that reflect as
much as possible of 500–600 nm at normal incidence. The target is R = 1 with ``p = 1``, so the
merit is 1 − mean R over the band. The optimiser (differential evolution rounds, each followed by
exact-gradient L-BFGS-B refinement) converges on its own, in about a second, to the
quarter-wave stack centred near 550 nm (TiO₂ ≈ 56 nm, SiO₂ ≈ 94 nm). Then
:func:`torchirid.design.tolerance` draws 2000 stacks with every thickness off by a normal error
of σ = 2 nm: the mirror hardly notices.
"""

import os

import matplotlib.pyplot as plt
import numpy as np
import torch

import torchirid
from torchirid import design

tiny = os.environ.get("TORCHIRID_GALLERY_TINY") == "1"
pairs = 3 if tiny else 7
band = np.linspace(500.0, 600.0, 11 if tiny else 41)  # nm

problem = design.Problem(
    [design.Layer(m, (10.0, 200.0)) for m in ("TiO2", "SiO2") * pairs + ("TiO2",)],  # incident side first
    [design.SpectralTarget("R", band, value=1.0, cos_theta=1.0, p=1)],
    n_incident=1.0, n_substrate="glass")
mirror = design.optimise(problem, seed=0)
print(f"{len(mirror.layers)} layers, merit (1 - mean R) = {mirror.merit:.5f}, "
      f"{mirror.evaluations} stacks in {mirror.seconds:.1f} s")
print("thicknesses (nm):", [round(d, 1) for d in mirror.thicknesses])


def reflectance(d, wavelength, cos_theta=1.0):
    """R of a design at ``wavelength`` (nm): its media's indices, then torchirid.multilayer."""
    media = [d.problem.n_incident, *d.materials, d.problem.n_substrate]
    indices = torch.stack([torchirid.refractive_index(m, wavelength) for m in media], dim=-1)
    R, _ = torchirid.multilayer(wavelength, cos_theta, indices, torch.tensor(d.thicknesses, dtype=torch.float64))
    return R


wavelength = torch.linspace(400.0, 750.0, 71 if tiny else 701, dtype=torch.float64)
sigma = 2.0  # nm
tol = design.tolerance(mirror, sigma=sigma, samples=200 if tiny else 2000, seed=0)
print(f"σ = {sigma} nm: yield {100 * tol.yield_fraction:.1f} % (merit ≤ 1.1 × nominal), "
      f"95th percentile of 1 - mean R: {np.percentile(tol.merits, 95):.5f}")

fig, (ax, hx) = plt.subplots(1, 2, figsize=(10, 3.6), gridspec_kw={"width_ratios": [1.6, 1]})
ax.axvspan(band[0], band[-1], color="0.9", label="target band")
ax.plot(wavelength.numpy(), reflectance(mirror, wavelength).numpy(), label="0°")
ax.plot(wavelength.numpy(), reflectance(mirror, wavelength, float(np.cos(np.radians(45)))).numpy(), "--",
        label="45° (unpolarized)")
ax.set_xlabel("wavelength (nm)")
ax.set_ylabel("reflectance R")
ax.set_ylim(0, 1.02)
ax.set_title(f"{len(mirror.layers)}-layer TiO$_2$/SiO$_2$ mirror on glass")
ax.legend(loc="lower left", fontsize=8)

hx.hist(100 * tol.merits, bins=40, color="C0")
hx.axvline(100 * tol.nominal, color="k", lw=1, label="as designed")
hx.axvline(100 * tol.merit_limit, color="C3", lw=1, ls="--", label="limit: 1.1 × nominal")
hx.set_xlabel("1 − mean R over 500–600 nm (%)")
hx.set_ylabel("draws")
hx.set_title(f"σ = {sigma:g} nm errors: yield {100 * tol.yield_fraction:.0f} %")
hx.legend(fontsize=8)
fig.tight_layout()
plt.show()
