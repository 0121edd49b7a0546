"""Colour: CMFs and illuminants (colour-science data as cached tensors), spectrum → XYZ →
L*a*b* / sRGB, and colour differences (ΔE*ab, CIEDE2000). Batched and differentiable."""

from .colorimetry import ILLUMINANTS, OBSERVERS, cmfs, illuminant_spd, white_point_xy, white_point_xyz
from .convert import (
    lab_to_xyz,
    linear_srgb_to_srgb,
    spectrum_to_xyz,
    xyz_to_lab,
    xyz_to_linear_srgb,
    linear_srgb_to_xyz,
    xyz_to_srgb,
    xyz_weights,
)
from .difference import DELTA_E_METHODS, delta_e, delta_e_1976, delta_e_2000

__all__ = [
    "DELTA_E_METHODS",
    "ILLUMINANTS",
    "OBSERVERS",
    "cmfs",
    "delta_e",
    "delta_e_1976",
    "delta_e_2000",
    "illuminant_spd",
    "lab_to_xyz",
    "linear_srgb_to_srgb",
    "spectrum_to_xyz",
    "white_point_xy",
    "white_point_xyz",
    "xyz_to_lab",
    "xyz_to_linear_srgb",
    "linear_srgb_to_xyz",
    "xyz_to_srgb",
    "xyz_weights",
]
