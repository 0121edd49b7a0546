"""The plugins in Mitsuba's vectorised LLVM variants: χ² tests of sampling against the pdf,
white furnace, the geometry against Mitsuba's ``roughconductor``, the Dr.Jit kernel against
the library (torch) pixel for pixel, and gradients through ``mi.traverse``. Skipped, with the
reason, where Dr.Jit has no LLVM backend (libLLVM >= 16 missing)."""

import gc
import math

import numpy as np
import pytest

mi = pytest.importorskip("mitsuba", reason="Mitsuba 3 is not installed (pip install 'torchirid[mitsuba]')")
dr = pytest.importorskip("drjit")

import torchirid.mitsuba as tm  # noqa: E402
from torchirid.mitsuba.scenes import sphere_scene  # noqa: E402

if not dr.has_backend(dr.JitBackend.LLVM):  # pragma: no cover - depends on the machine
    pytest.skip("Dr.Jit's LLVM backend is unavailable (needs libLLVM >= 16: apt-get install libllvm19)",
                allow_module_level=True)

pytestmark = pytest.mark.slow

LAM = (450.0, 523.0, 600.0, 690.0)
SKY = {"type": "constant", "radiance": {"type": "rgb", "value": [0.6, 0.7, 0.9]}}
SUN = {"type": "directional", "direction": [1.0, -1.0, -1.0], "irradiance": {"type": "rgb", "value": [3, 3, 3]}}

ROUGH = {
    "thin_film_on_gold": {"type": "torchirid_thin_film", "n_film": 1.45, "thickness": 310.0, "n_substrate": "Au",
                          "alpha": 0.3},
    "multilayer": {"type": "torchirid_multilayer", "materials": "TiO2,SiO2,TiO2", "thicknesses": "60,95,60",
                   "n_substrate": 1.52, "alpha": 0.2},
    "bragg_on_base": {"type": "torchirid_bragg", "n1": 1.0, "n2": 1.9, "d1": 90.0, "d2": 70.0, "cells": 10,
                      "alpha": 0.2, "base_albedo": 0.5},
    "coated_bragg_on_base": {"type": "torchirid_bragg", "n1": 1.56, "n2": 1.9, "d1": 90.0, "d2": 70.0, "cells": 10,
                             "alpha": 0.2, "base_albedo": 0.5},
}


@pytest.fixture
def llvm_spectral():
    tm.register("llvm_ad_spectral")
    yield
    dr.set_flag(dr.JitFlag.SymbolicLoops, True)
    dr.set_flag(dr.JitFlag.SymbolicCalls, True)
    gc.collect()  # a symbolic call traces every live BSDF instance, also those of earlier scenes


def _interactions(n, wi, lam=LAM):
    si = dr.zeros(mi.SurfaceInteraction3f, n)
    si.wi = wi
    si.wavelengths = mi.Spectrum(*lam)
    return si


def _glossy_context():
    ctx = mi.BSDFContext()
    ctx.component = 0  # the lobe: a coated layer's specular delta is not a density
    return ctx


@pytest.mark.parametrize("case", sorted(ROUGH))
@pytest.mark.parametrize("cos_i", [1.0, 0.7, 0.25])
def test_chi2_sampling_matches_the_pdf(llvm_spectral, case, cos_i, tmp_path, monkeypatch):
    from mitsuba.chi2 import ChiSquareTest, SphericalDomain

    monkeypatch.chdir(tmp_path)  # a failing test writes chi2_data.py to the working directory
    spec = ROUGH[case]
    wi = mi.Vector3f(math.sqrt(1 - cos_i * cos_i), 0.0, cos_i)
    ctx = _glossy_context()
    bsdf = mi.load_dict(spec)

    def sample(u, *args):
        bs, w = bsdf.sample(ctx, _interactions(dr.width(u), wi), u[0], mi.Vector2f(u[1], u[2]))
        valid = dr.full(mi.Float, 1.0, dr.width(w))
        valid[dr.all(w == 0)] = 0
        return bs.wo, valid

    def pdf(wo, *args):
        return bsdf.pdf(ctx, _interactions(dr.width(wo), wi), wo)

    # seed 2: at seed 7 Mitsuba's own roughconductor (α 0.3, cos θi 0.25) is rejected at p = 0.0019, and so is
    # the thin film with the same p-value (its lobe is sampled by the same VNDF code): a 1 % test fails 1 % of draws
    chi2 = ChiSquareTest(domain=SphericalDomain(), sample_func=sample, pdf_func=pdf, sample_dim=3, seed=2)
    assert chi2.run(), chi2.messages


@pytest.mark.parametrize("case", sorted(ROUGH) + ["soap_film", "bragg_smooth"])
def test_white_furnace_albedo_is_at_most_one(llvm_spectral, case):
    spec = dict(ROUGH.get(case) or {
        "soap_film": {"type": "torchirid_thin_film", "n_film": 1.33, "thickness": 420.0, "n_substrate": 1.0},
        "bragg_smooth": {"type": "torchirid_bragg", "n1": 1.5, "n2": 2.3, "d1": 95.0, "d2": 60.0, "cells": 30,
                         "n_incident": 1.0},
    }[case])
    bsdf = mi.load_dict(spec)
    n = 400_000
    rng = mi.PCG32(n, 11)
    worst = 0.0
    for cos_i in (1.0, 0.8, 0.5, 0.2, 0.05):
        wi = mi.Vector3f(math.sqrt(1 - cos_i * cos_i), 0.0, cos_i)
        _, w = bsdf.sample(mi.BSDFContext(), _interactions(n, wi), rng.next_float32(),
                           mi.Point2f(rng.next_float32(), rng.next_float32()))
        albedo = np.array(dr.mean(w, axis=1)).ravel()
        worst = max(worst, float(np.max(albedo)))
    assert worst <= 1.0 + 1e-2, worst


def _sphere_scene(bsdf, *, size=32, spp=16, integrator="path"):
    """The sphere of these tests and of benchmarks/mitsuba_plugins.py: a constant sky and a sun."""
    return sphere_scene(bsdf, environment=SKY, extra={"sun": SUN}, elevation_deg=0.0, azimuth_deg=90.0,
                        size=size, spp=spp, integrator=integrator)


@pytest.mark.parametrize("case", ["thin_film_on_gold", "multilayer", "bragg_on_base"])
def test_with_the_fresnel_term_forced_to_one_the_rough_plugins_render_as_roughconductor(llvm_spectral, case):
    """The geometry (GGX D, separable Smith G, VNDF sampling) is Mitsuba's own: with R ≡ 1 and no
    base the sphere renders as ``roughconductor`` (a 100 % mirror microsurface) pixel for pixel."""
    spec = {k: v for k, v in ROUGH[case].items() if k != "base_albedo"}
    ours = mi.load_dict(spec)
    ours._values = lambda si, cos_i, side: (dr.ones(mi.Spectrum), None)
    ref = mi.load_dict({"type": "roughconductor", "alpha": spec["alpha"], "distribution": "ggx"})
    a = np.array(mi.render(_sphere_scene(ours), seed=3))
    b = np.array(mi.render(_sphere_scene(ref), seed=3))
    assert np.abs(a - b).max() <= 1e-4 * max(1.0, np.abs(b).max()), np.abs(a - b).max()


@pytest.mark.parametrize("case", ["soap_film", "thin_film_on_gold", "coated_bragg_on_base"])
def test_drjit_kernel_renders_the_pixels_of_the_exact_torch_path(llvm_spectral, case):
    spec = dict(ROUGH.get(case) or {"type": "torchirid_thin_film", "n_film": 1.33, "thickness": 420.0,
                                    "n_substrate": 1.0})
    dr.set_flag(dr.JitFlag.SymbolicLoops, False)  # dr.wrap runs torch on evaluated arrays
    dr.set_flag(dr.JitFlag.SymbolicCalls, False)
    a = np.array(mi.render(_sphere_scene(mi.load_dict(spec), size=16, spp=4), seed=5))
    b = np.array(mi.render(_sphere_scene(mi.load_dict({**spec, "evaluator": "torch"}), size=16, spp=4), seed=5))
    # float32 pixels; the Dr.Jit path runs the film recursion in float32 after float64 roots and phases
    # (≤ 2.4e-6 in R, test_llvm_smooth_weights_equal_the_exact_r_to_1e_5)
    assert np.abs(a - b).max() <= 5e-5 * max(1.0, np.abs(b).max()), np.abs(a - b).max()


@pytest.mark.parametrize("case,key,step", [("thin_film_on_gold", "thickness", 0.5), ("thin_film_on_gold", "alpha", 1e-3),
                                            ("bragg_on_base", "d1", 0.02), ("multilayer", "thicknesses", 0.25)])
def test_bsdf_gradients_by_drjit_ad_match_finite_differences(llvm_spectral, case, key, step):
    """Dr.Jit differentiates the plugins' float64 kernels: ∂eval/∂parameter by AD against a
    central difference of the same eval, at many direction pairs."""
    bsdf = mi.load_dict(ROUGH[case])
    params = mi.traverse(bsdf)
    n = 64
    rng = np.random.default_rng(3)
    c_i, c_o = rng.uniform(0.2, 1.0, n), rng.uniform(0.2, 1.0, n)
    phi = rng.uniform(0, 2 * np.pi, n)
    wi = mi.Vector3f(np.sqrt(1 - c_i ** 2), 0.0 * c_i, c_i)
    wo = mi.Vector3f(np.sqrt(1 - c_o ** 2) * np.cos(phi), np.sqrt(1 - c_o ** 2) * np.sin(phi), c_o)
    ctx = _glossy_context()

    def value():
        return bsdf.eval(ctx, _interactions(n, wi), wo)

    base = mi.Float(params[key])
    dr.enable_grad(params[key])
    params.update()
    out = value()
    dr.backward(dr.sum(out, axis=None))
    grad = np.array(dr.grad(params[key]))[0]
    dr.disable_grad(params[key])

    def total(delta):
        p = np.array(base).copy()
        p[0] += delta
        params[key] = mi.Float(p)
        params.update()
        return float(np.array(dr.sum(value(), axis=None), dtype=np.float64).ravel()[0])

    fd = (total(step) - total(-step)) / (2 * step)
    params[key] = base
    params.update()
    assert grad == pytest.approx(fd, rel=2e-3, abs=1e-6)


def test_inverse_rendering_gradient_of_an_image_loss_has_the_finite_difference_slope(llvm_spectral):
    """Through Mitsuba's differentiable path replay (``prb``): d(mean pixel)/d(thickness) against a
    central difference of renders at the same seed (Monte Carlo: within 10 %)."""
    scene = _sphere_scene(mi.load_dict(ROUGH["thin_film_on_gold"]), size=16, spp=32, integrator="prb")
    params = mi.traverse(scene)
    name = "sphere.bsdf.thickness"
    dr.enable_grad(params[name])
    params.update()
    img = mi.render(scene, params, seed=2, spp=32)
    dr.backward(dr.mean(img, axis=None))
    grad = float(np.array(dr.grad(params[name]))[0])

    def loss(v):
        p = mi.traverse(scene)
        p[name] = mi.Float(v)
        p.update()
        return float(np.array(mi.render(scene, p, seed=2, spp=32), dtype=np.float64).mean())

    fd = (loss(311.0) - loss(309.0)) / 2.0
    assert grad == pytest.approx(fd, rel=0.1)


def test_every_plugin_renders_in_the_scalar_and_llvm_variants():
    for variant in ("scalar_spectral", "scalar_rgb", "llvm_ad_spectral", "llvm_ad_rgb"):
        tm.register(variant)
        for spec in [ROUGH["thin_film_on_gold"], ROUGH["coated_bragg_on_base"], ROUGH["multilayer"],
                     {"type": "torchirid_thin_film", "n_film": 1.33, "thickness": 420.0, "n_substrate": 1.0},
                     {"type": "torchirid_bragg", "n1": 1.5, "n2": 2.3, "d1": 95.0, "d2": 60.0, "cells": 30}]:
            img = np.array(mi.render(_sphere_scene(mi.load_dict(spec), size=8, spp=2), seed=1))
            assert img.shape[:2] == (8, 8) and np.isfinite(img).all() and img.max() > 0, (variant, spec["type"])


SMOOTH_REFERENCES = {
    # plugin spec, (materials top first, thicknesses, substrate): the stack's R by the library (float64)
    "film_on_gold": ({"type": "torchirid_thin_film", "n_film": 1.45, "thickness": 310.0, "n_substrate": "Au"},
                     ([1.45], [310.0], "Au")),
    "thick_film": ({"type": "torchirid_thin_film", "n_film": 1.6, "thickness": 20000.0, "n_substrate": 1.52},
                   ([1.6], [20000.0], 1.52)),
    "named_stack": ({"type": "torchirid_multilayer", "materials": "TiO2,SiO2,TiO2,SiO2,Ag",
                     "thicknesses": "55,91,60,88,30", "n_substrate": "SiO2"},
                    (["TiO2", "SiO2", "TiO2", "SiO2", "Ag"], [55.0, 91.0, 60.0, 88.0, 30.0], "SiO2")),
    "bragg_400": ({"type": "torchirid_bragg", "n1": 1.5, "n2": 1.9, "k2": 0.002, "d1": 95.0, "d2": 70.0, "cells": 400,
                   "n_incident": 1.0},
                  ([1.9 + 0.002j, 1.5] * 400, [70.0, 95.0] * 400, 1.5)),
}


@pytest.mark.parametrize("case", sorted(SMOOTH_REFERENCES))
def test_llvm_smooth_weights_equal_the_exact_r_to_1e_5(llvm_spectral, case):
    """In the JIT variants films and stacks run their recursion in float32 after float64 roots and
    phases (reduced modulo 2π), Bragg mirrors in float64: the weight is still the exact R to 1e-5,
    at random directions and wavelengths, grazing included."""
    import torch

    from torchirid.materials import refractive_index
    from torchirid.optics import multilayer

    spec, (materials, thicknesses, substrate) = SMOOTH_REFERENCES[case]
    bsdf = mi.load_dict(spec)
    rng = np.random.default_rng(5)
    n = 256
    cos = np.concatenate([rng.uniform(0.0, 1.0, n - 2), [1.0, 1e-3]])
    lam = rng.uniform(400.0, 800.0, (4, n))
    if case == "bragg_400":  # the band edges of its stop band near 565 nm
        lam[:2] = rng.uniform(540.0, 590.0, (2, n))
    si = dr.zeros(mi.SurfaceInteraction3f, n)
    si.wi = mi.Vector3f(np.sqrt(1 - cos ** 2), 0.0 * cos, cos)
    si.wavelengths = mi.Spectrum(*[mi.Float(x) for x in lam])
    ctx = mi.BSDFContext()
    ctx.component = 0
    _, w = bsdf.sample(ctx, si, dr.full(mi.Float, 0.5, n), mi.Point2f(0.5, 0.5))
    ours = np.array(w)  # (4, n)
    c64 = torch.tensor(np.array(si.wi.z), dtype=torch.float64)[:, None]
    lam64 = torch.tensor(np.array(si.wavelengths), dtype=torch.float64).T  # (n, 4): the float32 wavelengths
    index = [torch.ones_like(lam64, dtype=torch.complex128)]
    for m in materials + [substrate]:
        index.append(refractive_index(m, lam64) if isinstance(m, str) else torch.full_like(lam64, 0, dtype=torch.complex128) + m)
    ref = multilayer(lam64, c64.expand_as(lam64), torch.stack(index, -1),
                     torch.tensor(thicknesses, dtype=torch.float64).expand(*lam64.shape, len(thicknesses)))[0]
    np.testing.assert_allclose(ours, ref.numpy().T, atol=1e-5, rtol=0)


@pytest.mark.parametrize("case", ["thin_film_on_gold", "multilayer"])
def test_llvm_rough_eval_is_the_librarys_microfacet_brdf_to_1e_4(llvm_spectral, case):
    """The JIT variants' eval (float32 film recursion) against the library's GGX BRDF with the
    stack's Fresnel at the half vector, relative 1e-4, at 512 random pairs × 4 wavelengths."""
    import torch

    from torchirid.materials import refractive_index
    from torchirid.microfacet import microfacet_brdf
    from torchirid.optics import multilayer

    spec = ROUGH[case]
    bsdf = mi.load_dict(spec)
    rng = np.random.default_rng(9)
    n = 512

    def directions():
        c = rng.uniform(0.05, 1.0, n)
        phi = rng.uniform(0, 2 * np.pi, n)
        s = np.sqrt(1 - c * c)
        return mi.Vector3f(s * np.cos(phi), s * np.sin(phi), c)

    wi, wo = directions(), directions()
    si = dr.zeros(mi.SurfaceInteraction3f, n)
    si.wi = wi
    si.wavelengths = mi.Spectrum(*[mi.Float(x) for x in rng.uniform(400.0, 800.0, (4, n))])
    ours = np.array(bsdf.eval(_glossy_context(), si, wo))  # (4, n)
    lam = torch.tensor(np.array(si.wavelengths), dtype=torch.float64).T  # (n, 4)
    i64 = torch.tensor(np.array(si.wi), dtype=torch.float64).T
    o64 = torch.tensor(np.array(wo), dtype=torch.float64).T
    if case == "thin_film_on_gold":
        media = [1.0, 1.45, "Au"]
        d = [310.0]
    else:
        media = [1.0, "TiO2", "SiO2", "TiO2", 1.52]
        d = [60.0, 95.0, 60.0]
    index = torch.stack([refractive_index(m, lam) if isinstance(m, str) else torch.full_like(lam, 0, dtype=torch.complex128) + m
                         for m in media], -1)

    def fresnel(c):  # c: (n,) cosines i·h → (n, 4)
        return multilayer(lam, c[:, None].expand_as(lam), index, torch.tensor(d, dtype=torch.float64).expand(*lam.shape, len(d)))[0]

    ref = (microfacet_brdf(i64, o64, spec["alpha"], fresnel) * o64[:, 2:3]).numpy().T
    np.testing.assert_allclose(ours, ref, rtol=1e-4, atol=1e-7)
