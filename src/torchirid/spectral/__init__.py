"""Spectral integration of structural colour: Bragg mirror XYZ from exact spectra (sampled,
converged) or from piecewise-constant spectra on spectral landmarks (Fourneau et al. 2024 §3.2)."""

from .bragg_color import BRAGG_XYZ_METHODS, bragg_xyz
from .sampling import fringe_count, max_fringes, spectral_samples
from .correction import (
    PAPER_COEFFICIENTS,
    angular_correction,
    angular_correction_limit,
    angular_correction_reference,
    fitted_coefficients,
)
from .cumulative import box_integrals, cumulative_cmf_lut, shipped_cumulative_cmf_lut
from .envelope import bragg_xyz_envelope, envelope_weights, fringe_averaged_reflectance
from .landmarks import bragg_landmarks, dispersion_parts
from .piecewise import bragg_xyz_piecewise

__all__ = [
    "BRAGG_XYZ_METHODS",
    "PAPER_COEFFICIENTS",
    "angular_correction",
    "angular_correction_limit",
    "angular_correction_reference",
    "box_integrals",
    "bragg_landmarks",
    "bragg_xyz",
    "bragg_xyz_envelope",
    "bragg_xyz_piecewise",
    "cumulative_cmf_lut",
    "shipped_cumulative_cmf_lut",
    "dispersion_parts",
    "envelope_weights",
    "fitted_coefficients",
    "fringe_averaged_reflectance",
    "fringe_count",
    "max_fringes",
    "spectral_samples",
]
