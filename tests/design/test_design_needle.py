"""torchirid.design.needle: the needle derivatives are the merit's thickness derivative at 0."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from torchirid import design
from torchirid.design.merit import Evaluator
from torchirid.design.needle import _insert, needle_derivatives


def test_needle_derivatives_equal_finite_differences():
    lam = np.linspace(420, 680, 7)
    p = design.Problem([design.Layer("SiO2", (0, 300)), design.Layer("TiO2", (0, 300))],
                       [design.SpectralTarget("R", lam, value=0.0, cos_theta=[1.0, 0.7])], n_substrate="glass")
    materials, thicknesses = ["SiO2", "TiO2"], [97.0, 41.0]
    palette = ["SiO2", "TiO2"]
    P, rows, _ = needle_derivatives(p, materials, thicknesses, palette)
    assert len(rows) == len(P) and np.isfinite(P).all()
    h = 1e-4
    for i in np.linspace(0, len(rows) - 1, 6).astype(int):
        j, z, k = rows[i]  # the needle of material k at depth z of layer j: the stack split there
        mats = materials[:j] + [materials[j], palette[k], materials[j]] + materials[j + 1:]
        ds = thicknesses[:j] + [z, 0.0, thicknesses[j] - z] + thicknesses[j + 1:]
        at = j + 1
        ev = Evaluator(design.Problem([design.Layer(m, (0, 1e3)) for m in mats], p.targets, n_substrate="glass"))
        x = torch.tensor([ds], dtype=torch.float64)
        e = torch.zeros_like(x)
        e[0, at] = h
        fd = (ev.merit(x + e) - ev.merit(x)).item() / h
        assert P[i] == pytest.approx(fd, rel=2e-3, abs=1e-8)


def test_insert_splits_a_layer_and_drops_empty_pieces():
    assert _insert(["a", "b"], [10.0, 20.0], 1, 5.0, "c") == (["a", "b", "c", "b"], [10.0, 5.0, 0.0, 15.0])
    assert _insert(["a", "b"], [10.0, 20.0], 0, 0.0, "c") == (["c", "a", "b"], [0.0, 10.0, 20.0])
    assert _insert(["a", "b"], [10.0, 20.0], 1, 20.0, "c") == (["a", "b", "c"], [10.0, 20.0, 0.0])
