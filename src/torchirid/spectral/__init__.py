"""Spectral integration of structural colour: Bragg mirror XYZ from exact spectra (sampled,
converged) or from piecewise-constant spectra on spectral landmarks (Fourneau et al. 2024 §3.2)."""

from .bragg_color import BRAGG_XYZ_METHODS, bragg_xyz
from .sampling import spectral_samples
from .correction import angular_correction, fitted_coefficients
from .cumulative import cumulative_cmf_lut, shipped_cumulative_cmf_lut
from .envelope import bragg_xyz_envelope
from .landmarks import bragg_landmarks
from .piecewise import bragg_xyz_piecewise

__all__ = [
    "BRAGG_XYZ_METHODS",
    "angular_correction",
    "bragg_landmarks",
    "bragg_xyz",
    "bragg_xyz_envelope",
    "bragg_xyz_piecewise",
    "cumulative_cmf_lut",
    "shipped_cumulative_cmf_lut",
    "fitted_coefficients",
    "spectral_samples",
]
