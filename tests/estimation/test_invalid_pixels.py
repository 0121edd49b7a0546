"""Dead pixels and missing samples (issue 21, item 8): a pixel without a finite sample — NaN, as
``read_cube`` gives an ENVI header's ``data ignore value``, or ±inf — enters no score of
``estimate_film`` and is reported invalid; a missing sample of a valid pixel is left out of the sums.

Before the fix a dead pixel in the index sample gave a NaN misfit that every index-model score
summed: every BIC was NaN, ``min`` kept the first model ('constant'), the order hypotheses all
compared False (the first kept), and on ZnS the estimate went from n error 6e-4 / mean |d error|
0.06 nm to 0.042 / 115 nm with a warning advising ``index_model_name='auto'`` — which was in use.
"""

import math
import warnings

import pytest
import torch

from torchirid.estimation import estimate_film, film_metrics, refine_film, synthetic_cube

F64 = torch.float64


@pytest.mark.slow
def test_dead_pixels_leave_the_auto_estimate_unchanged():
    c = synthetic_cube("zns_500", height=6, width=6, seed=0, polarization="s")
    y = c.cube.clone()
    y[0, 0] = math.nan  # dead pixels: every angle and band ignored (NaN) or infinite
    y[3, 1] = math.inf
    y[5, 4, 0, 30] = math.inf  # one missing sample: the pixel stays valid
    kw = dict(index_model_name="auto", polarization="s")
    ref = estimate_film(c.cube, c.wavelength, c.cos_theta, 1.64, **kw)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        est = estimate_film(y, c.wavelength, c.cos_theta, 1.64, **kw)
    dead = torch.zeros(6, 6, dtype=torch.bool)
    dead[0, 0] = dead[3, 1] = True
    assert torch.equal(est.valid, ~dead) and ref.valid.all()
    for t in (est.thickness, est.rms, est.thickness_peak):
        assert t[dead].isnan().all() and t[~dead].isfinite().all()
    assert est.settings["invalid_pixels"] == 2 and est.settings["pixels_missing_samples"] == 1
    # every score is finite: the BIC chose like on the clean cube, the order hypotheses were compared
    sel = est.settings["index_selection"]
    assert ref.index_model == est.index_model == "cauchy3"
    assert all(math.isfinite(v["bic"]) and all(math.isfinite(s) for s in v["order_sse"].values()) for v in sel.values())
    assert all(v["order_sse"][f"{v['order_shift']:+.0f}"] == min(v["order_sse"].values()) for v in sel.values())
    assert abs(est.n - ref.n) < 2e-4  # (measured 5e-5; the dead-pixel run on the old code: 0.043)
    assert float((est.thickness - ref.thickness)[~dead].abs().max()) < 0.1  # nm (measured 0.015)
    m = film_metrics(est, c)
    assert m["valid_pixels"] == 34 and m["n_error"] < 0.002 and m["d_error_mean"] < 0.5
    assert all(math.isfinite(v) for v in m.values())


def test_a_cube_without_a_valid_pixel_is_refused():
    c = synthetic_cube("mgf2_400", height=2, width=2, seed=0)
    for bad in (math.nan, math.inf, -math.inf):
        with pytest.raises(ValueError, match="cube must have at least one pixel with a finite sample"):
            estimate_film(torch.full_like(c.cube, bad), c.wavelength, c.cos_theta, 1.64)


@pytest.mark.slow
def test_the_noise_warning_does_not_advise_auto_when_auto_was_used():
    c = synthetic_cube("zns_500", height=4, width=4, seed=0, polarization="s")
    with pytest.warns(RuntimeWarning, match="noise level") as rec:  # a wrong polarization: no model fits
        est = estimate_film(c.cube, c.wavelength, c.cos_theta, 1.64, index_model_name="auto", polarization="p")
    text = " ".join(str(w.message) for w in rec)
    assert est.settings["residual_to_noise"] > 3
    assert "index_model_name='auto'" not in text and "none of the index models" in text and "polarization" in text


def test_noise_advice_suggests_only_models_not_tried():
    from torchirid.estimation.noise import noise_advice

    assert "index_model_name='auto'" in noise_advice("constant", "constant") and "'cauchy3'" in noise_advice(
        "cauchy", "cauchy")
    for model, requested in (("cauchy3", "cauchy3"), ("constant", "auto"), ("cauchy3", "auto")):
        text = noise_advice(model, requested)
        assert "try index_model_name" not in text and "substrate index" in text


def test_refine_film_leaves_pixels_without_data_out():
    c = synthetic_cube("mgf2_400", height=6, width=6, seed=0, polarization="s")
    y = c.cube.clone()
    y[2, 3] = math.nan  # no data
    y[4, 4, 1, 10:30] = math.inf  # missing samples (the old code fitted this pixel 220 nm off)
    kw = dict(polarization="s", smoothness=1e-6, iterations=3)
    res = refine_film(y, c.wavelength, c.cos_theta, 1.64, c.thickness, 1.37, **kw)
    clean = refine_film(c.cube, c.wavelength, c.cos_theta, 1.64, c.thickness, 1.37, **kw)
    assert res.reordered == 0 == clean.reordered  # the empty pixel is no order change (old code: 2)
    assert math.isnan(float(res.thickness[2, 3])) and math.isnan(float(res.sse[2, 3]))
    ok = res.thickness.isfinite()
    assert int(ok.sum()) == 35 and abs(float(res.params[0] - clean.params[0])) < 1e-3
    assert float((res.thickness - clean.thickness)[ok].abs().max()) < 1.0
