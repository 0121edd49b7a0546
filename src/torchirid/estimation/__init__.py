"""Thin-film index and thickness from hyperspectral cubes (Kobayashi et al., "BRDF estimation of
structural color object by using hyper spectral image").

Forward model (:mod:`.measurement`), index models (:mod:`.dispersion`), seeded synthetic cubes
(:mod:`.synthetic`), the peak-wavelength method eq. 8–14 (:mod:`.peaks`), the joint
Levenberg–Marquardt refinement (:mod:`.refine`), the whole pipeline and Table-1 metrics
(:mod:`.estimate`), cube files (:mod:`.cube_io`) and the ``fit-film`` command (:mod:`.cli`).
"""

from .dispersion import INDEX_MODELS, fit_index_model, index_model, index_model_size, sellmeier_index, zns_index
from .estimate import INDEX_CHOICES, FilmEstimate, estimate_film, film_metrics, model_cube, noise_level
from .measurement import (
    airy_terms,
    band_nodes,
    band_reflectance,
    band_reflectance_fast,
    band_terms,
    band_variance,
    reflectance_from_terms,
)
from .peaks import (
    PeakResult,
    detect_extrema,
    index_from_peak_pair,
    index_from_tracks,
    peak_method,
    thickness_candidates,
    track_extrema,
)
from .refine import RefineResult, d_only_gauss_newton, lm_jacobian, refine_film, scan_index
from .synthetic import SAMPLES, FilmSample, SyntheticCube, synthetic_cube

__all__ = [
    "INDEX_MODELS", "fit_index_model", "index_model", "index_model_size", "sellmeier_index", "zns_index",
    "INDEX_CHOICES", "FilmEstimate", "estimate_film", "film_metrics", "model_cube", "noise_level",
    "airy_terms", "band_nodes", "band_reflectance", "band_reflectance_fast", "band_terms", "band_variance",
    "reflectance_from_terms",
    "PeakResult", "detect_extrema", "index_from_peak_pair", "index_from_tracks", "peak_method",
    "thickness_candidates", "track_extrema",
    "RefineResult", "d_only_gauss_newton", "lm_jacobian", "refine_film", "scan_index",
    "SAMPLES", "FilmSample", "SyntheticCube", "synthetic_cube",
]
