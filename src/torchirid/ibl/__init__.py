"""Image-based lighting of thin films: Belcour–Barla Fourier colour (Kneiphof et al. 2019)."""

from .fourier import (  # noqa: F401
    FOURIER_SENSITIVITY_BUILDER,
    SENSITIVITY_MODES,
    fourier_sensitivity_lut,
    prefiltered_sensitivity_lut,
    fourier_sensitivity,
    fourier_sensitivity_exact,
    shipped_fourier_sensitivity_lut,
    fourier_sensitivity_path,
    prefiltered_fourier_sensitivity,
    thin_film_fourier_terms,
    thin_film_xyz_fourier,
)
from .dfg import DFG_BUILDER, DFG_SHIPPED, dfg_lut, shipped_dfg_lut  # noqa: F401
from .filtered import filtered_thin_film_xyz, gaussian_path_thin_film_xyz  # noqa: F401
from .fitted import (  # noqa: F401
    DEFAULT_QUANTILES,
    LIGHT_MIXTURE_BUILDER,
    light_mixture_lut,
    fitted_thin_film_xyz,
    light_mixture,
    light_mixture_path,
    shipped_light_mixture_lut,
)
from .uniform import (  # noqa: F401
    cos_theta1_distribution,
    path_difference_moments,
    uniform_light_moments,
    uniform_lobe_quadrature,
    uniform_thin_film_xyz,
)
from .prefilter import (  # noqa: F401
    MOMENT_CHANNELS,
    PREFILTERED_ENVIRONMENT_BUILDER,
    PrefilteredEnvironment,
    equirect_directions,
    light_moments_to_mean_cov,
    load_environment,
    prefilter_environment,
    synthetic_environment,
)
from .shading import SHADING_METHODS, SHADING_OUTPUTS, shade_thin_film_environment  # noqa: F401

__all__ = [name for name in dir() if not name.startswith("_")]
