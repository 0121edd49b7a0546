"""Tests of torchirid.layered.structure: the description of a layered Bragg structure.

``RoughBraggLayer.reflectance`` is one mirror of the layer, ``n_incident | (n2, d2), (n1, d1) × N | n1``
(Fourneau et al. 2024 §4.1 and appendix D): checked against the ``tmm`` package's coherent
transfer matrices on the same stack (lossless and absorbing n2, lit from the host and from
another medium); the parameter checks name the parameter; ``LayeredBragg`` derives its coating
from the shared host index.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from oracles import tmm_RT
from tensors import F64, t64
from torchirid.layered.structure import LayeredBragg, RoughBraggLayer

LAM = [420.0, 515.0, 600.0, 710.0]
COS = [1.0, 0.8, 0.35]


def _tmm_mirror(layer: RoughBraggLayer, lam: float, cos_theta: float) -> float:
    """Unpolarized R of ``n_incident | (n2, d2), (n1, d1) × cells | n1`` by tmm (cos θ in n_incident)."""
    indices = [layer.n_incident] + [layer.n2, layer.n1] * layer.cells + [layer.n1]
    thicknesses = [layer.d2, layer.d1] * layer.cells
    return tmm_RT(lam, cos_theta, indices, thicknesses, "unpolarized")[0]


@pytest.mark.parametrize("layer", [
    RoughBraggLayer(1.0, 1.5, 125.0, 375.0, 20, 0.1),  # Fourneau's Fig. 1 mirror in air
    RoughBraggLayer(1.55, 1.7, 90.0, 80.0, 12, 0.2),  # low contrast, in its host
    RoughBraggLayer(1.4, 1.6 + 0.02j, 110.0, 95.0, 8, 0.1),  # absorbing n2
    RoughBraggLayer(1.56, 1.68, 100.0, 70.0, 10, 0.05, n_incident=1.0),  # a cuticle lit from air
], ids=["fig1", "low-contrast", "absorbing", "from-air"])
def test_mirror_reflectance_is_the_transfer_matrix_reflectance(layer):
    lam, c = t64(LAM)[:, None], t64(COS)
    got = layer.reflectance(lam, c)
    ref = np.array([[_tmm_mirror(layer, wl, ct) for ct in COS] for wl in LAM])
    assert got.shape == (len(LAM), len(COS)) and got.dtype == F64
    np.testing.assert_allclose(got.numpy(), ref, rtol=1e-10, atol=1e-13)


def test_tensor_parameters_give_the_number_reflectance_and_its_gradient():
    d2 = t64(375.0).requires_grad_(True)
    layer = RoughBraggLayer(1.0, 1.5, 125.0, d2, 20, 0.1)
    assert layer.tensors() == (d2,) and layer.numbers()["d2"] == 375.0
    lam, c = t64([480.0, 560.0, 650.0]), t64(0.9)
    R = layer.reflectance(lam, c)
    plain = RoughBraggLayer(1.0, 1.5, 125.0, 375.0, 20, 0.1).reflectance(lam, c)
    torch.testing.assert_close(R.detach(), plain, rtol=1e-14, atol=0)
    (grad,) = torch.autograd.grad(R.sum(), d2)
    h = 1e-4  # central difference of tmm's reflectance in d2
    fd = sum((_tmm_mirror(RoughBraggLayer(1.0, 1.5, 125.0, 375.0 + h, 20, 0.1), wl, 0.9)
              - _tmm_mirror(RoughBraggLayer(1.0, 1.5, 125.0, 375.0 - h, 20, 0.1), wl, 0.9)) / (2 * h)
             for wl in lam.tolist())
    assert math.isclose(float(grad), fd, rel_tol=1e-5)


def test_n_incident_defaults_to_the_host_and_numbers_are_plain():
    layer = RoughBraggLayer(1.5, t64(1.8), 100.0, 80.0, 10, t64(0.2))
    assert layer.n_incident == 1.5
    numbers = layer.numbers()
    assert numbers == {"n1": 1.5, "n2": 1.8, "d1": 100.0, "d2": 80.0, "cells": 10, "alpha": 0.2, "n_incident": 1.5}
    assert all(type(v) in (int, float) for v in numbers.values())
    assert len(layer.tensors()) == 2


@pytest.mark.parametrize("kwargs, name", [
    (dict(n1=0.0), "n1"), (dict(n1=-1.5), "n1"), (dict(d1=0.0), "d1"), (dict(d2=-80.0), "d2"),
    (dict(alpha=0.0), "alpha"), (dict(alpha=True), "alpha"), (dict(d1=t64([100.0, 120.0])), "d1"),
    (dict(d1=torch.tensor(100)), "d1"), (dict(n2=-1.8), "n2"), (dict(n2=1.8 - 0.1j), "n2"), (dict(n2="1.8"), "n2"),
    (dict(n_incident=0.0), "n_incident"), (dict(n_incident=1.0 + 0.1j), "n_incident"),
    (dict(cells=0), "cells"), (dict(cells=2.5), "cells"),
])
def test_bad_layer_parameters_raise_naming_the_parameter(kwargs, name):
    args = dict(n1=1.5, n2=1.8, d1=100.0, d2=80.0, cells=10, alpha=0.1) | kwargs
    with pytest.raises(ValueError, match=rf"\b{name}\b"):
        RoughBraggLayer(**args)


def test_structure_coating_follows_the_host_index():
    a = RoughBraggLayer(1.5, 1.8, 100.0, 90.0, 10, 0.1)
    b = RoughBraggLayer(1.5, 1.8, 130.0, 110.0, 10, 0.3)
    s = LayeredBragg([a, b], base_albedo=0.2)
    assert s.layers == (a, b) and s.base_albedo == 0.2
    assert s.coated and s.n_coating == 1.5
    bare = LayeredBragg([RoughBraggLayer(1.0, 1.5, 125.0, 375.0, 20, 0.1)])
    assert not bare.coated and bare.n_coating == 1.0 and bare.base_albedo == 0.0
    lit_from_air = LayeredBragg([RoughBraggLayer(1.56, 1.68, 100.0, 70.0, 10, 0.05, n_incident=1.0)])
    assert not lit_from_air.coated  # the host n_incident, not n1, is the coating medium


@pytest.mark.parametrize("layers, albedo, match", [
    ([], 0.0, "layers"),
    (["not a layer"], 0.0, "layers"),
    ([RoughBraggLayer(1.5, 1.8, 100.0, 90.0, 10, 0.1), RoughBraggLayer(1.4, 1.8, 100.0, 90.0, 10, 0.1)], 0.0, "host"),
    ([RoughBraggLayer(1.5, 1.8, 100.0, 90.0, 10, 0.1)], 1.5, "base_albedo"),
    ([RoughBraggLayer(1.5, 1.8, 100.0, 90.0, 10, 0.1)], -0.1, "base_albedo"),
    ([RoughBraggLayer(1.5, 1.8, 100.0, 90.0, 10, 0.1)], True, "base_albedo"),
])
def test_bad_structures_raise(layers, albedo, match):
    with pytest.raises(ValueError, match=match):
        LayeredBragg(layers, base_albedo=albedo)
