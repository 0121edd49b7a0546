"""The colour of a thin film by name: :func:`thin_film_xyz` dispatches to ``thin_film_xyz_<method>``.

One signature for the family (colour-science's pattern: a registry whose keys are the function
suffixes). The smooth film under a directional light, and the rough (GGX) film under uniform
light, by the method the scene needs:

============  ==============================================  ===========================================
method        what                                            function
============  ==============================================  ===========================================
``fourier``   smooth film, Belcour–Barla's Fourier series      :func:`~torchirid.ibl.thin_film_xyz_fourier`
``uniform``   rough film (``alpha``) under uniform light:      :func:`~torchirid.ibl.thin_film_xyz_uniform`
              the quadrature reference
``fitted``    rough film (``alpha``) under uniform light:      :func:`~torchirid.ibl.thin_film_xyz_fitted`
              the fitted light-mixture table (fast)
============  ==============================================  ===========================================

Under an environment map: :func:`~torchirid.ibl.shade_thin_film_environment`; for a light
distribution of given mean and covariance: :func:`~torchirid.ibl.thin_film_xyz_filtered`.
"""

from __future__ import annotations

from .. import _checks
from .fitted import thin_film_xyz_fitted
from .fourier import thin_film_xyz_fourier
from .uniform import thin_film_xyz_uniform

__all__ = ["THIN_FILM_XYZ_METHODS", "thin_film_xyz"]

#: method name → function (:func:`thin_film_xyz`); the rough methods take ``alpha``
THIN_FILM_XYZ_METHODS = {
    "fourier": thin_film_xyz_fourier,
    "uniform": thin_film_xyz_uniform,
    "fitted": thin_film_xyz_fitted,
}
_ROUGH = ("uniform", "fitted")


def thin_film_xyz(cos_theta, n_film, thickness, n_substrate, *, alpha=None, method: str = "fourier",
                  n_incident=1.0, **options):
    r"""CIE XYZ of a thin film ``n_incident | n_film (thickness) | n_substrate`` by ``method``.

    Normalised as :func:`~torchirid.color.spectrum_to_xyz` (the perfect white has Y = 1).

    Args:
        cos_theta: cosine of the incidence (smooth film) or viewing (rough film) angle in the
            incident medium, in [0, 1]. Shape ``(*)``.
        n_film: film index (real, ≥ ``n_incident`` for ``"fourier"``).
        thickness: film thickness in nm (≥ 0).
        n_substrate: base index n + iκ (κ ≥ 0).
        alpha: GGX roughness in (0, 1] of a rough film: needed by ``"uniform"`` and ``"fitted"``,
            refused by ``"fourier"`` (the smooth film).
        method: a key of :data:`THIN_FILM_XYZ_METHODS`: ``"fourier"`` (default), ``"uniform"``,
            ``"fitted"``.
        n_incident: real index of the incident medium (default 1).
        **options: the method's own options (``observer``, ``illuminant``, ``polarization``,
            ``terms``, ``sensitivity``, ``masking``, ...: see its function).

    Returns:
        ``(*, 3)`` XYZ in the real dtype of the inputs; differentiable with respect to every input.

    Raises:
        ValueError: an unknown method (listing the valid ones), ``alpha`` missing for a rough
            method or given to ``"fourier"``, or the method's own argument errors.

    >>> import torch
    >>> cos_theta = torch.tensor([1.0, 0.5], dtype=torch.float64)
    >>> smooth = thin_film_xyz(cos_theta, 1.33, 300.0, 1.0)                 # a soap film in air
    >>> rough = thin_film_xyz(cos_theta, 1.33, 300.0, 1.0, alpha=0.2, method="fitted")
    >>> smooth.shape, rough.shape
    (torch.Size([2, 3]), torch.Size([2, 3]))
    """
    fn = THIN_FILM_XYZ_METHODS[_checks.check_choice(method, "method", THIN_FILM_XYZ_METHODS)]
    if method in _ROUGH:
        if alpha is None:
            raise ValueError(f"method {method!r} is a rough film: pass its GGX roughness alpha=")
        return fn(cos_theta, alpha, n_film, thickness, n_substrate, n_incident=n_incident, **options)
    if alpha is not None:
        raise ValueError("method 'fourier' is a smooth film and takes no alpha; for a rough film use "
                         "method='uniform' (reference) or method='fitted'")
    return fn(cos_theta, n_film, thickness, n_substrate, n_incident=n_incident, **options)
