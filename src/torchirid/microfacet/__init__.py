"""Microfacet theory: the isotropic GGX (Trowbridge–Reitz) distribution, Smith masking, and
a microfacet BRDF that takes any reflectance function (Fourneau et al. 2024 §4.1, eq. 17–19)."""

from .brdf import MicrofacetBRDF, microfacet_brdf
from .ggx import ggx_d, ggx_vndf_pdf, reflect, sample_ggx_vndf, smith_g, smith_g1, smith_lambda

__all__ = [
    "MicrofacetBRDF",
    "ggx_d", "ggx_vndf_pdf", "reflect", "sample_ggx_vndf", "smith_g", "smith_g1", "smith_lambda",
    "microfacet_brdf",
]
