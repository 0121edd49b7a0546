"""Real time: small colour textures for shaders, fitted by autograd.

:func:`fit_texture` builds a texture of one material family — a thin film over (cos θ, d), a
Bragg mirror over (cos θ, Λ, δ), a rough film under uniform light over (cos θ_o, α, d) — whose
node values minimise the CIEDE2000 error of the hardware-interpolated texture against the exact
spectral colour (:mod:`torchirid.realtime.textures`).
"""

from .textures import (
    AXIS_WARPS,
    FAMILIES,
    SHIPPED_TEXTURES,
    TextureFit,
    bragg_wavelength,
    exact_colour,
    fit_texture,
    glsl_source,
    lookup,
    path_difference,
    shipped_texture,
    texture_lut,
)

__all__ = ["AXIS_WARPS", "FAMILIES", "SHIPPED_TEXTURES", "TextureFit", "bragg_wavelength", "exact_colour", "fit_texture",
           "glsl_source", "lookup", "path_difference", "shipped_texture", "texture_lut"]
