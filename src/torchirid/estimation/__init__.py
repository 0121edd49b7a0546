"""Thin-film index and thickness from hyperspectral cubes (Kobayashi et al., "BRDF estimation of
structural color object by using hyper spectral image").

Forward model (:mod:`.measurement`), index models (:mod:`.dispersion`), seeded synthetic cubes
(:mod:`.synthetic`), residuals of the band model shared by the fits (:mod:`.residuals`), the
peak-wavelength method eq. 8–14 (:mod:`.peaks`), the joint Levenberg–Marquardt refinement
(:mod:`.refine`), the whole pipeline and Table-1 metrics (:mod:`.estimate`) and cube files
(:mod:`.cube_io`). The ``torchirid fit-film`` command wraps :func:`estimate_film`.

``polarization`` defaults to ``"unpolarized"`` here as in the rest of the library — for
:func:`synthetic_cube` and :func:`estimate_film` alike. Kobayashi et al.'s camera sees only the
s wave through a polarizer (§5.1): their setup is ``polarization="s"``, to be passed to both.
"""

from .cube_io import Cube, read_cube, write_envi, write_npz
from .dispersion import (INDEX_MODELS, REFERENCE_WAVELENGTH, fit_index_model, index_model, index_model_size,
                         sellmeier_index, zns_index)
from .estimate import INDEX_CHOICES, FilmEstimate, estimate_film, film_metrics, model_cube, noise_level
from .measurement import (
    PASSBANDS,
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
    select_candidates,
    thickness_candidates,
    track_extrema,
)
from .refine import RefineResult, d_only_gauss_newton, grid_scan, lm_jacobian, model_terms, refine_film, scan_index
from .residuals import cube_sse
from .synthetic import DEFAULT_ANGLES, SAMPLES, FilmSample, SyntheticCube, default_wavelengths, synthetic_cube

__all__ = [
    "Cube", "read_cube", "write_envi", "write_npz",
    "INDEX_MODELS", "REFERENCE_WAVELENGTH", "fit_index_model", "index_model", "index_model_size", "sellmeier_index",
    "zns_index",
    "INDEX_CHOICES", "FilmEstimate", "estimate_film", "film_metrics", "model_cube", "noise_level",
    "PASSBANDS", "airy_terms", "band_nodes", "band_reflectance", "band_reflectance_fast", "band_terms",
    "band_variance", "reflectance_from_terms",
    "PeakResult", "detect_extrema", "index_from_peak_pair", "index_from_tracks", "peak_method", "select_candidates",
    "thickness_candidates", "track_extrema",
    "RefineResult", "d_only_gauss_newton", "grid_scan", "lm_jacobian", "model_terms", "refine_film", "scan_index",
    "cube_sse",
    "DEFAULT_ANGLES", "SAMPLES", "FilmSample", "SyntheticCube", "default_wavelengths", "synthetic_cube",
]
