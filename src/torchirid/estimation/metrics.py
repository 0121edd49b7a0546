r"""Scoring a film estimate: its re-rendered cube and the Table-1 metrics against a synthetic truth.

:func:`model_cube` renders the noise-free band reflectance of an estimate (index parameters and
per-pixel thickness) with the fast band model; :func:`film_metrics` scores an estimate against a
:class:`~torchirid.estimation.SyntheticCube` as in Kobayashi et al.'s Table 1 (n error, mean
|d error|, mean ΔE*ab over angles under D65 / CIE 1931 2°, spectral RMSE).
"""

from __future__ import annotations

import math

import torch

from ..color import delta_e_1976, spectrum_to_xyz, xyz_to_lab
from ._validation import real_index, tensor
from .estimate import FilmEstimate
from .gauss_newton import model_terms
from .measurement import band_reflectance_fast

__all__ = ["film_metrics", "model_cube"]


def model_cube(params, index_model_name, thickness, wavelength, cos_theta, n_substrate, **kw) -> torch.Tensor:
    """Noise-free band reflectance ``(*, A, B)`` of an estimate (fast band model), for the metrics;
    dtype and device follow ``thickness``.

    Args:
        params: ``(K,)`` parameters of the index model ``index_model_name``
            (:func:`~torchirid.estimation.index_model`).
        thickness: ``(*)`` film thickness (nm); wavelength ``(B,)`` band centres (nm);
            cos_theta ``(A,)``; n_substrate: real.
        kw: the band model of ``band_terms()`` (``bandwidth``,
            ``passband``, ``polarization``, ``n_incident``).

    Example (a 4 × 4 image of a 400 nm MgF₂ film, n = 1.37, on PET at 3 angles, 400–720 nm):
        >>> import torch
        >>> w = torch.arange(400.0, 721.0, 4.0, dtype=torch.float64)  # nm
        >>> cos_t = torch.cos(torch.deg2rad(torch.tensor([10.0, 30.0, 50.0], dtype=torch.float64)))
        >>> d = torch.full((4, 4), 400.0, dtype=torch.float64)  # nm
        >>> R = model_cube(torch.tensor([1.37], dtype=torch.float64), "constant", d, w, cos_t, 1.64)
        >>> tuple(R.shape), round(float(R[0, 0, 0, 37]), 4)  # (H, W, A, B); R at 10°, 548 nm
        ((4, 4, 3, 81), 0.0586)
    """
    d = tensor(thickness)
    lam = torch.as_tensor(wavelength, dtype=d.dtype, device=d.device)
    c = torch.as_tensor(cos_theta, dtype=d.dtype, device=d.device)
    terms = model_terms(params, index_model_name, lam, c, real_index(n_substrate, "n_substrate", d), **kw)
    # the polarization axis leads the terms: pixels go after it, angles and bands last
    R = band_reflectance_fast(tuple(t[:, None] for t in terms), d.reshape(1, -1, 1, 1))
    return R.reshape(*d.shape, *R.shape[-2:])


def film_metrics(estimate: FilmEstimate, truth) -> dict:
    """Table-1 metrics of an estimate against a :class:`~torchirid.estimation.SyntheticCube`.

    n error at 589.3 nm; mean and max |d error| (nm); mean ΔE*ab (CIE 1976, D65, CIE 1931 2°)
    between the true noise-free band spectra and the re-rendered estimate, averaged over
    pixels and angles; spectral RMSE (reflectance units) averaged the same way. Every average
    runs over the estimate's valid pixels (:meth:`FilmEstimate.valid_pixels`; ``valid_pixels``
    counts them): a dead pixel has no estimate to score.

    Returns a dict of floats (and ``valid_pixels``, an int): ``n_true``, ``n_est``, ``n_error``,
    ``n_peak``, ``d_true_mean``, ``d_est_mean``, ``d_error_mean``, ``d_error_max``,
    ``d_error_peak_mean`` (nm), ``delta_e_mean``, ``rmse_mean``, ``time_s`` (the estimate's).

    Example (a 2 × 2 pixel synthetic MgF₂ cube; few iterations, for speed):
        >>> from torchirid.estimation import estimate_film, synthetic_cube
        >>> c = synthetic_cube("mgf2_400", height=2, width=2, seed=1)
        >>> est = estimate_film(c.cube, c.wavelength, c.cos_theta, 1.64, thickness_range=(300.0, 500.0),
        ...                     iterations=2, final_iterations=0)
        >>> m = film_metrics(est, c)
        >>> round(m["n_error"], 2), m["valid_pixels"], m["d_error_max"] < 1.0, m["delta_e_mean"] < 0.5
        (0.0, 4, True, True)
    """
    kw = {k: estimate.settings[k] for k in ("bandwidth", "passband", "polarization", "n_incident")}
    ok = estimate.valid_pixels()
    est = model_cube(estimate.params, estimate.index_model, estimate.thickness[ok], truth.wavelength,
                     truth.cos_theta, truth.sample.n_substrate, **kw)
    clean = truth.clean[ok]
    lab_t = xyz_to_lab(spectrum_to_xyz(clean, truth.wavelength))
    lab_e = xyz_to_lab(spectrum_to_xyz(est, truth.wavelength))
    de = delta_e_1976(lab_t, lab_e)
    rmse = ((est - clean) ** 2).mean(-1).sqrt()
    d_true = truth.thickness[ok]
    err = (estimate.thickness[ok] - d_true).abs()
    return {
        "n_true": truth.sample.n_reference,
        "n_est": estimate.n,
        "n_error": abs(estimate.n - truth.sample.n_reference),
        "n_peak": estimate.n_peak,
        "valid_pixels": int(ok.sum()),
        "d_true_mean": float(d_true.mean()),
        "d_est_mean": float(estimate.thickness[ok].mean()),
        "d_error_mean": float(err.mean()),
        "d_error_max": float(err.max()),
        "d_error_peak_mean": float((estimate.thickness_peak[ok] - d_true).abs().mean()),
        "delta_e_mean": float(de.mean()),
        "rmse_mean": float(rmse.mean()),
        "time_s": float(estimate.timings.get("total", math.nan)),
    }
