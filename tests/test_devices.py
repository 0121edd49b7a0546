"""Every public function on every available device (docs/conventions.md: dtype and device follow
the inputs; no hidden host copies in hot loops).

Tests that take a ``device`` argument run once per device of ``conftest.available_devices()``:
the CPU always, CUDA when torch sees it (``TORCHIRID_TEST_DEVICES`` names them explicitly). On a
CPU-only machine the table tests compare the CPU with itself, which still checks that results
stay on the inputs' device; the ``meta`` test below is the CPU-side check that the hot kernels
never read tensor values back to the host (a meta tensor has no values to read), and on CUDA a
synchronisation count checks the same on a real device.

The references are the CPU float64 results: float64 on CUDA rounds differently (fused
multiply-adds, other libm), so values agree to 1e-8 relative, not bit for bit, and gradients to
1e-6: the layered functions interpolate tabulated transmissivities in angle, and a query that
falls on a node takes its segment (so its slope) by rounding. Measured worst on an H200 (torch
2.11, CUDA 13): 2e-9 relative in values, 2e-7 in gradients (``layered.single_reflection_pdf``).
"""

from __future__ import annotations

import warnings

import pytest
import torch

import torchirid as ti
from api_cases import CASES, case_id, pick
from tensors import F64

RTOL, ATOL = 1e-8, 1e-12
GRAD_RTOL = 1e-6


def on(value, device):
    """``value`` with its tensors on ``device`` (tensors, LUT-like objects with ``.to``, containers)."""
    if torch.is_tensor(value):
        return value.to(device)
    if isinstance(value, (list, tuple)):
        return type(value)(on(v, device) for v in value)
    if isinstance(value, dict):
        return {k: on(v, device) for k, v in value.items()}
    if hasattr(value, "to") and hasattr(value, "axes"):  # LUT, FilterLUT
        return value.to(device=device)
    return value


def assert_close_on(out, ref, device, what, rtol=RTOL):
    assert out.device.type == device.type, f"{what}: result on {out.device}, inputs on {device}"
    assert out.dtype == ref.dtype, f"{what}: {out.dtype} on {device}, {ref.dtype} on the CPU"
    assert out.shape == ref.shape, what
    got = out.detach().cpu()
    err = (got - ref.detach()).abs()
    tol = ATOL + rtol * ref.detach().abs()
    assert bool((err <= tol).all()), f"{what}: max |Δ| {float(err.max()):.3g} on {device}"


@pytest.mark.parametrize("name", list(CASES), ids=[case_id(n) for n in CASES])
def test_every_call_runs_on_the_device_of_its_inputs(name, device):
    fn, build, _, which = CASES[name]
    ref = pick(fn(**build()), which)
    out = pick(fn(**on(build(), device)), which)
    assert_close_on(out, ref, device, name)


_GRAD_CASES = [n for n in CASES if n not in {"smith_g"}]


@pytest.mark.parametrize("name", _GRAD_CASES, ids=[case_id(n) for n in _GRAD_CASES])
def test_gradients_are_computed_on_the_device(name, device):
    """Backward through each call on the device: the gradient of the first per-sample argument is
    on the device and equals the CPU one."""
    fn, build, args, which = CASES[name]
    arg = args[0]

    def grad(dev):
        kw = on(build(), dev)
        x = kw[arg].detach().clone().requires_grad_(True)
        out = pick(fn(**{**kw, arg: x}), which)
        y = torch.view_as_real(out) if out.is_complex() else out
        (g,) = torch.autograd.grad(y.sum(), x, allow_unused=True)
        return g

    ref = grad(torch.device("cpu"))
    if ref is None:
        pytest.skip(f"{name} does not depend on {arg} differentiably")
    assert_close_on(grad(device), ref, device, f"d {name} / d {arg}", rtol=GRAD_RTOL)


# -- whole scenes and fits ---------------------------------------------------------------------

def test_scatterogram_follows_the_wavelength_device(device):
    from torchirid.layered import scatterogram
    from torchirid.presets import jewel_beetle

    lam = torch.linspace(400.0, 700.0, 7, dtype=F64)
    kw = dict(incident_deg=(20.0, 0.0), resolution=8, lobe_nodes=(12, 8), transmissivity_angles=33)
    ref = scatterogram(jewel_beetle("green"), wavelength=lam, **kw)
    sg = scatterogram(jewel_beetle("green"), wavelength=lam.to(device), **kw)
    assert_close_on(sg.xyz, ref.xyz, device, "scatterogram xyz")


def test_montecarlo_reference_on_the_device_agrees_within_its_error(device):
    """The random streams differ between devices (torch's CPU and CUDA generators), so the two
    estimates agree statistically: within 5 standard errors of their difference."""
    from torchirid.layered import LayeredBragg, RoughBraggLayer, montecarlo_brdf

    lam = torch.tensor([430.0, 520.0, 610.0], dtype=F64)
    wi = torch.tensor([[0.3, 0.0, 0.954]], dtype=F64)
    wo = torch.tensor([[-0.2, 0.1, 0.975]], dtype=F64)
    wi, wo = wi / wi.norm(dim=-1, keepdim=True), wo / wo.norm(dim=-1, keepdim=True)
    s = LayeredBragg([RoughBraggLayer(1.0, 1.5, 110.0, 90.0, 6, 0.15)], base_albedo=0.4)
    f0, e0 = montecarlo_brdf(lam, wi, wo, s, samples=2048, seed=3, transmissivity_angles=91)
    f1, e1 = montecarlo_brdf(*on((lam, wi, wo), device), s, samples=2048, seed=3, transmissivity_angles=91)
    assert f1.device.type == device.type and e1.device.type == device.type
    f1, e1 = f1.cpu(), e1.cpu()
    if device.type == "cpu":
        assert torch.equal(f1, f0) and torch.equal(e1, e0)  # same generator: the same numbers
    assert bool(((f1 - f0).abs() <= 5 * (e0**2 + e1**2).sqrt() + 1e-12).all()), (f0, f1, e0)


def test_environment_shading_follows_the_device(device):
    from torchirid.ibl import prefilter_environment, shade_thin_film_environment, synthetic_environment

    env = synthetic_environment(16, 32)
    ref_pre = prefilter_environment(env, [0.1, 0.3], resolution=(8, 16))
    pre = prefilter_environment(env.to(device), [0.1, 0.3], resolution=(8, 16))
    assert_close_on(pre.radiance, ref_pre.radiance, device, "prefiltered radiance")
    th = torch.tensor([0.1, 0.7, 1.2], dtype=F64)
    view = torch.stack([th.sin(), torch.zeros_like(th), th.cos()], -1)
    normal = torch.tensor([0.0, 0.0, 1.0], dtype=F64)
    film = (torch.tensor(0.2, dtype=F64), torch.tensor(1.33, dtype=F64), torch.tensor(350.0, dtype=F64),
            torch.tensor(1.5, dtype=F64))
    ref = shade_thin_film_environment(ref_pre, normal, view, *film, sensitivity="exact")
    out = shade_thin_film_environment(pre, *on((normal, view, *film), device), sensitivity="exact")
    assert_close_on(out, ref, device, "shade_thin_film_environment")


def test_film_estimate_follows_the_cube_device(device):
    import torchirid.estimation as E

    sc = E.synthetic_cube("mgf2_400", height=4, width=4, seed=0)
    ref = E.estimate_film(sc.cube, sc.wavelength, sc.cos_theta, 1.64)
    est = E.estimate_film(*on((sc.cube, sc.wavelength, sc.cos_theta), device), 1.64)
    assert est.thickness.device.type == device.type and abs(est.n - ref.n) < 1e-9
    assert torch.allclose(est.thickness.cpu(), ref.thickness, rtol=0, atol=1e-6)


def test_chunked_evaluation_on_the_device_equals_one_piece(device):
    """Block evaluation (tests/test_chunks.py on the CPU) on the device: many blocks, the result of
    one piece, for the spectral kernels and the colour of a Bragg mirror."""
    lam = torch.linspace(380.0, 780.0, 201, dtype=F64, device=device)
    c = torch.linspace(0.05, 1.0, 300, dtype=F64, device=device)[:, None]
    calls = {
        "bragg": lambda: ti.bragg_reflectance(lam, c, 1.0, 1.5, 125.0, 375.0, 20),
        "thin film": lambda: ti.thin_film_reflectance(lam, c, 1.33, 300.0, 1.5),
        "bragg_xyz": lambda: ti.bragg_xyz(c[:, 0], 1.0, 1.5, 125.0, 375.0, 20, method="piecewise"),
    }
    for name, call in calls.items():
        with ti.options(chunk_size=None):
            whole = call()
        with ti.options(chunk_size=4096):
            blocks = call()
        assert blocks.device.type == device.type
        assert torch.allclose(blocks, whole, rtol=1e-12, atol=1e-15), name


# -- no host round trips in the hot kernels ------------------------------------------------------

def _hot_kernels(device, size):
    W = 100
    lam = torch.linspace(380.0, 780.0, W, dtype=F64, device=device)
    c = torch.linspace(0.0, 1.0, size // W, dtype=F64, device=device)[:, None]
    idx = torch.tensor([1.0, 1.38, 2.3, 1.38, 2.3, 1.52], dtype=torch.complex128, device=device)
    thk = torch.tensor([100.0, 60.0, 100.0, 60.0], dtype=F64, device=device)
    return {
        "bragg_reflectance": lambda: ti.bragg_reflectance(lam, c, 1.0, 1.5, 125.0, 375.0, 20),
        "thin_film_reflectance": lambda: ti.thin_film_reflectance(lam, c, 1.33, 300.0, 1.5),
        "multilayer": lambda: ti.multilayer(lam, c, idx, thk)[0],
        "fresnel_reflectance": lambda: ti.optics.fresnel_reflectance(c, 1.0, 1.5),
        "rough_multilayer_reflectance": lambda: ti.optics.rough_multilayer_reflectance(
            lam, c, idx[:3], thk[:1], 20.0, 300.0),
    }


def test_hot_kernels_never_read_values_back_to_the_host():
    """With value checks off (``torchirid.options(value_checks=False)``: the per-call argument checks are the
    only reads), the spectral kernels run on ``meta`` tensors: shapes and dtypes only, no values,
    so any ``.item()``, ``.tolist()``, host copy or data-dependent branch would raise."""
    meta = torch.device("meta")
    with ti.options(value_checks=False):
        for name, call in _hot_kernels(meta, 10_000).items():
            out = call()
            assert out.device.type == "meta" and out.numel() >= 10_000 // 100, name


@pytest.mark.skipif(not torch.cuda.is_available(), reason="no CUDA device: the sync count needs one")
def test_cuda_synchronisations_do_not_grow_with_the_blocks():
    """On CUDA, every host–device synchronisation (an ``.item()``, a host copy, a data-dependent
    shape) is counted with ``torch.cuda.set_sync_debug_mode``: a kernel evaluated in 40 blocks
    must synchronise no more often than in one (none per block)."""
    dev = torch.device("cuda")

    def syncs(call):
        torch.cuda.synchronize()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            torch.cuda.set_sync_debug_mode("warn")
            try:
                call()
            finally:
                torch.cuda.set_sync_debug_mode("default")
        return sum("synchroniz" in str(w.message) for w in caught)

    counts = {}
    with ti.options(value_checks=False):
        small, big = _hot_kernels(dev, 4_000), _hot_kernels(dev, 160_000)
        for name in small:
            with ti.options(chunk_size=4_000):
                small[name]()  # warm-up (caches)
                counts[name] = (syncs(small[name]), syncs(big[name]))
    grew = {k: v for k, v in counts.items() if v[1] > v[0]}
    assert not grew, f"synchronisations (1 block, 40 blocks): {grew}"
    print("CUDA synchronisations per call (1 block, 40 blocks):", counts)
