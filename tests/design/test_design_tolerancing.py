"""torchirid.design.tolerancing: merit and ΔE distributions and the yield against tmm Monte Carlo."""

from __future__ import annotations

import math

import numpy as np
import pytest

from oracles import colour_lab, material_nk, tmm_RT
from torchirid import design

QW = [600 / (4 * n) for n in (1.8, 1.4) * 4]


def _mirror(lam=(580.0, 600.0, 620.0)):
    return design.Problem([design.Layer(m, d) for m, d in zip((1.8, 1.4) * 4, QW)],
                          [design.SpectralTarget("R", list(lam), value=1.0, p=1)], n_substrate=1.8)


def _tmm_merit(d, lam=(580.0, 600.0, 620.0)):
    return np.mean([1 - tmm_RT(w, 1.0, [1.0, *(1.8, 1.4) * 4, 1.8], d, "unpolarized")[0] for w in lam])


def test_same_draws_give_tmm_merits():
    t = design.tolerance(_mirror(), sigma=1.0, samples=200, seed=2)
    ref = np.array([_tmm_merit(d) for d in t.thicknesses])
    np.testing.assert_allclose(t.merits, ref, rtol=0, atol=1e-12)
    assert t.nominal == pytest.approx(_tmm_merit(QW), abs=1e-12)


def test_yield_agrees_with_an_independent_tmm_monte_carlo():
    """σ = 1 nm: the yield (merit within 0.1 % of the nominal: about half the draws) of 20 000
    library draws against 3000 independent draws through tmm, within ±2 points (their Monte Carlo
    noise: ~1 point)."""
    p = _mirror()
    nominal = _tmm_merit(QW)
    limit = nominal * 1.001
    t = design.tolerance(p, sigma=1.0, samples=20000, seed=0, merit_limit=limit)
    rng = np.random.default_rng(12345)
    draws = np.clip(np.array(QW) + rng.standard_normal((3000, 8)), 0, None)
    ref = np.mean([_tmm_merit(d) <= limit for d in draws])
    assert 0.1 < ref < 0.9  # the limit makes the yield informative
    assert abs(t.yield_fraction - ref) <= 0.02
    assert t.standard_error == pytest.approx(math.sqrt(t.yield_fraction * (1 - t.yield_fraction) / 20000))


def test_relative_errors_and_per_layer_sigma():
    t = design.tolerance(_mirror(), sigma=[0.0] * 7 + [0.02], relative=True, samples=500, seed=1)
    spread = t.thicknesses - np.array(QW)
    assert np.all(spread[:, :7] == 0)
    assert np.std(spread[:, 7]) == pytest.approx(0.02 * QW[7], rel=0.15)


def test_colour_differences_against_colour_science():
    lam = np.arange(360.0, 781.0, 5.0)
    mats, d = ["TiO2", "SiO2"], [60.0, 150.0]
    cos = [1.0, math.cos(math.radians(45))]
    labs = []
    for c in cos:
        R = [tmm_RT(w, c, [1.0, *(complex(material_nk(m, w)) for m in mats), complex(material_nk("SiO2", w))], d,
                    "unpolarized")[0] for w in lam]
        labs.append(colour_lab(lam, R))
    p = design.Problem([design.Layer(m, t) for m, t in zip(mats, d)], [design.ColourTarget(labs, cos_theta=cos)],
                       n_substrate="glass")
    t = design.tolerance(p, sigma=2.0, samples=300, seed=4)
    assert t.delta_e.shape == (300, 2) and t.delta_e_limit == 1.0 and t.merit_limit is None
    assert t.nominal < 0.05  # the target is this stack's own colour (trapezoid vs rectangle rule)
    assert t.yield_fraction == pytest.approx(np.mean((t.delta_e <= 1.0).all(-1)))
    import colour

    for i in (0, 1):
        R = [tmm_RT(w, cos[1], [1.0, *(complex(material_nk(m, w)) for m in mats), complex(material_nk("SiO2", w))],
                    t.thicknesses[i].tolist(), "unpolarized")[0] for w in lam]
        assert t.delta_e[i, 1] == pytest.approx(colour.delta_E(labs[1], colour_lab(lam, R), method="CIE 2000"), abs=0.02)


def test_tolerance_errors():
    free = design.Problem([design.Layer(1.5, (0, 100))], [design.SpectralTarget("R", [500.0])])
    with pytest.raises(ValueError, match="fixed"):
        design.tolerance(free)
    with pytest.raises(ValueError, match="sigma"):
        design.tolerance(_mirror(), sigma=-1)
    with pytest.raises(ValueError, match="samples"):
        design.tolerance(_mirror(), samples=0)
