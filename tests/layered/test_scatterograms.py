"""torchirid.layered.scatterograms, the scatterogram forward model: angular mapping,
illuminations, symmetry, closed forms, gradients, precision."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

import torchirid as ti
from torchirid import layered
from torchirid.color import xyz_weights
from torchirid.layered import LayeredBragg, RoughBraggLayer, single_reflection_brdf
from torchirid.presets import jewel_beetle
from torchirid.layered.scatterograms import _brdf_kwargs, _white_profile

F64 = torch.float64
LAM = torch.tensor([450.0, 550.0, 650.0], dtype=F64)
FAST = dict(wavelength=LAM, lobe_nodes=(12, 8))
# one layer over a black base uses no transmissivity τ: skip its 361-angle filter table (seconds per α)
NO_TAU = dict(transmissivity_angles=2)


@pytest.mark.parametrize("projection", layered.PROJECTIONS)
def test_circles_geometry(projection):
    theta = torch.deg2rad(torch.tensor([0.0, 5.0, 30.0, 60.0, 90.0], dtype=F64))
    rho = layered.projection_radius(theta, projection)
    assert rho[0] == 0 and abs(float(rho[-1]) - 1.0) < 1e-15 and bool((rho.diff() > 0).all())
    torch.testing.assert_close(layered.scatterograms.projection_theta(rho, projection), theta, atol=1e-12, rtol=0)
    expected = {"equidistant": 1 / 3, "orthographic": 0.5, "equal_area": math.sqrt(2) * math.sin(math.radians(15))}
    assert abs(float(rho[2]) - expected[projection]) < 1e-12
    # pixels whose centre lies on the 30° circle look at θ = 30°
    d, mask = layered.scatterogram_directions(201, projection=projection)
    c = (2 * torch.arange(201, dtype=F64) + 1) / 201 - 1
    y, x = torch.meshgrid(-c, c, indexing="ij")
    on = ((x * x + y * y).sqrt() - float(rho[2])).abs() < 0.5 / 201
    assert int(on.sum()) > 20
    theta_px = torch.rad2deg(torch.acos(d[on][:, 2]))
    dtheta = 90.0 / 201 * (3 if projection != "equidistant" else 1)  # half a pixel, projection's slope
    assert float((theta_px - 30.0).abs().max()) < dtheta


def test_directions_and_mask():
    d, mask = layered.scatterogram_directions(8)
    assert d.shape == (8, 8, 3) and mask.shape == (8, 8) and mask.dtype == torch.bool
    assert int(mask.sum()) == 52  # pixel centres within the unit disc on an 8 × 8 grid
    torch.testing.assert_close(torch.linalg.vector_norm(d[mask], dim=-1), torch.ones(52, dtype=F64))
    assert bool(torch.isnan(d[~mask]).all()) and bool((d[mask][:, 2] >= 0).all())
    # column → +x, row 0 → +y
    assert d[4, 7, 0] > 0.9 and d[0, 4, 1] > 0.9


def test_shapes_mask_and_white_values():
    sg = layered.scatterogram(jewel_beetle("green"), resolution=8, **FAST)
    assert sg.xyz.shape == (8, 8, 3) and sg.xyz.dtype == F64 and sg.incident_deg is None
    assert bool((sg.xyz[~sg.mask] == 0).all())
    inside = sg.xyz[sg.mask]
    assert bool(torch.isfinite(inside).all()) and bool((inside[:, 1] > 0).all()) and bool((inside[:, 1] < 1).all())
    assert sg.params["illumination"] == "white" and sg.params["layers"][0]["cells"] == 8


def test_bad_arguments():
    s = jewel_beetle("red")
    for kw, word in [({"projection": "fisheye"}, "projection"), ({"incident_deg": (95.0, 0.0)}, "incident_deg"),
                     ({"incident_deg": 30.0}, "incident_deg"), ({"resolution": 0}, "resolution"),
                     ({"lobe_nodes": (0, 4)}, "lobe_nodes"), ({"profile_angles": 1}, "profile_angles")]:
        with pytest.raises(ValueError, match=word):
            layered.scatterogram(s, **kw)
    with pytest.raises(ValueError, match="structure"):
        layered.scatterogram("green")


def test_normal_incidence_is_rotationally_symmetric():
    s = jewel_beetle("purple")
    sg = layered.scatterogram(s, incident_deg=(0.0, 0.0), resolution=12, wavelength=LAM)
    img = sg.xyz
    for k in (1, 2, 3):
        torch.testing.assert_close(torch.rot90(img, k, dims=(0, 1)), img, rtol=1e-9, atol=1e-12)
    torch.testing.assert_close(img.flip(1), img, rtol=1e-9, atol=1e-12)
    # and a pixel against the BRDF at its direction, off the pixel grid's symmetry axes
    wo = sg.directions[3, 2]
    f = single_reflection_brdf(LAM, torch.tensor([0.0, 0.0, 1.0], dtype=F64), wo[None], s, **NO_TAU)[0]
    torch.testing.assert_close(img[3, 2], f @ xyz_weights(LAM))


def test_beam_peaks_at_the_mirror_direction():
    sg = layered.scatterogram(jewel_beetle("green"), incident_deg=(30.0, 0.0), resolution=45, wavelength=LAM)
    Y = sg.xyz[..., 1]
    peak = sg.directions.reshape(-1, 3)[int(Y.argmax())]
    mirror = torch.tensor([-math.sin(math.radians(30)), 0.0, math.cos(math.radians(30))], dtype=F64)
    assert math.degrees(math.acos(float((peak * mirror).sum()))) < 90.0 / 45 * 1.5  # within 1.5 pixels
    # φ_i = 90° rotates the image by 90° (the beam comes from +y; the spot is at −y)
    sg90 = layered.scatterogram(jewel_beetle("green"), incident_deg=(30.0, 90.0), resolution=45, wavelength=LAM)
    torch.testing.assert_close(torch.rot90(sg.xyz, 1, dims=(0, 1)), sg90.xyz, rtol=1e-8, atol=1e-10)


def test_white_centre_matches_one_dimensional_integral():
    # at θo = 0 the integrand depends on θi only: L = 2π ∫ f_r(θi) cos θi sin θi dθi (dense trapezoid)
    s = jewel_beetle("red")
    sg = layered.scatterogram(s, resolution=7, wavelength=LAM)
    t = torch.linspace(0.0, math.pi / 2, 20001, dtype=F64)  # the GGX tail holds ~2.5 % beyond θi = 0.6
    wi = torch.stack([torch.sin(t), torch.zeros_like(t), torch.cos(t)], -1)
    f = single_reflection_brdf(LAM, wi, torch.tensor([0.0, 0.0, 1.0], dtype=F64), s, **NO_TAU)
    g = f * (torch.cos(t) * torch.sin(t) * 2 * math.pi).unsqueeze(-1)
    ref = torch.trapezoid(g, t, dim=0) @ xyz_weights(LAM)
    torch.testing.assert_close(sg.xyz[3, 3], ref, rtol=3e-3, atol=0)


def test_white_lambertian_closed_form():
    # a layer that reflects nothing (n1 = n2 = 1): f_r = ρd/π G1(i) G1(o) (τ = ∫ F_α = G1, app. C), so
    # the directional albedo is ρd G1(o) · 2∫ G1(μ) μ dμ — checks the cosine rule and the MIS weights
    a, rho = 0.3, 0.8
    s = LayeredBragg([RoughBraggLayer(1.0, 1.0, 100.0, 100.0, 2, a)], base_albedo=rho)
    theta = torch.tensor([0.0, 0.5, 1.0, 1.4], dtype=F64)
    got = _white_profile(s, theta, LAM, _brdf_kwargs(s, "exact", 19), (12, 8), (24, 16))

    def g1(mu):
        tan2 = (1 - mu * mu) / (mu * mu)
        return 2.0 / (1.0 + torch.sqrt(1.0 + a * a * tan2))

    x, w = np.polynomial.legendre.leggauss(200)
    mu = torch.as_tensor(0.5 * (x + 1), dtype=F64)
    hemi = float((torch.as_tensor(0.5 * w, dtype=F64) * g1(mu) * mu).sum() * 2)
    ref = rho * g1(torch.cos(theta)) * hemi
    torch.testing.assert_close(got, ref.unsqueeze(-1).expand_as(got), rtol=2e-3, atol=0)


def test_gradients_flow_to_every_layer_parameter():
    p = {k: torch.tensor(v, dtype=F64, requires_grad=True)
         for k, v in dict(n1=1.6, n2=1.68, d1=93.1, d2=96.9, alpha=0.05).items()}

    def white(n1, n2, d1, d2, alpha):
        s = LayeredBragg([RoughBraggLayer(n1, n2, d1, d2, 8, alpha, n_incident=1.0)])
        return layered.scatterogram(s, resolution=3, profile_angles=3, wavelength=LAM, lobe_nodes=(4, 4)).xyz

    out = white(**p)
    out.sum().backward()
    for k, v in p.items():
        assert v.grad is not None and math.isfinite(float(v.grad)) and float(v.grad) != 0.0, k
    args = tuple(p[k] for k in ("n2", "d1"))
    assert torch.autograd.gradcheck(lambda n2, d1: white(p["n1"].detach(), n2, d1, p["d2"].detach(),
                                                         p["alpha"].detach()), args, eps=1e-6, atol=1e-6, rtol=1e-4)


def test_gradcheck_beam_in_thickness_and_incidence():
    d2 = torch.tensor(81.6, dtype=F64, requires_grad=True)
    theta = torch.tensor(20.0, dtype=F64, requires_grad=True)

    def beam(d2, theta):
        s = LayeredBragg([RoughBraggLayer(1.59, 1.67, 78.4, d2, 8, 0.05, n_incident=1.0)])
        return layered.scatterogram(s, incident_deg=(theta, 0.0), resolution=4, wavelength=LAM).xyz

    assert torch.autograd.gradcheck(beam, (d2, theta), eps=1e-6, atol=1e-6, rtol=1e-4)


def test_float32_follows_the_wavelengths():
    sg = layered.scatterogram(jewel_beetle("green"), resolution=5, wavelength=LAM.float(), lobe_nodes=(12, 8))
    ref = layered.scatterogram(jewel_beetle("green"), resolution=5, **FAST)
    assert sg.xyz.dtype == torch.float32
    torch.testing.assert_close(sg.xyz.double(), ref.xyz, rtol=1e-3, atol=1e-5)


@pytest.mark.parametrize("illumination", ["white", "beam"])
def test_brdf_blocks_follow_the_chunk_knob(illumination, monkeypatch):
    """The BRDF is called on blocks of torchirid.options(chunk_size=...) // wavelengths direction
    pairs; None: all pairs in one call. Pairs are independent: the same image."""
    from torchirid.layered import scatterograms

    kw = FAST if illumination == "white" else dict(wavelength=LAM, incident_deg=(30.0, 0.0))
    pairs = []
    real = scatterograms._single_reflection_brdf  # (the BRDF's body: the render checked its arguments)

    def spy(lam, wi, wo, *a, **k):
        pairs.append(torch.broadcast_shapes(wi.shape[:-1], wo.shape[:-1]).numel())
        return real(lam, wi, wo, *a, **k)

    monkeypatch.setattr(scatterograms, "_single_reflection_brdf", spy)
    results = {}
    for chunk in (None, 48):
        pairs.clear()
        with ti.options(chunk_size=chunk):
            results[chunk] = layered.scatterogram(jewel_beetle("green"), resolution=8, **kw).xyz
        if chunk is None:
            assert max(pairs) > 32  # one call per rule (white) or per image (beam)
        else:
            assert len(pairs) > 2 and max(pairs) <= chunk // LAM.numel()
    torch.testing.assert_close(results[48], results[None], rtol=1e-14, atol=1e-16)
