"""The Mitsuba 3 plugins against the library and independent references (tmm), in the scalar
variants (always) — the vectorised checks (χ², furnace, renders) are in test_mitsuba_render.py."""

import math

import numpy as np
import pytest
import torch

mi = pytest.importorskip("mitsuba", reason="Mitsuba 3 is not installed (pip install 'torchirid[mitsuba]')")
dr = pytest.importorskip("drjit")
tmm = pytest.importorskip("tmm")

import torchirid.mitsuba as tm  # noqa: E402
from torchirid.layered import LayeredBragg, RoughBraggLayer, single_reflection_brdf  # noqa: E402
from torchirid.materials import refractive_index  # noqa: E402
from torchirid.microfacet import microfacet_brdf  # noqa: E402
from torchirid.optics import multilayer, thin_film_reflectance  # noqa: E402

LAM = (412.5, 523.0, 611.0, 702.0)


@pytest.fixture(params=["scalar_spectral"])
def spectral(request):
    tm.register(request.param)
    return request.param


def _si(wi, lam=LAM):
    si = dr.zeros(mi.SurfaceInteraction3f)
    si.wi = mi.Vector3f(*wi)
    si.wavelengths = mi.Spectrum(*lam)
    return si


def _directions(count, seed, *, below=False):
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(count):
        c = rng.uniform(0.02, 1.0)
        phi = rng.uniform(0, 2 * math.pi)
        s = math.sqrt(1 - c * c)
        out.append((s * math.cos(phi), s * math.sin(phi), -c if below else c))
    return out


def _f32(x):
    return float(np.float32(x))


def _tmm_r_t(n_list, d_list, cos0, lam):
    """Unpolarized (R, T) of tmm's coherent solver (independent of the library)."""
    th0 = complex(math.acos(min(1.0, cos0)))
    out = []
    for pol in ("s", "p"):
        res = tmm.coh_tmm(pol, n_list, [math.inf] + list(d_list) + [math.inf], th0, lam)
        out.append((res["R"], res["T"]))
    return 0.5 * (out[0][0] + out[1][0]), 0.5 * (out[0][1] + out[1][1])


def _channels(spectrum):
    return np.array([float(spectrum[i]) for i in range(len(spectrum))])


# ---------------------------------------------------------------------------------------------
# smooth: the delta's weight is the stack's R (and T), to 1e-5 against tmm on the explicit stack
# ---------------------------------------------------------------------------------------------
def test_smooth_thin_film_on_gold_weight_is_tmm_r(spectral):
    b = mi.load_dict({"type": "torchirid_thin_film", "n_film": 1.45, "thickness": 310.0, "n_substrate": "Au"})
    ctx = mi.BSDFContext()
    for wi in _directions(12, 1):
        si = _si(wi)
        bs, w = b.sample(ctx, si, 0.3, mi.Point2f(0.5, 0.5))
        cos0 = float(si.wi[2])
        ref = []
        for lam in LAM:
            au = complex(refractive_index("Au", torch.tensor(lam, dtype=torch.float64)).item())
            ref.append(_tmm_r_t([1.0, 1.45, au], [310.0], cos0, lam)[0])
        np.testing.assert_allclose(_channels(w), ref, atol=1e-5, rtol=0)
        np.testing.assert_allclose([float(bs.wo[k]) for k in range(3)], [-wi[0], -wi[1], wi[2]], atol=1e-6)


def test_smooth_soap_film_reflects_and_transmits_tmm_r_and_t_from_both_sides(spectral):
    """A free-standing film (n_substrate = n_incident): R and T = 1 − R, straight through."""
    b = mi.load_dict({"type": "torchirid_thin_film", "n_film": 1.33, "thickness": 420.0, "n_substrate": 1.0})
    for below in (False, True):
        for wi in _directions(6, 2, below=below):
            si = _si(wi)
            cos0 = abs(float(si.wi[2]))
            ref = [_tmm_r_t([1.0, 1.33, 1.0], [420.0], cos0, lam) for lam in LAM]
            for component, k in ((0, 0), (1, 1)):
                ctx = mi.BSDFContext()
                ctx.component = component
                bs, w = b.sample(ctx, si, 0.5, mi.Point2f(0.5, 0.5))
                np.testing.assert_allclose(_channels(w), [r[k] for r in ref], atol=1e-5, rtol=0)
                if component == 1:  # straight through
                    np.testing.assert_allclose([float(bs.wo[j]) for j in range(3)], [-x for x in wi], atol=1e-6)


def test_smooth_film_on_glass_transmits_tmm_t_and_refracts(spectral):
    b = mi.load_dict({"type": "torchirid_thin_film", "n_film": 2.1, "thickness": 150.0, "n_substrate": 1.5})
    for below in (False, True):
        for wi in _directions(6, 3, below=below):
            si = _si(wi)
            cos0 = abs(float(si.wi[2]))
            n_list = [1.0, 2.1, 1.5] if not below else [1.5, 2.1, 1.0]
            ref = [_tmm_r_t(n_list, [150.0], cos0, lam) for lam in LAM]
            ctx = mi.BSDFContext()
            ctx.component = 0
            _, w = b.sample(ctx, si, 0.5, mi.Point2f(0.5, 0.5))
            np.testing.assert_allclose(_channels(w), [r[0] for r in ref], atol=1e-5, rtol=0)
            ctx.component = 1
            bs, w = b.sample(ctx, si, 0.5, mi.Point2f(0.5, 0.5))
            eta = 1.5 if not below else 1 / 1.5  # n_t / n_i
            # radiance is compressed by (n_i / n_t)² (Mitsuba's dielectric convention)
            np.testing.assert_allclose(_channels(w) * eta ** 2, [r[1] for r in ref], atol=1e-5, rtol=0)
            sin_t = math.sqrt(1 - cos0 ** 2) / eta
            if sin_t < 1:
                assert float(bs.wo[2]) * float(si.wi[2]) < 0
                assert abs(abs(float(bs.wo[2])) - math.sqrt(1 - sin_t ** 2)) < 1e-5
            else:  # total internal reflection: nothing goes through
                assert np.all(_channels(w) < 1e-7)


def test_smooth_multilayer_of_named_materials_weight_is_tmm_r(spectral):
    mats = ["TiO2", "SiO2", "TiO2", "SiO2", "Ag"]
    d = [55.0, 91.0, 60.0, 88.0, 30.0]
    b = mi.load_dict({"type": "torchirid_multilayer", "materials": ",".join(mats),
                      "thicknesses": ",".join(map(str, d)), "n_substrate": "SiO2"})
    ctx = mi.BSDFContext()
    for wi in _directions(6, 4):
        si = _si(wi)
        cos0 = float(si.wi[2])
        _, w = b.sample(ctx, si, 0.3, mi.Point2f(0.5, 0.5))
        ref = []
        for lam in LAM:
            t = torch.tensor(lam, dtype=torch.float64)
            n_list = [1.0] + [complex(refractive_index(m, t).item()) for m in mats] + [
                complex(refractive_index("SiO2", t).item())]
            ref.append(_tmm_r_t(n_list, d, cos0, lam)[0])
        # the plugin interpolates n, k on a 0.1 nm grid; the library interpolates the database's own
        # samples: the difference is far below 1e-5 at these wavelengths
        np.testing.assert_allclose(_channels(w), ref, atol=1e-5, rtol=0)


@pytest.mark.parametrize("cells", [5, 60, 400])
def test_smooth_bragg_weight_is_tmm_r_of_the_explicit_stack_also_at_band_edges(spectral, cells):
    n1, n2, d1, d2 = 1.5, 1.9 + 0.002j, 95.0, 70.0
    b = mi.load_dict({"type": "torchirid_bragg", "n1": n1, "n2": 1.9, "k2": 0.002, "d1": d1, "d2": d2,
                      "cells": cells, "n_incident": 1.0})
    ctx = mi.BSDFContext()
    # the band edges of the stop band near 560 nm at normal incidence, and grazing light
    lam = (547.3, 556.0, 571.2, 580.9)
    for wi in [(0.0, 0.0, 1.0), (0.6, 0.0, 0.8), (0.999, 0.0, math.sqrt(1 - 0.999 ** 2))]:
        si = _si(wi, lam)
        cos0 = float(si.wi[2])
        _, w = b.sample(ctx, si, 0.3, mi.Point2f(0.5, 0.5))
        ref = [_tmm_r_t([1.0] + [n2, n1] * cells + [n1], [d2, d1] * cells, cos0, x)[0] for x in lam]
        np.testing.assert_allclose(_channels(w), ref, atol=1e-5, rtol=0)


# ---------------------------------------------------------------------------------------------
# rough: eval = the library's GGX microfacet BRDF with the structure's R at i·h (× cos θo)
# ---------------------------------------------------------------------------------------------
def _pairs(count, seed):
    return list(zip(_directions(count, seed), _directions(count, seed + 100)))


def _as64(v):
    return torch.tensor([float(v[k]) for k in range(3)], dtype=torch.float64)


ROUGH = {
    "thin_film_on_gold": ({"type": "torchirid_thin_film", "n_film": 1.45, "thickness": 310.0, "n_substrate": "Au",
                           "alpha": 0.25},
                          lambda lam, c: thin_film_reflectance(lam, c, 1.45, 310.0, refractive_index("Au", lam))),
    "multilayer": ({"type": "torchirid_multilayer", "materials": "2.3,1.46,2.3", "thicknesses": "60,95,60",
                    "n_substrate": 1.52, "alpha": 0.1},
                   lambda lam, c: multilayer(lam, c, torch.tensor([1.0, 2.3, 1.46, 2.3, 1.52], dtype=torch.complex128),
                                             torch.tensor([60.0, 95.0, 60.0], dtype=torch.float64))[0]),
}


@pytest.mark.parametrize("case", sorted(ROUGH))
def test_rough_eval_is_the_librarys_microfacet_brdf_with_the_films_fresnel(spectral, case):
    spec, reflectance = ROUGH[case]
    b = mi.load_dict(spec)
    ctx = mi.BSDFContext()
    lam = torch.tensor(LAM, dtype=torch.float64)
    for wi, wo in _pairs(10, 5):
        si = _si(wi)
        v = _channels(b.eval(ctx, si, mi.Vector3f(*wo)))
        i64, o64 = _as64(si.wi), _as64(mi.Vector3f(*wo))
        ref = microfacet_brdf(i64, o64, spec["alpha"], lambda c: reflectance(lam, c[..., None])) * o64[2]
        np.testing.assert_allclose(v, ref.numpy(), rtol=1e-4, atol=1e-7)
        # the sample weight is eval / pdf
        bs, w = b.sample(ctx, si, 0.5, mi.Point2f(0.31, 0.77))
        if float(bs.pdf) > 0:
            ev, pdf = b.eval_pdf(ctx, si, bs.wo)
            np.testing.assert_allclose(_channels(w), _channels(ev) / float(pdf), rtol=1e-5)
            assert abs(float(pdf) - float(bs.pdf)) <= 1e-5 * float(pdf)


@pytest.mark.parametrize("n_incident,base_albedo", [(1.0, 0.0), (1.0, 0.6), (1.56, 0.3)])
def test_rough_bragg_eval_is_the_single_reflection_brdf(spectral, n_incident, base_albedo):
    """Fourneau et al. eq. 34 with one layer: the microfacet lobe of the mirrors, the base seen
    through τ, the coating's transmittances; against ``single_reflection_brdf``."""
    n1 = 1.56 if n_incident > 1 else 1.0
    b = mi.load_dict({"type": "torchirid_bragg", "n1": n1, "n2": 1.9, "d1": 90.0, "d2": 70.0, "cells": 10,
                      "alpha": 0.15, "base_albedo": base_albedo, "n_incident": n_incident})
    s = LayeredBragg([RoughBraggLayer(n1, 1.9, 90.0, 70.0, 10, 0.15, n_incident=n_incident)], base_albedo=base_albedo)
    lam = (450.0, 523.0, 600.0, 700.0)  # on the τ table's 1 nm grid
    ctx = mi.BSDFContext()
    ctx.component = 0
    for wi, wo in _pairs(8, 6):
        si = _si(wi, lam)
        v = _channels(b.eval(ctx, si, mi.Vector3f(*wo)))
        i64, o64 = _as64(si.wi), _as64(mi.Vector3f(*wo))
        ref = single_reflection_brdf(torch.tensor(lam, dtype=torch.float64), i64[None], o64[None], s)[0] * o64[2]
        np.testing.assert_allclose(v, ref.numpy(), rtol=1e-4, atol=1e-6)
        bs, w = b.sample(ctx, si, 0.4, mi.Point2f(0.31, 0.77))
        if float(bs.pdf) > 0:
            ev, pdf = b.eval_pdf(ctx, si, bs.wo)
            np.testing.assert_allclose(_channels(w), _channels(ev) / float(pdf), rtol=1e-5)


def test_coated_rough_bragg_reflects_the_coatings_fresnel_in_the_mirror_direction(spectral):
    b = mi.load_dict({"type": "torchirid_bragg", "n1": 1.56, "n2": 1.9, "d1": 90.0, "d2": 70.0, "cells": 10,
                      "alpha": 0.15, "n_incident": 1.56})
    ctx = mi.BSDFContext()
    ctx.component = 1
    wi = (0.6, 0.0, 0.8)
    bs, w = b.sample(ctx, _si(wi), 0.2, mi.Point2f(0.5, 0.5))
    assert int(bs.sampled_type) == int(mi.BSDFFlags.DeltaReflection)
    rs = ((0.8 - math.sqrt(1.56 ** 2 - 0.36)) / (0.8 + math.sqrt(1.56 ** 2 - 0.36))) ** 2
    ct = math.sqrt(1.56 ** 2 - 0.36) / 1.56
    rp = ((1.56 * 0.8 - ct) / (1.56 * 0.8 + ct)) ** 2
    np.testing.assert_allclose(_channels(w), [(rs + rp) / 2] * 4, rtol=1e-5)


# ---------------------------------------------------------------------------------------------
# the exact path (torch), RGB variants, parameters and errors
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("spec", [
    {"type": "torchirid_thin_film", "n_film": 1.33, "thickness": 420.0, "n_substrate": 1.0},
    {"type": "torchirid_thin_film", "n_film": 1.45, "thickness": 310.0, "n_substrate": "Au", "alpha": 0.25},
    {"type": "torchirid_multilayer", "materials": "TiO2,SiO2", "thicknesses": "60,95", "n_substrate": 1.52},
    {"type": "torchirid_bragg", "n1": 1.56, "n2": 1.9, "d1": 90.0, "d2": 70.0, "cells": 10, "alpha": 0.15,
     "base_albedo": 0.3},
], ids=["soap", "rough_gold", "multilayer", "rough_bragg"])
def test_torch_evaluator_gives_the_values_of_the_drjit_kernel(spectral, spec):
    a = mi.load_dict(spec)
    b = mi.load_dict({**spec, "evaluator": "torch"})
    ctx = mi.BSDFContext()
    for wi, wo in _pairs(5, 7):
        si = _si(wi)
        for u in (0.1, 0.9):
            _, wa = a.sample(ctx, si, u, mi.Point2f(0.4, 0.6))
            _, wb = b.sample(ctx, si, u, mi.Point2f(0.4, 0.6))
            np.testing.assert_allclose(_channels(wa), _channels(wb), rtol=2e-6, atol=1e-7)
        np.testing.assert_allclose(_channels(a.eval(ctx, si, mi.Vector3f(*wo))),
                                   _channels(b.eval(ctx, si, mi.Vector3f(*wo))), rtol=2e-6, atol=1e-7)


def test_rgb_variant_integrates_the_spectrum_to_linear_srgb():
    """In the RGB variants the weight is linear sRGB of R(λ) under D65 on the 5 nm nodes; against
    the library's 1 nm colour it is within ΔE2000 0.1 for films up to 1 µm."""
    from torchirid.color import delta_e_2000, linear_srgb_to_xyz, spectrum_to_xyz, xyz_to_lab

    tm.register("scalar_rgb")
    worst = 0.0
    ctx = mi.BSDFContext()
    lam = torch.arange(360.0, 831.0, 1.0, dtype=torch.float64)
    for d in (120.0, 330.0, 610.0, 1000.0):
        b = mi.load_dict({"type": "torchirid_thin_film", "n_film": 1.33, "thickness": d, "n_substrate": 1.52})
        for c in (1.0, 0.5, 0.1):
            si = dr.zeros(mi.SurfaceInteraction3f)
            si.wi = mi.Vector3f(math.sqrt(1 - c * c), 0.0, c)
            ctx.component = 0
            _, w = b.sample(ctx, si, 0.5, mi.Point2f(0.5, 0.5))
            ours = xyz_to_lab(linear_srgb_to_xyz(torch.tensor(_channels(w), dtype=torch.float64)))
            r = thin_film_reflectance(lam, torch.tensor(float(si.wi[2]), dtype=torch.float64), 1.33, d, 1.52)
            ref = xyz_to_lab(spectrum_to_xyz(r, lam))
            worst = max(worst, float(delta_e_2000(ours, ref)))
    assert worst < 0.1, worst


@pytest.mark.parametrize("cells", [10, 100])
def test_rgb_variant_bragg_mirror_is_its_exact_1nm_colour(cells):
    """A mirror of many cells has fringes 5 nm apart: its RGB comes from a table of the 1 nm colour
    over the angle (exact path: the 1 nm integral itself)."""
    from torchirid.color import delta_e_2000, linear_srgb_to_xyz, spectrum_to_xyz, xyz_to_lab
    from torchirid.optics import bragg_reflectance

    tm.register("scalar_rgb")
    spec = {"type": "torchirid_bragg", "n1": 1.5, "n2": 2.3, "d1": 95.0, "d2": 60.0, "cells": cells, "n_incident": 1.0}
    lam = torch.arange(360.0, 831.0, 1.0, dtype=torch.float64)
    worst = {}
    for evaluator in ("drjit", "torch"):
        b = mi.load_dict({**spec, "evaluator": evaluator})
        worst[evaluator] = 0.0
        for c in np.linspace(0.03, 1.0, 23):
            si = dr.zeros(mi.SurfaceInteraction3f)
            si.wi = mi.Vector3f(math.sqrt(1 - c * c), 0.0, c)
            _, w = b.sample(mi.BSDFContext(), si, 0.5, mi.Point2f(0.5, 0.5))
            ours = xyz_to_lab(linear_srgb_to_xyz(torch.tensor(_channels(w), dtype=torch.float64)))
            r = bragg_reflectance(lam, torch.tensor(float(si.wi[2]), dtype=torch.float64), 1.5, 2.3, 95.0, 60.0, cells,
                                  n_incident=1.0)
            worst[evaluator] = max(worst[evaluator], float(delta_e_2000(ours, xyz_to_lab(spectrum_to_xyz(r, lam)))))
    assert worst["drjit"] < 0.1 and worst["torch"] < 0.01, worst


def test_traverse_exposes_the_differentiable_parameters(spectral):
    scene_bsdf = mi.load_dict({"type": "torchirid_thin_film", "n_film": 1.33, "thickness": 420.0, "n_substrate": 1.0,
                               "alpha": 0.1})
    params = mi.traverse(scene_bsdf)
    assert "thickness" in params and "alpha" in params
    bragg = mi.traverse(mi.load_dict({"type": "torchirid_bragg", "n1": 1.5, "n2": 1.9, "d1": 90.0, "d2": 70.0,
                                      "cells": 10}))
    assert "d1" in bragg and "d2" in bragg


@pytest.mark.parametrize("spec,message", [
    ({"type": "torchirid_thin_film", "n_film": 1.33}, "thickness"),
    ({"type": "torchirid_thin_film", "n_film": 1.33, "thickness": -3.0}, "thickness must be"),
    ({"type": "torchirid_thin_film", "n_film": "unobtainium", "thickness": 100.0}, "unobtainium"),
    ({"type": "torchirid_thin_film", "n_film": 1.33, "thickness": 100.0, "evaluator": "numpy"}, "evaluator"),
    ({"type": "torchirid_bragg", "n1": 1.5, "n2": 1.9, "d1": 90.0, "d2": 70.0, "cells": 0}, "cells"),
    ({"type": "torchirid_multilayer", "materials": "1.5,2.0", "thicknesses": "100"}, "thicknesses"),
])
def test_bad_parameters_name_the_parameter(spectral, spec, message):
    with pytest.raises(Exception, match=message):
        mi.load_dict(spec)


def test_design_file_of_torchirid_design_loads_as_a_multilayer(spectral, tmp_path):
    from torchirid import design

    problem = design.Problem([design.Layer(2.3, (50.0, 70.0)), design.Layer("SiO2", (80.0, 100.0))],
                             [design.SpectralTarget("R", [550.0], value=0.0)], n_incident=1.0, n_substrate=1.52)
    found = design.optimise(problem, seed=0, max_evaluations=200)
    path = tmp_path / "design.json"
    found.to_json(path)  # what `torchirid design` writes
    a = mi.load_dict({"type": "torchirid_multilayer", "design": str(path)})
    b = mi.load_dict({"type": "torchirid_multilayer", "materials": "2.3,SiO2",
                      "thicknesses": ",".join(f"{d!r}" for d in map(float, found.thicknesses)), "n_substrate": 1.52})
    ctx = mi.BSDFContext()
    si = _si((0.3, 0.2, math.sqrt(1 - 0.13)))
    np.testing.assert_allclose(_channels(a.sample(ctx, si, 0.2, mi.Point2f(0.5, 0.5))[1]),
                               _channels(b.sample(ctx, si, 0.2, mi.Point2f(0.5, 0.5))[1]), rtol=1e-7)


def test_a_thickness_texture_gives_each_point_its_film(spectral):
    """``thickness`` as a Mitsuba texture of nm: a point reflects as the film of its texel."""
    data = np.array([[[150.0], [300.0]], [[450.0], [600.0]]], dtype=np.float32)  # (2, 2, 1) nm
    b = mi.load_dict({"type": "torchirid_thin_film", "n_film": 1.33, "n_substrate": 1.52,
                      "thickness": {"type": "bitmap", "bitmap": mi.Bitmap(data), "raw": True,
                                    "filter_type": "nearest"}})
    assert any(k.startswith("thickness") for k in mi.traverse(b).keys())
    ctx = mi.BSDFContext()
    ctx.component = 0
    lam = torch.tensor(LAM, dtype=torch.float64)
    for (u, v), d in [((0.25, 0.25), 150.0), ((0.75, 0.25), 300.0), ((0.25, 0.75), 450.0), ((0.75, 0.75), 600.0)]:
        si = _si((0.3, 0.0, math.sqrt(1 - 0.09)))
        si.uv = mi.Point2f(u, v)
        _, w = b.sample(ctx, si, 0.5, mi.Point2f(0.5, 0.5))
        ref = multilayer(lam, torch.tensor(float(si.wi[2]), dtype=torch.float64),
                         torch.tensor([1.0, 1.33, 1.52], dtype=torch.complex128), torch.tensor([d], dtype=torch.float64))[0]
        np.testing.assert_allclose(_channels(w), ref.numpy(), atol=1e-5)
