"""torchirid.presets (Fourneau et al. 2024 Table 3 and Fig. 7) and tensor parameters of RoughBraggLayer."""

from __future__ import annotations

import pytest
import torch

from torchirid.layered import LayeredBragg, RoughBraggLayer, single_reflection_brdf
from torchirid.presets import JEWEL_BEETLE_NAMES, fourneau_fig7, jewel_beetle

# Table 3: n1, n2, Λ (nm), δ, N
TABLE_3 = {"green": (1.59, 1.67, 160.0, 0.51, 8), "red": (1.60, 1.68, 190.0, 0.51, 8),
           "purple": (1.60, 1.68, 205.0, 0.51, 6)}


@pytest.mark.parametrize("name", JEWEL_BEETLE_NAMES)
def test_presets_match_table_3(name):
    n1, n2, period, delta, cells = TABLE_3[name]
    s = jewel_beetle(name)
    (layer,) = s.layers
    assert (layer.n1, layer.n2, layer.cells, layer.alpha, layer.n_incident, s.base_albedo) == (n1, n2, cells, 0.05, 1.0, 0.0)
    assert layer.d2 == pytest.approx(delta * period, abs=1e-12)  # δ: fraction of Λ in the n2 layer
    assert layer.d1 == pytest.approx((1 - delta) * period, abs=1e-12)
    assert not s.coated


def test_presets_names_and_errors():
    assert JEWEL_BEETLE_NAMES == ("green", "red", "purple")
    with pytest.raises(ValueError, match="'green', 'red', 'purple'"):
        jewel_beetle("blue")
    assert jewel_beetle("red", base_albedo=0.1, alpha=0.1).layers[0].alpha == 0.1
    two = jewel_beetle("green", layers=2)
    assert len(two.layers) == 2 and two.layers[0] == two.layers[1] == jewel_beetle("green").layers[0]
    for bad in (0, 1.5, True):
        with pytest.raises(ValueError, match="layers"):
            jewel_beetle("green", layers=bad)


def test_fig7_structures():
    # Fourneau et al. 2024 Fig. 7: n2 = 1.5, N = 10; A d = 250 nm α = 0.1, B d = 494 nm α = 0.05,
    # A′ = A under a coating of index 1.35
    for name, (n1, d, alpha) in {"a": (1.0, 250.0, 0.1), "b": (1.0, 494.0, 0.05),
                                 "a_coated": (1.35, 250.0, 0.1)}.items():
        s = fourneau_fig7(name, layers=2, base_albedo=0.5)
        assert len(s.layers) == 2 and s.base_albedo == 0.5 and s.coated == (n1 != 1.0)
        (layer,) = set(s.layers)
        assert (layer.n1, layer.n2, layer.d1, layer.d2, layer.cells, layer.alpha, layer.n_incident) == (
            n1, 1.5, d, d, 10, alpha, n1)
    s = fourneau_fig7("b")
    assert len(s.layers) == 1 and s.base_albedo == 0.0
    with pytest.raises(ValueError, match="'a', 'b', 'a_coated'"):
        fourneau_fig7("c")
    with pytest.raises(ValueError, match="layers"):
        fourneau_fig7("a", layers=0)
    with pytest.raises(ValueError, match="base_albedo"):
        fourneau_fig7("a", base_albedo=1.5)


def test_normal_incidence_hue_order():
    # peaks at 2 n̄ Λ: green ≈ 522 nm, red ≈ 623 nm, purple ≈ 672 nm
    lam = torch.linspace(400.0, 750.0, 71, dtype=torch.float64)
    n = torch.tensor([[0.0, 0.0, 1.0]], dtype=torch.float64)
    peaks = [float(lam[single_reflection_brdf(lam, n, n, jewel_beetle(k), transmissivity_angles=2)[0].argmax()]) for k in JEWEL_BEETLE_NAMES]
    assert 500 < peaks[0] < 545 and 600 < peaks[1] < 645 and 650 < peaks[2] < 700


def test_layer_accepts_scalar_tensors():
    t = lambda v: torch.tensor(v, dtype=torch.float64, requires_grad=True)  # noqa: E731
    layer = RoughBraggLayer(t(1.6), t(1.68), t(93.0), t(97.0), 8, t(0.05), n_incident=1.0)
    assert layer.numbers() == {"n1": 1.6, "n2": 1.68, "d1": 93.0, "d2": 97.0, "cells": 8, "alpha": 0.05, "n_incident": 1.0}
    LayeredBragg([layer, RoughBraggLayer(t(1.6), 1.5, 10.0, 10.0, 2, 0.1, n_incident=1.0)])  # hosts compared by value
    RoughBraggLayer(1.0, torch.tensor(1.5 + 0.01j, dtype=torch.complex128), 10.0, 10.0, 2, 0.1)
    for kw in (dict(n1=torch.tensor([1.6])), dict(d1=torch.tensor(-1.0)), dict(alpha=torch.tensor(1)),
               dict(n2=torch.tensor(1.5 - 0.1j)), dict(n2=torch.tensor([1.5]))):
        args = dict(n1=1.6, n2=1.68, d1=93.0, d2=97.0, cells=8, alpha=0.05) | kw
        with pytest.raises(ValueError, match=next(iter(kw))):
            RoughBraggLayer(**args)
