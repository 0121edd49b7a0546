"""torchirid.design.search: the optimisers reach known optima, reproducibly, within their budget."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
import torch

from oracles import colour_lab, material_nk, tmm_RT
from torchirid import design

#: PyMoosh's ``bragg`` problem: 1 − R of the quarter-wave stack (the known optimum), N layers
BRAGG_OPTIMUM = {10: 0.16485577190, 20: 0.01447894191, 40: 9.5716746e-5}


def bragg(n: int) -> design.Problem:
    """PyMoosh 4.0.1's ``bragg``: air | (1.8, 1.4) × N/2 | 1.8, λ = 600 nm, normal, TE, cost 1 − R."""
    return design.Problem([design.Layer(m, (0.0, 600 / (2 * 1.4))) for m in (1.8, 1.4) * (n // 2)],
                          [design.SpectralTarget("R", [600.0], value=1.0, polarization="s", p=1)],
                          n_incident=1.0, n_substrate=1.8)


def pymoosh_cost(n: int, x) -> float:
    pm = pytest.importorskip("PyMoosh", reason="PyMoosh is not installed")
    struct = pm.Structure([1.0, 1.4**2, 1.8**2], [0] + [2, 1] * (n // 2) + [2], [0.0, *x, 0.0], verbose=False)
    return 1 - pm.coefficient(struct, 600.0, 0.0, 0)[2]


@pytest.mark.parametrize("seed", range(5))
def test_bragg_20_reaches_the_quarter_wave_optimum(seed):
    d = design.optimise(bragg(20), seed=seed)
    assert len(d.thicknesses) == 20
    cost = pymoosh_cost(20, d.thicknesses)  # the peer's own cost of the returned design
    assert cost == pytest.approx(BRAGG_OPTIMUM[20], rel=1e-3)
    assert d.merit == pytest.approx(cost, rel=1e-9)
    np.testing.assert_allclose(d.thicknesses, [600 / (4 * n) for n in (1.8, 1.4) * 10], atol=0.5)


@pytest.mark.slow
def test_bragg_40_reaches_the_quarter_wave_optimum():
    d = design.optimise(bragg(40), seed=0)
    assert pymoosh_cost(40, d.thicknesses) <= 9.6e-5


def test_same_seed_same_design_and_seeds_differ():
    p = bragg(10)
    a, b = design.optimise(p, seed=3), design.optimise(p, seed=3)
    assert a.thicknesses == b.thicknesses and a.evaluations == b.evaluations
    c = design.optimise(p, seed=4)
    assert c.evaluations != a.evaluations or c.thicknesses != a.thicknesses


def test_time_limit_and_evaluation_budget():
    p = bragg(40)
    t = time.perf_counter()
    d = design.optimise(p, seed=0, time_limit=0.3)
    assert d.seconds < 0.3 + 0.3 and time.perf_counter() - t < 3  # a round's last call may overrun
    e = design.optimise(p, seed=0, max_evaluations=500)
    assert e.evaluations < 500 + 4 * 80  # the last generation or refinement step may overrun


def test_progress_and_goal():
    seen = []
    d = design.optimise(bragg(10), seed=1, goal=0.2, progress=lambda n, m: seen.append((n, m)))
    assert seen and all(m1 >= m2 for (_, m1), (_, m2) in zip(seen, seen[1:]))
    assert d.merit <= 0.2 + 1e-12
    assert d.history[-1][2] <= 0.2


def test_material_choice_picks_the_index_matched_antireflection_layer():
    """A single quarter-wave layer on glass 1.52: n = √1.52 = 1.233 is the best of the candidates."""
    p = design.Problem([design.Layer([2.0, 1.23, 1.38, 1.7], (10, 300))],
                       [design.SpectralTarget("R", [550.0], value=0.0, p=1)], n_substrate=1.52)
    d = design.optimise(p, seed=0)
    assert d.materials == [1.23]
    assert d.thicknesses[0] == pytest.approx(550 / (4 * 1.23), abs=0.05)


def test_gradient_method():
    d = design.optimise(bragg(10), method="gradient", seed=0)
    assert len(d.thicknesses) == 10 and d.merit < 0.5


def test_needle_method_grows_a_broadband_antireflection_coating():
    lam = np.linspace(400, 700, 31)
    p = design.Problem([design.Layer("SiO2", (0, 300)), design.Layer("TiO2", (0, 300))],
                       [design.SpectralTarget("R", lam, value=0.0)], n_substrate="glass", max_layers=10,
                       min_thickness=3.0)
    start = design.optimise(p, method="global", seed=0)
    d = design.optimise(p, method="needle", seed=0)
    assert d.merit < 0.5 * start.merit
    assert 2 < len(d.thicknesses) <= 10 and min(d.thicknesses) >= 3.0
    assert all(a != b for a, b in zip(d.materials, d.materials[1:]))  # equal neighbours merged
    R = [tmm_RT(w, 1.0, [1.0] + [complex(material_nk(m, w)) for m in d.materials] +
                [complex(material_nk("SiO2", w))], d.thicknesses, "unpolarized")[0] for w in lam]
    assert d.merit == pytest.approx(math.sqrt(np.mean(np.square(R))), rel=1e-6)


def _lab(materials, thicknesses, angles_deg):
    lam = np.arange(360.0, 781.0, 5.0)
    out = []
    for a in angles_deg:
        R = [tmm_RT(w, math.cos(math.radians(a)),
                    [1.0] + [complex(material_nk(m, w)) for m in materials] + [complex(material_nk("SiO2", w))],
                    thicknesses, "unpolarized")[0] for w in lam]
        out.append(colour_lab(lam, R))
    return np.array(out)


def _delta_e(lab1, lab2):
    import colour

    return colour.delta_E(lab1, lab2, method="CIE 2000")


def test_colour_targets_of_a_two_layer_stack_are_met():
    angles = [0.0, 45.0]
    target = _lab(["TiO2", "SiO2"], [60.0, 150.0], angles)
    p = design.Problem([design.Layer("TiO2", (10, 250)), design.Layer("SiO2", (10, 250))],
                       [design.ColourTarget(target, cos_theta=np.cos(np.radians(angles)))], n_substrate="glass")
    d = design.optimise(p, seed=0, time_limit=30, goal=0.05)
    assert np.all(_delta_e(target, _lab(d.materials, d.thicknesses, angles)) < 1.0)


@pytest.mark.slow
def test_colour_targets_of_a_six_layer_stack_are_met_at_0_30_60_degrees():
    """The issue's bar: the CIELAB of a TiO2/SiO2 stack on glass at 0°, 30°, 60° (reachable by a
    stack of that layer count), met within ΔE2000 1.0 at every angle, checked with tmm and
    colour-science (the time, < 60 s, is measured by benchmarks/design.py, not asserted)."""
    angles = [0.0, 30.0, 60.0]
    mats = ["TiO2", "SiO2"] * 3
    target = _lab(mats, [95.0, 140.0, 60.0, 180.0, 110.0, 75.0], angles)
    p = design.Problem([design.Layer(m, (10, 250)) for m in mats],
                       [design.ColourTarget(target, cos_theta=np.cos(np.radians(angles)))], n_substrate="glass")
    d = design.optimise(p, seed=0, time_limit=60, goal=0.2)
    assert np.all(_delta_e(target, _lab(d.materials, d.thicknesses, angles)) < 1.0)


def test_robust_design_lowers_the_worst_case():
    """Against 3 nm errors the CVaR design's worst 10 % is no worse than the nominal design's: on
    the optimiser's own draws (it starts from the nominal optimum) and on 2000 fresh ones."""
    lam = np.linspace(500, 600, 5)
    layers = [design.Layer(m, (20, 200)) for m in ("TiO2", "SiO2") * 2]
    target = [design.SpectralTarget("R", lam, value=1.0, p=1, polarization="s")]
    plain = design.optimise(design.Problem(layers, target, n_substrate="glass"), seed=0)
    robust = design.Robust(sigma=3.0, samples=100, objective="cvar", alpha=0.1, seed=1)
    rob = design.optimise(design.Problem(layers, target, n_substrate="glass", robust=robust), seed=0, time_limit=4)
    from torchirid.design.merit import Evaluator

    ev = Evaluator(design.Problem(layers, target, n_substrate="glass", robust=robust))
    cvar = [ev.merit(torch.tensor([x.thicknesses], dtype=torch.float64)).item() for x in (plain, rob)]
    assert cvar[1] <= cvar[0] + 1e-12
    assert rob.merit == pytest.approx(cvar[1], rel=1e-12)
    t_plain = design.tolerance(plain, sigma=3.0, samples=2000, seed=5)
    t_rob = design.tolerance(rob, sigma=3.0, samples=2000, seed=5)
    worst = lambda t: np.sort(t.merits)[-200:].mean()  # noqa: E731
    assert worst(t_rob) <= worst(t_plain) * 1.01


def test_bad_arguments():
    p = bragg(10)
    with pytest.raises(ValueError, match="method"):
        design.optimise(p, method="annealing")
    with pytest.raises(ValueError, match="time_limit"):
        design.optimise(p, time_limit=0)
    with pytest.raises(TypeError, match="Problem"):
        design.optimise({"layers": []})
    with pytest.raises(TypeError, match="progress"):
        design.optimise(p, progress=3)


def test_design_json_keys(tmp_path):
    d = design.optimise(bragg(10), seed=0)
    out = d.to_dict()
    for key in ("layers", "incident", "exit", "merit", "seconds", "evaluations"):
        assert key in out
    assert out["layers"][0] == {"material": 1.8, "thickness_nm": pytest.approx(600 / 7.2, abs=0.01)}
    d.to_json(tmp_path / "d.json")
    assert (tmp_path / "d.json").read_text().startswith("{")
    fixed = d.as_problem()
    assert fixed.free_thicknesses == 0 and len(fixed.layers) == 10
    assert torch.get_default_dtype() == torch.float32  # the optimiser left torch's state alone
