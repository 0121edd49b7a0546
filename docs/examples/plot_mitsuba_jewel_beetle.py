"""
A jewel beetle of rough Bragg layers, rendered in Mitsuba 3
===========================================================

A stylised jewel beetle — two elytra, a pronotum and a head, ellipsoid meshes — whose cuticle
is Fourneau et al.'s rough Bragg layer (2024, eq. 34: the mirrors' Bragg reflectance on GGX
microfacets, one reflection), the ``torchirid_bragg`` BSDF of :func:`torchirid.mitsuba.register`
with ``alpha``. Each part is one of the paper's measured areas (Table 3,
:func:`torchirid.presets.jewel_beetle`): the elytra the green/blue area (Λ = 160 nm, 8 cells),
the pronotum the red one (Λ = 190 nm, 8 cells), the head the purple one (Λ = 205 nm, 6 cells).

The preset is one :class:`~torchirid.layered.RoughBraggLayer` (``layers=1``, the paper's) over
an absorbing base, and it maps onto the plugin's parameters one to one: ``n1``, ``n2``,
``d1 = (1 − δ)Λ``, ``d2 = δΛ``, ``cells`` and ``alpha = 0.05`` as they are, ``n_incident = 1``
(the preset lights the mirrors from air: the reflectance of the paper's appendix D, no coating
— the plugin's default ``n_incident`` would be the host ``n1``) and ``base_albedo = 0`` (the
black base: every path out of the cuticle reflects once, so the single-reflection BRDF is exact).

The beetle lies on a grey card under the library's synthetic sky
(:func:`torchirid.ibl.synthetic_environment`), rendered with Mitsuba's ``path`` integrator in
``llvm_ad_spectral`` (``scalar_spectral`` at a small size where Dr.Jit has no LLVM backend).
The right panel is the three mirrors' reflectance (:func:`torchirid.bragg_reflectance`, from
air) at normal incidence and at 45°: the weak index contrast (Δn = 0.08) over 6–8 cells gives
peaks of 25–30 % some 50 nm wide (over the 5 % of the air | n1 surface) that move to shorter
wavelengths off normal — the green-to-blue and red-to-green shifts across each curved part.
"""

import os
import time

import matplotlib.pyplot as plt
import mitsuba as mi
import numpy as np
import torch

import torchirid
import torchirid.mitsuba
from torchirid.color import linear_srgb_to_srgb
from torchirid.ibl import synthetic_environment
from torchirid.mitsuba.scenes import default_variant, render, sphere_scene
from torchirid.presets import jewel_beetle

tiny = os.environ.get("TORCHIRID_GALLERY_TINY") == "1"
variant = default_variant()   # llvm_ad_spectral where Dr.Jit has its LLVM backend (libLLVM 19), else scalar_spectral
llvm = variant.startswith("llvm")
torchirid.mitsuba.register(variant)
size = 24 if tiny else (200 if llvm else 32)     # image side in pixels
spp = 8 if tiny else (96 if llvm else 8)
rings = 12 if tiny else 48                       # mesh resolution: rings × 2·rings quads per part


def cuticle(name):
    """The plugin's parameters of a preset: its one rough Bragg layer over a black base."""
    structure = jewel_beetle(name)
    (layer,) = structure.layers
    return {"type": "torchirid_bragg", "n1": layer.n1, "n2": layer.n2, "d1": layer.d1, "d2": layer.d2,
            "cells": layer.cells, "alpha": layer.alpha, "n_incident": layer.n_incident,
            "base_albedo": structure.base_albedo}


def ellipsoid(center, semi_axes, bsdf):
    """A triangle mesh of an ellipsoid with its exact normals, carrying ``bsdf``."""
    theta = np.linspace(0.0, np.pi, rings + 1)
    phi = np.linspace(0.0, 2 * np.pi, 2 * rings, endpoint=False)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    unit = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1).reshape(-1, 3)
    normal = unit / np.asarray(semi_axes)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    i, j = np.meshgrid(np.arange(rings), np.arange(2 * rings), indexing="ij")
    a, b = i * 2 * rings + j, i * 2 * rings + (j + 1) % (2 * rings)
    faces = np.concatenate([np.stack([a, a + 2 * rings, b], -1), np.stack([b, a + 2 * rings, b + 2 * rings], -1)])
    props = mi.Properties()
    props["bsdf"] = mi.load_dict(bsdf)
    mesh = mi.Mesh("part", len(unit), faces.size // 3, has_vertex_normals=True, props=props)
    params = mi.traverse(mesh)
    for key, value in (("vertex_positions", unit * semi_axes + center), ("vertex_normals", normal), ("faces", faces)):
        params[key] = type(params[key])(value.astype(np.uint32 if key == "faces" else np.float32).ravel())
    params.update()
    return mesh


green, red, purple = cuticle("green"), cuticle("red"), cuticle("purple")
print("elytra:", green)
beetle = {
    "sphere": ellipsoid([-0.35, 0.23, 0.0], [1.25, 0.33, 0.42], green),      # the left and right elytron
    "elytron": ellipsoid([-0.35, -0.23, 0.0], [1.25, 0.33, 0.42], green),
    "pronotum": ellipsoid([0.92, 0.0, -0.02], [0.32, 0.5, 0.3], red),
    "head": ellipsoid([1.3, 0.0, -0.08], [0.17, 0.26, 0.17], purple),
    "card": {"type": "rectangle", "to_world": mi.ScalarTransform4f().translate([0, 0, -0.3]).scale(10),
             "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": 0.35}}},
}
env = synthetic_environment(64, 128, sun_direction=(-0.3, 0.5, 0.8)).numpy()
scene = sphere_scene({"type": "diffuse"}, environment=env, size=size, spp=spp, integrator="path", max_depth=4,
                     elevation_deg=38.0, azimuth_deg=-55.0, distance=6.0, fov_deg=33.0, extra=beetle)
start = time.perf_counter()
image = render(scene, spp=spp, seed=1)
print(f"{mi.variant()}: {size}×{size} pixels, {spp} spp in {time.perf_counter() - start:.1f} s")

wavelength = torch.linspace(380.0, 780.0, 81 if tiny else 401, dtype=torch.float64)
fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(10.0, 4.6), width_ratios=[1.0, 1.15], layout="constrained")
ax0.imshow(linear_srgb_to_srgb(torch.from_numpy(image).double() * 1.6).clamp(0, 1).numpy())
ax0.set_title(f"α = {green['alpha']}, black base ({mi.variant()}, {spp} spp)", fontsize=10)
ax0.axis("off")
for (part, spec), colour in zip({"elytra: green": green, "pronotum: red": red, "head: purple": purple}.items(),
                                ("tab:green", "tab:red", "tab:purple")):
    for cos_theta, style in ((1.0, "-"), (0.7071, "--")):
        r = torchirid.bragg_reflectance(wavelength, cos_theta, spec["n1"], spec["n2"], spec["d1"], spec["d2"],
                                        spec["cells"], n_incident=spec["n_incident"])
        ax1.plot(wavelength, r, style, color=colour, label=f"{part}, {'0°' if cos_theta == 1 else '45°'}")
ax1.set_xlabel("wavelength λ (nm)")
ax1.set_ylabel("reflectance R (unpolarized)")
ax1.set_title("the mirrors' reflectance from air (Fourneau et al., Table 3)", fontsize=10)
ax1.legend(fontsize=8)
plt.show()
