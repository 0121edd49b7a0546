"""
Inverse rendering: a film's thickness from a rendered image
===========================================================

A sphere of silicon coated with a film of silica (``torchirid_thin_film``, ``n_film = "SiO2"``
on ``n_substrate = "Si"``, both the library's tabulated indices) on a GGX-rough surface
(α = 0.2), under the library's synthetic sky (:func:`torchirid.ibl.synthetic_environment`).
The target image is rendered at d = 320 nm; starting from a wrong thickness, the thickness is
recovered from the image alone by gradient descent on the image's mean squared error: Mitsuba's
differentiable path replay (the ``prb`` integrator) carries the loss's derivative back to the
BSDF, whose film reflectance — the library's thin-film formula evaluated in Dr.Jit arithmetic —
Dr.Jit differentiates in the thickness (``mi.traverse(scene)["sphere.bsdf.thickness"]``); the
steps are ``mi.ad.Adam``'s, at a learning rate of 5 nm for the first third of the steps, then decaying to 0.25 nm (β₁ = 0.7). Each step renders
16 samples per pixel with a new seed, so the gradient is a noisy but unbiased estimate; the
estimate reported is the mean of the last ten iterates.

**The loss has many minima.** A film's colours repeat as its optical path grows by about half
a wavelength, so the image error against the thickness (bottom right: renders at fixed seed over
100–600 nm) has a minimum near every ~190 nm — here at about 130, 320 and 510 nm — and a
descent converges to the one of the basin it starts in. The start, 270 nm, lies in the target's
basin (between the maxima near 240 and 420 nm); started at 200 nm, the same descent ends at
133 nm, the wrong minimum. A global search (a coarse scan like the landscape's, or the library's
:func:`torchirid.estimate_film` on a spectrum) finds the basin; the gradient then refines it.

Runs in ``llvm_ad_spectral`` (each path samples four wavelengths): 40 steps of a 64 × 64 image
take about 5 s on two cores. Where Dr.Jit has no LLVM backend there is no differentiable variant
on the CPU: the script then renders in ``scalar_spectral`` at a tiny size and steps by the sign
of central differences at a fixed seed instead.
"""

import os
import time

import drjit as dr
import matplotlib.pyplot as plt
import mitsuba as mi
import numpy as np
import torch

import torchirid.mitsuba
from torchirid.color import linear_srgb_to_srgb
from torchirid.mitsuba.scenes import default_variant, sphere_scene

tiny = os.environ.get("TORCHIRID_GALLERY_TINY") == "1"
variant = default_variant()   # llvm_ad_spectral where Dr.Jit has its LLVM backend (libLLVM 19), else scalar_spectral
llvm = variant.startswith("llvm")
torchirid.mitsuba.register(variant)
small = tiny or not llvm                         # the scalar variants evaluate the BSDF in Python per sample
size = 64 if not small else (16 if llvm else 12)  # image side in pixels
spp = 16 if llvm else 4                          # samples per pixel of each step
iterations = 40 if not small else (8 if llvm else 12)
target_nm, start_nm = 320.0, 270.0
key = "sphere.bsdf.thickness"

film = {"type": "torchirid_thin_film", "n_film": "SiO2", "thickness": target_nm, "n_substrate": "Si", "alpha": 0.2}
setting = {"size": size, "spp": spp, "integrator": "prb" if llvm else "path", "max_depth": 2, "elevation_deg": 25.0}
scene = sphere_scene(film, **setting)
params = mi.traverse(scene)


def as_image(x):
    return np.array(x, dtype=np.float64).reshape(size, size, 3)


def set_thickness(d):
    global scene, params
    if llvm:
        params[key] = dr.opaque(mi.Float, d)   # opaque: a new value is not a new kernel
        params.update()
    else:  # the scalar variants' plugin parameters are Python floats that mi.traverse cannot set
        scene = sphere_scene({**film, "thickness": float(d)}, **setting)
        params = mi.traverse(scene)


start = time.perf_counter()
target = as_image(mi.render(scene, params, spp=8 * spp if small else 256, seed=10_000))


def loss_of(image):
    return float(np.mean((image - target) ** 2))


# the landscape: the loss over the thickness, at one seed (its noise floor is the target's)
thicknesses = np.arange(100.0, 601.0, 50.0 if small else 10.0)
landscape = []
for d in thicknesses:
    set_thickness(d)
    landscape.append(loss_of(as_image(mi.render(scene, params, spp=spp, seed=1))))

# the descent
set_thickness(start_nm)
start_image = as_image(mi.render(scene, params, spp=spp if small else 128, seed=2))
history, losses = [start_nm], []
if llvm:
    opt = mi.ad.Adam(lr=5.0, beta_1=0.7)              # light momentum: less overshoot
    opt[key] = params[key]
    params.update(opt)
descent = time.perf_counter()
for it in range(iterations):
    opt_lr = 5.0 * 0.05 ** max(0.0, (it - iterations / 3) / (iterations * 2 / 3))   # 5 nm, then → 0.25 nm
    if llvm:
        opt.set_learning_rate(opt_lr)
        image = mi.render(scene, params, spp=spp, seed=it)
        loss = dr.mean(dr.square(image - mi.TensorXf(target.astype(np.float32))), axis=None)
        dr.backward(loss)
        opt.step()
        params.update(opt)
        losses.append(float(np.array(loss).ravel()[0]))
        history.append(float(np.array(params[key]).ravel()[0]))
    else:  # no AD variant: the sign of a central difference at a fixed seed, a step of 1.6 × opt_lr
        d = history[-1]
        set_thickness(d + 2.0)
        up = loss_of(as_image(mi.render(scene, params, spp=spp, seed=it)))
        set_thickness(d - 2.0)
        down = loss_of(as_image(mi.render(scene, params, spp=spp, seed=it)))
        losses.append(0.5 * (up + down))
        history.append(d - 1.6 * opt_lr * np.sign(up - down))
        set_thickness(history[-1])
descent = time.perf_counter() - descent
final_nm = float(np.mean(history[-10:]))
set_thickness(final_nm)
final_image = as_image(mi.render(scene, params, spp=spp if small else 128, seed=3))
seconds = time.perf_counter() - start
print(f"{mi.variant()}: target {target_nm:g} nm, start {start_nm:g} nm, recovered {final_nm:.1f} nm "
      f"({final_nm - target_nm:+.1f} nm) after {iterations} steps in {descent:.1f} s; {seconds:.1f} s in all")

fig = plt.figure(figsize=(10.5, 6.4), layout="constrained")
top, bottom = fig.subfigures(2, 1, height_ratios=[1.0, 1.0])
exposure = 0.9 / np.quantile(target, 0.99)
for ax, (title, image) in zip(top.subplots(1, 3), [(f"target, d = {target_nm:g} nm", target),
                                                   (f"start, d = {start_nm:g} nm", start_image),
                                                   (f"recovered, d = {final_nm:.1f} nm", final_image)]):
    ax.imshow(linear_srgb_to_srgb(torch.from_numpy(exposure * image)).clamp(0, 1).numpy())
    ax.set_title(title, fontsize=10)
    ax.axis("off")
ax_loss, ax_d, ax_land = bottom.subplots(1, 3)
ax_loss.semilogy(np.arange(1, iterations + 1), losses, ".-")
ax_loss.set_xlabel("iteration")
ax_loss.set_ylabel("image MSE")
ax_loss.set_title(f"loss ({spp} spp a step)", fontsize=10)
ax_d.plot(np.arange(iterations + 1), history, ".-", label="iterate")
ax_d.axhline(target_nm, color="k", lw=0.8, ls="--", label="target")
ax_d.set_xlabel("iteration")
ax_d.set_ylabel("thickness d (nm)")
ax_d.set_title("thickness", fontsize=10)
ax_d.legend(fontsize=8)
ax_land.plot(thicknesses, landscape, "-", color="0.4")
ax_land.axvline(target_nm, color="k", lw=0.8, ls="--", label="target")
ax_land.axvline(start_nm, color="tab:orange", lw=0.8, label="start")
ax_land.axvline(final_nm, color="tab:green", lw=0.8, ls=":", label="recovered")
ax_land.set_xlabel("thickness d (nm)")
ax_land.set_ylabel("image MSE")
ax_land.set_title("the loss is multimodal", fontsize=10)
ax_land.legend(fontsize=8)
fig.suptitle(f"SiO₂ film on Si, GGX α = 0.2: recovered {final_nm:.1f} nm for {target_nm:g} nm "
             f"({mi.variant()}, {'prb + Adam' if llvm else 'central differences'})", fontsize=11)
plt.show()
