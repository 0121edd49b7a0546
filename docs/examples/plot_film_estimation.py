"""
A film's index and thickness map from a hyperspectral cube
==========================================================

Kobayashi et al.'s method (:func:`torchirid.estimate_film`): a cube of band reflectance seen at
several incidence angles → the film's refractive index (shared) and its thickness per pixel.
The cube here is synthetic (:func:`torchirid.estimation.synthetic_cube`: their MgF₂-on-PET
sample, 1 % noise), so the estimate can be compared with the truth.
"""

import os

import matplotlib.pyplot as plt

import torchirid
from torchirid.estimation import synthetic_cube

tiny = os.environ.get("TORCHIRID_GALLERY_TINY") == "1"
size = 8 if tiny else 64
truth = synthetic_cube("mgf2_400", height=size, width=size, seed=0)
fit = torchirid.estimate_film(truth.cube, truth.wavelength, truth.cos_theta, truth.sample.n_substrate)
error = (fit.thickness - truth.thickness).abs()
print(f"n = {float(fit.n):.4f} (true {truth.sample.n_film}); mean |Δd| = {float(error.mean()):.2f} nm")

fig, axes = plt.subplots(1, 3, figsize=(10, 3.2))
lo, hi = float(truth.thickness.min()), float(truth.thickness.max())
for ax, (title, image, kw) in zip(axes, [("true thickness (nm)", truth.thickness, {"vmin": lo, "vmax": hi}),
                                         ("estimated thickness (nm)", fit.thickness, {"vmin": lo, "vmax": hi}),
                                         ("|error| (nm)", error, {"cmap": "magma"})]):
    im = ax.imshow(image.numpy(), **kw)
    ax.set_title(title, fontsize=10)
    ax.axis("off")
    fig.colorbar(im, ax=ax, shrink=0.8)
fig.tight_layout()
plt.show()
