"""Thin-film index and thickness from hyperspectral cubes (Kobayashi et al., "BRDF estimation of
structural color object by using hyper spectral image").

Forward model (:mod:`.measurement`), index models (:mod:`.dispersion`), seeded synthetic cubes
(:mod:`.synthetic`), residuals of the band model shared by the fits (:mod:`.residuals`), the
peak-wavelength method eq. 8–14 (:mod:`.peaks`), the joint Levenberg–Marquardt refinement
(:mod:`.refine`), the whole pipeline (:mod:`.estimate`: its checked problem :mod:`.problem`, the
index search on a pixel sample :mod:`.index_search`, the per-pixel thickness map
:mod:`.thickness_map`), the data's noise level (:mod:`.noise`), the Table-1 metrics
(:mod:`.metrics`) and cube files (:mod:`.cube_io`). The ``torchirid fit-film`` command wraps :func:`estimate_film`.

``polarization`` defaults to ``"unpolarized"`` here as in the rest of the library — for
:func:`synthetic_cube` and :func:`estimate_film` alike. Kobayashi et al.'s camera sees only the
s wave through a polarizer (§5.1): their setup is ``polarization="s"``, to be passed to both.
"""

from .cube_io import Cube, read_cube, write_envi, write_npz
from .dispersion import INDEX_MODELS, fit_index_model, index_model
from .estimate import FilmEstimate, estimate_film
from .metrics import film_metrics, model_cube
from .noise import noise_level
from .peaks import PeakResult, peak_method
from .refine import RefineResult, refine_film
from .synthetic import FilmSample, SyntheticCube, synthetic_cube

__all__ = [
    # cube files
    "Cube",
    "read_cube",
    "write_envi",
    "write_npz",
    # index models
    "INDEX_MODELS",
    "fit_index_model",
    "index_model",
    # the method: the peak stage (eq. 8-14), the joint refinement, the whole pipeline
    "PeakResult",
    "peak_method",
    "RefineResult",
    "refine_film",
    "FilmEstimate",
    "estimate_film",
    "film_metrics",
    "model_cube",
    "noise_level",
    # synthetic cubes of the paper's samples
    "FilmSample",
    "SyntheticCube",
    "synthetic_cube",
]
