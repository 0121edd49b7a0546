"""The kernels under ``torch.func.vmap`` and ``torch.compile(fullgraph=True)`` (issue 22.7).

Value checks read tensors back to Python, which vmap cannot do and which breaks a full graph.
``torchirid.options(value_checks=False)`` turns them off, and torch.compile
turns them off by itself while it traces; either way the kernels take their masked branches
unconditionally. Reference: the same functions called eagerly on the whole batch."""

from __future__ import annotations

import pytest
import torch

import torchirid as ti

F64 = torch.float64
LAM = torch.tensor(550.0, dtype=F64)
D = torch.tensor([0.0, 100.0, 237.5, 1200.0], dtype=F64)


def _cases():
    c = torch.tensor(0.8, dtype=F64)
    stack = torch.tensor([1.0, 1.5, 2.0, 0.2 + 3.0j], dtype=torch.complex128)
    return {
        "thin_film": (lambda d: ti.thin_film_reflectance(LAM, c, 1.4, d, 1.5),
                      lambda d: ti.thin_film_reflectance(LAM, c, 1.4, d, 1.5)),
        "bragg_real": (lambda d: ti.bragg_reflectance(LAM, c, 1.0, 1.5, d, 300.0, 20),
                       lambda d: ti.bragg_reflectance(LAM, c, 1.0, 1.5, d, 300.0, 20)),
        # total internal reflection in n2 at this angle for part of the batch: the general path
        "bragg_tir": (lambda d: ti.bragg_reflectance(LAM, torch.tensor(0.3, dtype=F64), 1.5, 1.2, d, 300.0, 7),
                      lambda d: ti.bragg_reflectance(LAM, torch.tensor(0.3, dtype=F64), 1.5, 1.2, d, 300.0, 7)),
        "bragg_absorbing": (lambda d: ti.bragg_reflectance(LAM, c, 1.0, 1.5 + 0.01j, d, 300.0, 9),
                            lambda d: ti.bragg_reflectance(LAM, c, 1.0, 1.5 + 0.01j, d, 300.0, 9)),
        "multilayer": (lambda d: ti.multilayer(LAM, c, stack, torch.stack([d, 80.0 + 0 * d], -1))[0],
                       lambda d: ti.multilayer(LAM, c, stack, torch.stack([d, 80.0 + 0 * d], -1))[0]),
    }


@pytest.mark.parametrize("name", sorted(_cases()))
def test_vmap_with_value_checks_off(name):
    one, batched = _cases()[name]
    ref = batched(D)
    with ti.options(value_checks=False):
        got = torch.func.vmap(one)(D)
    torch.testing.assert_close(got, ref, rtol=0, atol=1e-13)


def test_vmap_needs_the_switch():
    one, _ = _cases()["thin_film"]
    assert ti.options("value_checks")
    with pytest.raises(RuntimeError, match="vmap"):  # (.item() / data-dependent control flow)
        torch.func.vmap(one)(D)


def test_switch_is_scoped_and_checked():
    with ti.options(value_checks=False):
        assert not ti.options("value_checks")
        ti.thin_film_reflectance(5e-7, 1.0, 1.4, 100.0, 1.5)  # no unit check with the checks off
    assert ti.options("value_checks")
    with pytest.raises(ValueError, match="wavelength must be in nm"):
        ti.thin_film_reflectance(5e-7, 1.0, 1.4, 100.0, 1.5)
    with pytest.raises(ValueError, match="value_checks must be True or False"):
        ti.options(value_checks="no")
    ti.options(value_checks=False)
    try:
        assert not ti.options("value_checks")
    finally:
        ti.options(value_checks=True)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["thin_film", "bragg_real", "multilayer"])
def test_compile_fullgraph(name):
    """No switch needed: the checks step aside while torch.compile traces."""
    pytest.importorskip("torch._dynamo")
    one, batched = _cases()[name]
    torch._dynamo.reset()
    try:
        fn = torch.compile(one, fullgraph=True, backend="aot_eager")  # (no C++ compiler needed)
        got = fn(D)
    except Exception as exc:  # pragma: no cover - the failure is the finding
        pytest.fail(f"torch.compile(fullgraph=True) failed: {exc!r}")
    torch.testing.assert_close(got, batched(D), rtol=0, atol=1e-12)
