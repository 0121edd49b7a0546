"""Spectral integration of structural colour: Bragg mirror XYZ (exact spectra; piecewise to come)."""

from .bragg_color import BRAGG_XYZ_METHODS, bragg_xyz, spectral_samples

__all__ = ["BRAGG_XYZ_METHODS", "bragg_xyz", "spectral_samples"]
