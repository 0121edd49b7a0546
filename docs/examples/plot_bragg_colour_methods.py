"""
Bragg colour: speed against error of the methods
================================================

The colour of a Bragg mirror (n1 = 1, n2 = 1.5, N = 20, Λ = 500 nm, d1/Λ from 0.1 to 0.9, all
angles) by each method of :func:`torchirid.bragg_xyz` — the converged spectral integration
(the reference), Fourneau et al.'s piecewise landmarks, the envelope method — timed on this
machine, against its CIEDE2000 error. docs/performance.md has the measured study over the
paper's whole Fig. 4 grid.
"""

import os
import time

import matplotlib.pyplot as plt
import torch

import torchirid
from torchirid.color import delta_e_2000, xyz_to_lab

tiny = os.environ.get("TORCHIRID_GALLERY_TINY") == "1"
f64 = torch.float64
cos = torch.cos(torch.deg2rad(torch.linspace(0.0, 80.0, 8 if tiny else 64, dtype=f64)))[:, None]
fraction = torch.linspace(0.1, 0.9, 4 if tiny else 32, dtype=f64)
d1, d2 = 500.0 * fraction, 500.0 * (1 - fraction)


def run(method):
    start = time.perf_counter()
    xyz = torchirid.bragg_xyz(cos, 1.0, 1.5, d1, d2, 20, method=method)
    return xyz, time.perf_counter() - start


reference, _ = run("spectral")
fig, ax = plt.subplots(figsize=(5.5, 3.6))
for method in ("spectral", "piecewise", "envelope"):
    xyz, seconds = run(method)
    de = delta_e_2000(xyz_to_lab(xyz), xyz_to_lab(reference))
    per_colour = 1e6 * seconds / de.numel()
    ax.scatter([per_colour], [float(torch.quantile(de.flatten(), 0.95)) + 1e-3], s=40)
    ax.annotate(method, (per_colour, float(torch.quantile(de.flatten(), 0.95)) + 1e-3), textcoords="offset points",
                xytext=(6, 4))
    print(f"{method:>9}: {per_colour:8.1f} µs per colour, ΔE2000 mean {float(de.mean()):.3f}, max {float(de.max()):.3f}")
ax.set_xscale("log")
ax.set_yscale("log")
ax.set_xlabel("µs per colour (this machine)")
ax.set_ylabel("p95 ΔE2000 vs spectral (+0.001)")
ax.set_title("Bragg mirror colour: speed against error")
fig.tight_layout()
plt.show()
