"""The fits differentiate internally (L-BFGS on scatterograms, Levenberg–Marquardt Jacobians):
called inside a caller's ``torch.inference_mode()`` (how inference pipelines and LUT scripts
run) they must still work, and give what they give outside it. Inference-mode first calls that
fill caches, followed by autograd calls, are tested over the whole API in contract/test_nan_harness.py."""

from __future__ import annotations

import torch

import torchirid.estimation as est
from torchirid.fitting import match_scatterogram, render_targets
from torchirid.presets import jewel_beetle

F64 = torch.float64


def test_film_estimation_inside_inference_mode():
    sc = est.synthetic_cube("mgf2_400", height=2, width=2, seed=0)
    ref = est.estimate_film(sc.cube, sc.wavelength, sc.cos_theta, 1.64)
    with torch.inference_mode():
        cube = sc.cube.clone()  # an inference tensor, as a pipeline inside inference mode would hand over
        fe = est.estimate_film(cube, sc.wavelength, sc.cos_theta, 1.64)
        rf = est.refine_film(cube, sc.wavelength, sc.cos_theta, 1.64, ref.thickness, ref.params,
                             index_model_name=ref.index_model, iterations=2)
    assert fe.n == ref.n and torch.equal(fe.thickness, ref.thickness)
    assert torch.isfinite(rf.thickness).all()
    terms = est.measurement.band_terms(sc.wavelength, sc.cos_theta[:, None], 1.38, 1.64)
    y, d = sc.cube.reshape(-1, *sc.cube.shape[-2:]), ref.thickness.reshape(-1)
    dterms = [torch.ones(t.shape + (1,), dtype=F64) for t in terms]
    r0 = est.gauss_newton.lm_jacobian(y, d, terms, dterms)
    with torch.inference_mode():
        r1 = est.gauss_newton.lm_jacobian(y, d, terms, dterms)
    assert all(torch.allclose(a, b) for a, b in zip(r0, r1))


def test_scatterogram_match_inside_inference_mode():
    n = torch.get_num_threads()
    torch.set_num_threads(1)  # (hundreds of small renders: see tests/fitting)
    try:
        lam = torch.linspace(380.0, 780.0, 41, dtype=F64)
        incs = [(0.0, 0.0), (40.0, 0.0)]
        target = render_targets(jewel_beetle("green"), incs, resolution=12, wavelength=lam)
        kw = dict(incident_deg=incs, n1=1.59, cells=(8,), period_range=None, wavelength=lam,
                  init={"period": 166.0, "delta": 0.51, "dn": 0.08, "alpha": 0.07}, short_iter=4, max_iter=6)
        ref = match_scatterogram(target, **kw)
        with torch.inference_mode():
            fit = match_scatterogram(target.clone(), **kw)
        assert fit.period == ref.period and fit.alpha == ref.alpha
    finally:
        torch.set_num_threads(n)
