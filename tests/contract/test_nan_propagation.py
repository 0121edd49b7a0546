"""NaN inputs propagate (docs/conventions.md): one NaN entry of a batch gives NaN outputs for that entry,
the other entries stay exactly what they are alone, and nothing raises for the whole batch.

Regression tests for paths found to "fix" NaN (guarded square roots and masks of
the form ``where(x > 0, f(x), 0)``, which send NaN to the 0 branch) or to raise for the batch
(``int(NaN)`` / ``.long()`` of a NaN index). The optics core has its own in test_validation.py.
"""

from __future__ import annotations

import math

import torch

from tensors import F64, t64

NAN = float("nan")


def assert_nan_first_entry(out, ref):
    """Entry 0 (the NaN input) all NaN, entry 1 equal to its reference: the assertions of the tests below."""
    assert torch.isnan(out[0]).all(), out
    assert torch.allclose(out[1], ref, rtol=1e-12, atol=0, equal_nan=False), (out[1], ref)


def test_smith_g_nan_microfacet_normal():
    from torchirid.microfacet import smith_g

    z = t64([0.0, 0.0, 1.0])
    m = t64([[NAN, NAN, NAN], [0.1, 0.0, 1.0]])
    assert_nan_first_entry(smith_g(z, z, m, 0.2), smith_g(z, z, m[1], 0.2))


def test_he_torrance_infinite_roughness_does_not_raise():
    from torchirid.optics import he_torrance as ht

    out = ht.he_directional_diffuse(550.0, 0.8, 0.6, -0.9, t64([math.inf, 25.0]), 300.0, 1.5)
    assert torch.isfinite(out[1])
    assert float(out[1]) == float(ht.he_directional_diffuse(550.0, 0.8, 0.6, -0.9, t64(25.0), 300.0, 1.5))


def test_uniform_light_paths():
    from torchirid import ibl

    c, a = t64([NAN, 0.8]), t64([0.3, 0.3])
    kw = dict(bins=64, nodes=8)
    assert_nan_first_entry(ibl.thin_film_xyz_uniform(c, a, 1.33, 450.0, 1.5, **kw),
           ibl.thin_film_xyz_uniform(c[1:], a[1:], 1.33, 450.0, 1.5, **kw)[0])
    assert_nan_first_entry(ibl.thin_film_xyz_uniform(t64([0.8, 0.8]), t64([NAN, 0.3]), 1.33, 450.0, 1.5, **kw),
           ibl.thin_film_xyz_uniform(c[1:], a[1:], 1.33, 450.0, 1.5, **kw)[0])
    albedo = ibl.uniform_light_moments(c, a, nodes=8)[0]
    assert_nan_first_entry(albedo, ibl.uniform_light_moments(c[1:], a[1:], nodes=8)[0][0])


def test_prefiltered_sensitivity_table_paths():
    from torchirid.ibl import thin_film_xyz_filtered, thin_film_xyz_fitted, thin_film_xyz_fourier

    d = t64([NAN, 300.0])
    cov = 0.01 * torch.eye(3, dtype=F64).expand(2, 3, 3)
    wo, mu = t64([[0.0, 0.0, 1.0]] * 2), t64([[0.1, 0.0, 0.9]] * 2)
    assert_nan_first_entry(thin_film_xyz_filtered(wo, mu, cov, 1.4, d, 1.5, sensitivity="lut"),
           thin_film_xyz_filtered(wo[1], mu[1], cov[1], 1.4, d[1], 1.5, sensitivity="lut"))
    c = t64([0.8, 0.8])
    assert_nan_first_entry(thin_film_xyz_fitted(c, 0.3, 1.33, d, 1.5, sensitivity="lut"),
           thin_film_xyz_fitted(c[1], 0.3, 1.33, d[1], 1.5, sensitivity="lut"))
    assert_nan_first_entry(thin_film_xyz_fourier(c, 1.33, d, 1.5, sensitivity="lut"),
           thin_film_xyz_fourier(c[1], 1.33, d[1], 1.5, sensitivity="lut"))


def test_bragg_landmarks_and_angular_correction_reference():
    from torchirid.spectral import correction
    from torchirid.spectral.landmarks import bragg_landmarks

    w0, w1 = 2 * math.pi / 780, 2 * math.pi / 380
    out = bragg_landmarks(w0, w1, t64([NAN, 200.0]), t64([150.0, 150.0]), t64([0.08, 0.08]))
    ref = bragg_landmarks(w0, w1, t64([200.0]), t64([150.0]), t64([0.08]))
    for key, v in out.items():
        if key == "m":
            continue
        assert torch.isnan(v[0]).all(), key
        keep = ~torch.isnan(v[1])
        assert torch.equal(v[1][keep], ref[key][0][~torch.isnan(ref[key][0])]), key
    c = t64([NAN, 0.8])
    assert_nan_first_entry(correction.angular_correction_reference(c, 1.0, 1.5),
           correction.angular_correction_reference(c[1:], 1.0, 1.5)[0])


def _layered(coated):
    import torchirid.layered as L

    n1 = 1.3 if coated else 1.0  # a host index ≠ 1 implies the smooth coating on top
    return L.LayeredBragg([L.RoughBraggLayer(n1, 1.5, 150.0, 150.0, 6, 0.1)])


def test_layered_single_reflection_paths():
    import pytest
    import torchirid.layered as L

    lam = t64([500.0])
    good = t64([0.3, 0.0, math.sqrt(0.91)])
    z = t64([0.0, 0.0, 1.0])
    wi = torch.stack([torch.full((3,), NAN, dtype=F64), good])
    for coated in (False, True):
        s = _layered(coated)
        assert_nan_first_entry(L.single_reflection_brdf(lam, wi, z, s), L.single_reflection_brdf(lam, good, z, s))
        assert_nan_first_entry(L.single_reflection_pdf(lam, wi, z, s), L.single_reflection_pdf(lam, good, z, s))
        assert_nan_first_entry(L.single_reflection_brdf(lam, z, wi, s), L.single_reflection_brdf(lam, z, good, s))
        u = t64([[NAN, 0.3, 0.3], [0.3, 0.3, 0.3]])
        wo, pdf = L.sample_single_reflection(lam, good.expand(2, 3), s, u)
        wo1, pdf1 = L.sample_single_reflection(lam, good, s, u[1])
        assert_nan_first_entry(wo, wo1)
        assert_nan_first_entry(pdf, pdf1)
        f, err = L.montecarlo_brdf(lam, wi, z, s, samples=8, transmission="microfacet")
        assert torch.isnan(f[0]).all() and torch.isnan(err[0]).all() and torch.isfinite(f[1]).all()
        # the wavelength grid is shared by all samples: a NaN there is refused, not spread
        with pytest.raises(ValueError, match="wavelength"):
            L.single_reflection_brdf(t64([NAN, 500.0]), good, z, s)
    w = L.transmission.transmission_weight(t64([[NAN, 0.6], [0.4, 0.6]]), 0.7, 0.1)
    assert torch.isnan(w[0]).all() and torch.allclose(w[1], L.transmission.transmission_weight(t64([[0.4, 0.6]]), 0.7, 0.1)[0])


def test_estimation_pixels_without_data_and_index_fit():
    import torchirid.estimation as est

    sc = est.synthetic_cube("mgf2_400", height=2, width=2, seed=0)
    cube = sc.cube.clone()
    cube[0, 0] = NAN  # a pixel without a single finite sample
    pk = est.peak_method(cube, sc.wavelength, sc.cos_theta, 1.64)
    assert torch.isnan(pk.thickness[0, 0]) and torch.isnan(pk.sse[0, 0])
    assert torch.isfinite(pk.thickness.reshape(-1)[1:]).all()
    fe = est.estimate_film(cube, sc.wavelength, sc.cos_theta, 1.64)
    assert torch.isnan(fe.thickness[0, 0]) and torch.isnan(fe.rms[0, 0])
    assert torch.isfinite(fe.thickness.reshape(-1)[1:]).all() and math.isfinite(fe.n)
    # the empty pixel's NaN peak thickness must not make the index search distrust the peaks
    sc4 = est.synthetic_cube("mgf2_400", height=4, width=4, seed=0)
    cube4 = sc4.cube.clone()
    cube4[0, 0] = NAN
    assert est.estimate_film(cube4, sc4.wavelength, sc4.cos_theta, 1.64).settings["index_start"] == "peaks"
    w = torch.linspace(400.0, 720.0, 9, dtype=F64)
    n = est.dispersion.zns_index(w)
    n[3] = NAN
    assert torch.isnan(est.fit_index_model(w, n, "cauchy3")).all()
