"""Chunked evaluation (issue 23.1): large batches are evaluated block by block when no gradient is
wanted; the values equal the one-piece evaluation (to the last bit or two: vectorised loop tails),
and gradients, shapes and dtypes are unchanged."""

from __future__ import annotations

import pytest
import torch

import torchirid as ti
from torchirid import _chunks

F64 = torch.float64


def _grid(W=401, A=90, dtype=F64):
    lam = torch.linspace(380.0, 780.0, W, dtype=dtype)
    c = torch.cos(torch.linspace(0.0, 1.5707963, A, dtype=dtype))[:, None]
    return lam, c


CASES = {
    "bragg": lambda lam, c: ti.bragg_reflectance(lam, c, 1.0, 1.5, 125.0, 375.0, 20),
    "bragg_tir": lambda lam, c: ti.bragg_reflectance(lam, c, 1.5, 1.2, 125.0, 375.0, 20),
    "bragg_absorbing": lambda lam, c: ti.bragg_reflectance(lam, c, 1.0, 1.5 + 0.01j, 125.0, 375.0, 9),
    "bragg_host": lambda lam, c: ti.bragg_reflectance(lam, c, 1.2, 1.6, 125.0, 375.0, 20, n_incident=1.0),
    "thin_film": lambda lam, c: ti.thin_film_reflectance(lam, c, 1.33, 800.0, 0.2 + 3.0j),
    "thin_film_batch_d": lambda lam, c: ti.thin_film_reflectance(lam, c[:, :, None], 1.33,
                                                                 torch.tensor([[10.0], [300.0]], dtype=lam.dtype), 1.5),
    # multilayer: two outputs (R, T stacked), indices and thicknesses with a trailing stack axis
    "multilayer": lambda lam, c: torch.stack(ti.multilayer(lam, c, _STACK[0], _STACK[1])),
    "multilayer_absorbing_grazing": lambda lam, c: torch.stack(ti.multilayer(
        lam, c, torch.tensor([1.0, 1.6, 0.2 + 3.0j, 1.38, 1.5 + 0.1j], dtype=torch.complex128),
        torch.tensor([80.0, 30.0, 0.0], dtype=F64))),
    # a batch of stacks: the stack axis is a batch axis of indices and thicknesses
    "multilayer_batch_stacks": lambda lam, c: torch.stack(ti.multilayer(
        lam[:, None], c[:, :, None], _STACK[0].expand(3, 12).clone(),
        _STACK[1] * torch.tensor([[0.5], [1.0], [2.0]], dtype=F64))),
}

_STACK = (torch.tensor([1.0] + [1.38, 2.3] * 5 + [1.52], dtype=torch.complex128),
          torch.tensor([100.0, 60.0] * 5, dtype=F64))


@pytest.mark.parametrize("name", sorted(CASES))
@pytest.mark.parametrize("points", [1, 977, 5000])
def test_chunked_equals_one_piece(name, points):
    lam, c = _grid()
    with ti.options(chunk_size=None):
        ref = CASES[name](lam, c)
    with ti.options(chunk_size=points):
        got = CASES[name](lam, c) if points > 1 else CASES[name](lam[:37], c[:5])
    if points == 1:
        with ti.options(chunk_size=None):
            ref = CASES[name](lam[:37], c[:5])
    assert got.shape == ref.shape and got.dtype == ref.dtype
    # ≤ a few ulp (vectorised loop tails); Bragg's real closed form picks its guarded branch near
    # critical angles from the minimum over the batch it is given, so a block may take the other
    # (equally accurate, 1e-12 vs tmm) branch: up to 5e-13 there (bragg_tir)
    torch.testing.assert_close(got, ref, rtol=0, atol=1e-12 if name.startswith("bragg") else 4e-15)
    assert not got.is_inference()


def test_float32_and_gradients_unchanged():
    lam, c = _grid(dtype=torch.float32)
    with ti.options(chunk_size=None):
        ref = CASES["bragg"](lam, c)
    with ti.options(chunk_size=1000):
        got = CASES["bragg"](lam, c)
    assert got.dtype == torch.float32
    torch.testing.assert_close(got, ref, rtol=0, atol=2e-6)
    d = torch.tensor(300.0, dtype=F64, requires_grad=True)
    lam, c = _grid()
    with ti.options(chunk_size=1000):  # a gradient is wanted: one piece, autograd as usual
        R = ti.thin_film_reflectance(lam, c, 1.33, d, 1.5)
    R.sum().backward()
    assert d.grad is not None and torch.isfinite(d.grad)


def test_knob():
    assert _chunks.get_chunk_size() == 1 << 15
    with ti.options(chunk_size=123):
        assert _chunks.get_chunk_size() == 123
        with ti.options(chunk_size=0):
            assert _chunks.get_chunk_size() is None
    assert _chunks.get_chunk_size() == 1 << 15
    for bad in (-1, 2.5, True, "1"):
        with pytest.raises(ValueError, match="points"):
            ti.options(chunk_size=bad)


def test_the_default_block_size_follows_the_inputs_device(monkeypatch):
    from torchirid import _chunks

    assert _chunks.get_chunk_size("cuda") == _chunks.DEVICE_CHUNK_SIZE > _chunks.get_chunk_size("cpu") == 1 << 15
    with ti.options(chunk_size=5000):  # a set size holds on every device
        assert _chunks.get_chunk_size("cuda") == _chunks.get_chunk_size() == 5000
    seen = []

    def kernel(x):
        seen.append((x.device.type, x.numel()))
        return 2 * x

    monkeypatch.setattr(_chunks, "default_chunk_size", lambda device=None: {"cpu": 1000, "meta": 10_000}[
        torch.device(device).type])
    for dev in ("cpu", "meta"):
        x = torch.zeros(100, 1000, device=dev)
        out = _chunks.evaluate(kernel, (x,), x.shape)
        assert out.device.type == dev and out.shape == x.shape
    assert {s for s in seen if s[0] == "cpu"} == {("cpu", 1000)}
    assert {s for s in seen if s[0] == "meta"} == {("meta", 10_000)}


@pytest.mark.parametrize("name", ["thin_film", "multilayer", "bragg"])
def test_gradients_checkpointed_equal_one_piece(name, monkeypatch):
    """With a gradient, batches over CHECKPOINT_POINTS run in checkpointed blocks: the values and
    gradients equal the one-piece graph's."""
    import torchirid._chunks as chunks

    lam, c = _grid(W=101, A=30)
    d = torch.tensor(300.0, dtype=F64, requires_grad=True)
    calls = {
        "thin_film": lambda: ti.thin_film_reflectance(lam, c, 1.33, d, 0.2 + 3.0j),
        "multilayer": lambda: sum(ti.multilayer(lam, c, _STACK[0], _STACK[1] * (d / 300.0))),
        "bragg": lambda: ti.bragg_reflectance(lam, c, 1.0, 1.5, 125.0, d, 20),
    }
    with ti.options(chunk_size=None):
        ref = calls[name]()
        (g_ref,) = torch.autograd.grad(ref.square().sum(), d)
    monkeypatch.setattr(chunks, "CHECKPOINT_POINTS", 1000)
    calls_made = []
    real = torch.utils.checkpoint.checkpoint

    def spy(*args, **kwargs):
        calls_made.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(torch.utils.checkpoint, "checkpoint", spy)
    with ti.options(chunk_size=500):
        got = calls[name]()
        (g,) = torch.autograd.grad(got.square().sum(), d)
    assert len(calls_made) >= 6  # 3030 points in blocks of ≤ 500
    assert got.shape == ref.shape and got.requires_grad
    torch.testing.assert_close(got, ref, rtol=0, atol=1e-12)
    torch.testing.assert_close(g, g_ref, rtol=1e-11, atol=1e-9)


def test_checkpointed_memory_is_bounded():
    """A gradient through a 2·10⁶-point thin-film grid keeps one block's graph (checkpointing):
    the autograd graph saved for backward is a few output sizes, not tens."""
    lam = torch.linspace(380.0, 780.0, 2000, dtype=F64)
    c = torch.cos(torch.linspace(0.0, 1.5, 1000, dtype=F64))[:, None]
    d = torch.tensor(300.0, dtype=F64, requires_grad=True)
    saved = []

    def pack(t):
        saved.append(t.untyped_storage().nbytes())
        return t

    with torch.autograd.graph.saved_tensors_hooks(pack, lambda t: t):
        R = ti.thin_film_reflectance(lam, c, 1.33, d, 1.5)
    out = R.numel() * 8
    # checkpointing saves each block's inputs (views of lam, c) and nothing of the kernel's graph
    assert sum(saved) < 3 * out, sum(saved) / out
    R.sum().backward()
    assert torch.isfinite(d.grad)


def _in_blocks(call):
    """``call()`` with blocks of 4 points, checking that it was evaluated in blocks."""
    import torchirid._chunks as chunks

    blocks = []
    real_take = chunks._take
    with ti.options(chunk_size=4), pytest.MonkeyPatch.context() as mp:
        mp.setattr(chunks, "_take", lambda *a: blocks.append(1) or real_take(*a))
        got = call()
    assert blocks, "the call was not evaluated in blocks"
    return got


def _colour_cases():
    from torchirid.ibl import thin_film_xyz_filtered, thin_film_xyz_fitted, thin_film_xyz_fourier
    from torchirid.layered import RoughBraggLayer
    from torchirid.layered.transmission import integrated_transmissivity
    from torchirid.spectral.envelope import bragg_xyz_envelope

    c = torch.linspace(0.05, 1.0, 7, dtype=F64)[:, None]
    d = torch.linspace(50.0, 900.0, 9, dtype=F64)
    wo = torch.nn.functional.normalize(torch.stack([torch.sin(torch.acos(c)) + 0 * d, 0 * d + 0 * c, c + 0 * d], -1),
                                       dim=-1)
    mu = 0.97 * wo * torch.tensor([-1.0, 1.0, 1.0], dtype=F64)
    cov = 1e-3 * torch.eye(3, dtype=F64)
    layer = RoughBraggLayer(1.0, 1.5, 110.0, 75.0, 10, 0.1)
    lam = torch.linspace(400.0, 700.0, 31, dtype=F64)
    return {
        "fourier_lut": lambda: thin_film_xyz_fourier(c, 1.33, d, 0.2 + 3.0j),
        "fourier_exact": lambda: thin_film_xyz_fourier(c, 1.33, d, 1.5, sensitivity="exact", terms=2),
        "fitted_lut": lambda: thin_film_xyz_fitted(c, 0.2, 1.3, d, complex(2.0, 0.5), sensitivity="lut"),
        "fitted_exact": lambda: thin_film_xyz_fitted(c[::3], 0.2, 1.3, d[::4], 1.5, terms=1, sensitivity="exact"),
        "filtered": lambda: thin_film_xyz_filtered(wo, mu, cov, 1.3, d, complex(2.0, 0.5), sensitivity="lut"),
        "transmissivity": lambda: integrated_transmissivity(lam, c, layer, nodes=64),
        "envelope": lambda: bragg_xyz_envelope(c, 1.0, 1.5, 125.0, d[:, None, None] * 0 + 375.0, 20),
        "piecewise": lambda: ti.bragg_xyz(c, 1.0, 1.5, 125.0, d[:, None, None] * 0.5 + 300.0, 20,
                                          method="piecewise"),
    }


@pytest.mark.parametrize("name", ["fourier_lut", "fourier_exact", "fitted_lut", "fitted_exact", "filtered",
                                  "transmissivity", "envelope", "piecewise"])
def test_colour_tables_chunked_equal_one_piece(name):
    """The colour and transmissivity tables (trailing XYZ axis, inner quadratures: blocks of
    chunk_size // width points) equal their one-piece evaluation."""
    case = _colour_cases()[name]
    with ti.options(chunk_size=None):
        ref = case()
    got = _in_blocks(case)
    assert got.shape == ref.shape and got.dtype == ref.dtype
    torch.testing.assert_close(got, ref, rtol=0, atol=1e-14)


def test_fitted_table_gradient_survives_chunking():
    """A table whose values require a gradient (LUT fitting) takes the gradient path, not the
    inference-mode blocks."""
    from torchirid.ibl import thin_film_xyz_fitted, shipped_light_mixture_lut
    from torchirid.lut import LUT

    base = shipped_light_mixture_lut()
    values = base.values.clone().requires_grad_()
    table = LUT(values, base.axes, builder=base.builder, parameters=base.parameters, units=base.units)
    c = torch.linspace(0.1, 1.0, 40, dtype=F64)[:, None]
    d = torch.linspace(100.0, 600.0, 30, dtype=F64)
    with ti.options(chunk_size=8):
        xyz = thin_film_xyz_fitted(c, 0.3, 1.3, d, 1.5, table=table, sensitivity="lut")
    xyz.sum().backward()
    assert values.grad is not None and bool(values.grad.abs().sum() > 0)


@pytest.mark.parametrize("lut", [False, True])
def test_single_reflection_brdf_chunked_equals_one_piece(lut):
    """Direction pairs (a trailing vector axis in, a trailing wavelength axis out) in blocks."""
    from torchirid.layered import LayeredBragg, RoughBraggLayer, single_reflection_brdf

    s = LayeredBragg([RoughBraggLayer(1.0, 1.5, 250.0, 250.0, 10, 0.1),
                      RoughBraggLayer(1.0, 1.6, 120.0, 180.0, 6, 0.2)], base_albedo=0.3)
    t = torch.linspace(0.0, 1.4, 9, dtype=F64)
    wi = torch.stack([torch.sin(t), 0 * t, torch.cos(t)], -1)[:, None]
    wo = torch.stack([-torch.sin(t) * 0.5, torch.sin(t) * 0.3, torch.cos(t)], -1)
    wo = wo / torch.linalg.vector_norm(wo, dim=-1, keepdim=True)
    lam = torch.linspace(400.0, 700.0, 16, dtype=F64)
    with ti.options(chunk_size=None):
        ref = single_reflection_brdf(lam, wi, wo, s, reflectance="lut" if lut else "exact", transmissivity_angles=16, reflectance_angles=32)
    got = _in_blocks(lambda: single_reflection_brdf(lam, wi, wo, s, reflectance="lut" if lut else "exact", transmissivity_angles=16,
                                                    reflectance_angles=32))
    assert got.shape == ref.shape == (9, 9, 16)
    torch.testing.assert_close(got, ref, rtol=0, atol=1e-14)


def test_ibl_ground_truths_chunked_equal_one_piece():
    """thin_film_xyz_uniform and path_difference_moments over geometries × films in blocks (the
    broadcast matmul of the one-piece path copied both to the full batch)."""
    from torchirid.ibl import path_difference_moments, thin_film_xyz_uniform

    c = torch.linspace(0.2, 1.0, 12, dtype=F64)[:, None]
    d = torch.linspace(100.0, 700.0, 5, dtype=F64)
    lam = torch.linspace(380.0, 780.0, 41, dtype=F64)
    for call in (lambda: thin_film_xyz_uniform(c, 0.2, 1.3, d, 1.5, bins=64, nodes=8, wavelength=lam),
                 lambda: torch.stack(torch.broadcast_tensors(*path_difference_moments(c, 0.2, 1.3, d, bins=64,
                                                                                      nodes=8)))):
        with ti.options(chunk_size=None):
            ref = call()
        got = _in_blocks(call)
        assert got.shape == ref.shape
        torch.testing.assert_close(got, ref, rtol=0, atol=1e-14)
