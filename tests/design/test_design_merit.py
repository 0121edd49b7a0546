"""torchirid.design.merit: the batched responses and merits against tmm and colour-science."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from oracles import colour_lab, material_nk, tmm_RT
from torchirid import design
from torchirid.design.merit import Evaluator, named_weight

F64 = torch.float64


def _stack_indices(materials, lam):
    out = []
    for m in materials:
        out.append(complex(material_nk(m, lam)) if isinstance(m, str) and m != "glass" else
                   complex(material_nk("SiO2", lam)) if m == "glass" else complex(m))
    return out


@pytest.mark.parametrize("polarization", ["s", "p", "unpolarized"])
def test_responses_equal_tmm(polarization):
    """R and T of random stacks (dispersive, absorbing, choices) at several λ and θ = tmm's."""
    rng = np.random.default_rng(1)
    lam = [420.0, 555.0, 690.0]
    cos = [1.0, 0.7, 0.2]
    layers = [design.Layer(["TiO2", "SiO2"], (0, 300)), design.Layer(1.9 + 0.05j, (0, 300)),
              design.Layer("SiO2", (0, 300)), design.Layer(2.2, 35.0)]
    p = design.Problem(layers, [design.SpectralTarget("R", lam, cos_theta=cos, polarization=polarization)],
                       n_incident=1.33, n_substrate="glass")
    ev = Evaluator(p)
    x = torch.tensor(rng.uniform(0, 300, (4, 3)), dtype=F64)
    choice = torch.tensor([[0], [1], [1], [0]])
    (R, T), = ev.responses(ev.thicknesses(x), choice)
    for b in range(4):
        mats = [1.33, ["TiO2", "SiO2"][int(choice[b, 0])], 1.9 + 0.05j, "SiO2", 2.2, "glass"]
        d = x[b].tolist() + [35.0]
        for i, w in enumerate(lam):
            for a, c in enumerate(cos):
                r, t = tmm_RT(w, c, _stack_indices(mats, w), d, polarization)
                # 1e-9: the database pages are interpolated by two codes (n agrees to ~1e-8)
                assert R[b, i, a].item() == pytest.approx(r, abs=1e-9)
                assert T[b, i, a].item() == pytest.approx(t, abs=1e-9)


def test_choice_path_equals_fixed_path():
    lam = np.linspace(400, 700, 7)
    t = [design.SpectralTarget("R", lam, cos_theta=[1.0, 0.5])]
    chosen = design.Problem([design.Layer(["TiO2", "SiO2"], (0, 200)), design.Layer("SiO2", (0, 200))], t,
                            n_substrate="glass")
    fixed = design.Problem([design.Layer("SiO2", (0, 200)), design.Layer("SiO2", (0, 200))], t,
                           n_substrate="glass")
    x = torch.tensor([[80.0, 120.0], [10.0, 200.0]], dtype=F64)
    a = Evaluator(chosen).merit(x, torch.tensor([[1], [1]]))
    b = Evaluator(fixed).merit(x)
    torch.testing.assert_close(a, b, rtol=0, atol=1e-15)


def test_large_batches_take_the_film_loop_with_the_same_values():
    """Above the matrix-product path's point budget the kernel's film loop answers (same values)."""
    lam = np.linspace(400, 700, 61)
    p = design.Problem([design.Layer(m, (0, 250)) for m in (2.3, 1.46) * 4],
                       [design.SpectralTarget("R", lam, cos_theta=[1.0, 0.6])], n_substrate=1.52)
    ev = Evaluator(p)
    x = torch.rand(64, 8, dtype=F64, generator=torch.Generator().manual_seed(0)) * 250
    whole = ev.merit(x)  # 64 × 61 × 2 × 2 points: the loop
    parts = torch.cat([ev.merit(x[i:i + 1]) for i in range(64)])  # 244 points each: the tree
    torch.testing.assert_close(whole, parts, rtol=1e-13, atol=1e-15)


def test_spectral_merit_formula():
    """(Σ w |v − X|^p / Σ w)^(1/p) over wavelengths and angles; p = 1 is 1 − mean R; A = 1 − R − T."""
    lam = np.array([450.0, 550.0, 650.0])
    w = np.array([1.0, 2.0, 0.5])
    layers = [design.Layer(2.0 + 0.1j, 60.0), design.Layer(1.5, 90.0)]
    ev = Evaluator(design.Problem(layers, [
        design.SpectralTarget("R", lam, value=1.0, cos_theta=[1.0, 0.5], weight=w, p=1),
        design.SpectralTarget("T", lam, value=[0.9, 0.8, 0.7], cos_theta=0.8, p=2),
        design.SpectralTarget("A", lam, value=0.0, p=3, importance=2.0)], n_substrate=1.52))
    d = ev.thicknesses(torch.zeros(1, 0, dtype=F64))
    m = ev.target_merits(d)[0].numpy()
    R = np.array([[tmm_RT(x, c, [1.0, 2.0 + 0.1j, 1.5, 1.52], [60.0, 90.0], "unpolarized")[0] for c in (1.0, 0.5)]
                  for x in lam])
    assert m[0] == pytest.approx(((1 - R) * w[:, None]).sum() / (2 * w.sum()), abs=1e-14)
    T = np.array([tmm_RT(x, 0.8, [1.0, 2.0 + 0.1j, 1.5, 1.52], [60.0, 90.0], "unpolarized")[1] for x in lam])
    assert m[1] == pytest.approx(np.sqrt(np.mean((np.array([0.9, 0.8, 0.7]) - T) ** 2)), abs=1e-14)
    RT = [tmm_RT(x, 1.0, [1.0, 2.0 + 0.1j, 1.5, 1.52], [60.0, 90.0], "unpolarized") for x in lam]
    A = np.array([1 - r - t for r, t in RT])
    assert m[2] == pytest.approx(np.mean(A ** 3) ** (1 / 3), abs=1e-14)
    assert ev.plain_merit(d).item() == pytest.approx(m[0] + m[1] + 2 * m[2], abs=1e-14)


def test_photon_flux_weighting_is_pvlib_astm_g173_times_lambda():
    pvlib = pytest.importorskip("pvlib", reason="pvlib (the ASTM G173 spectrum) is not installed")
    lam = np.array([400.0, 500.0, 600.0, 700.0])
    spectra = pvlib.spectrum.get_reference_spectra()
    e = np.interp(lam, spectra.index.to_numpy(float), spectra["global"].to_numpy(float))
    w = named_weight("AM1.5G photon flux", lam)
    np.testing.assert_allclose(w / w.sum(), e * lam / (e * lam).sum(), rtol=1e-12)
    assert w[2] == pytest.approx(e[2] * 600e-9 / (6.62607015e-34 * 299792458.0), rel=1e-12)  # photons s⁻¹ m⁻² nm⁻¹


def test_photovoltaic_cost_equals_pymoosh_photo():
    """PyMoosh's photovoltaic cost 1 − Jsc/Jsc,max is a T target weighted by its photon density."""
    pm = pytest.importorskip("PyMoosh", reason="PyMoosh is not installed")
    from PyMoosh.photo import photo

    x = [110.0, 70.0, 95.0, 60.0]
    struct = pm.Structure([1.0, 2.0, 3.0, "SiA"], [0, 1, 2, 1, 2, 3], [0.0, *x, 30000.0], verbose=False)
    if not hasattr(np, "trapz"):  # PyMoosh 4.0.1 calls np.trapz, gone in NumPy 2
        np.trapz = np.trapezoid
    eff, _, _, lam, density, _ = photo(struct, 0.0, 0, 375.0, 750.0, 5, 60)
    k = np.array([complex(struct.materials[3].get_permittivity(w)) ** 0.5 for w in lam])
    table = {"wavelength": lam, "n": k.real, "k": k.imag}
    # PyMoosh integrates by the trapezoid rule: the weights of a T target are its density × trapezoid weights
    trap = np.gradient(lam) * 1.0
    trap[0] = trap[-1] = (lam[1] - lam[0]) / 2
    p = design.Problem([design.Layer(m, d) for m, d in zip([2 ** 0.5, 3 ** 0.5] * 2, x)],
                       [design.SpectralTarget("T", lam, 1.0, weight=density * trap, p=1)], n_substrate=table)
    merit = Evaluator(p).merit(torch.zeros(1, 0, dtype=F64)).item()
    assert merit == pytest.approx(1 - eff, abs=1e-10)


def test_colour_target_lab_equals_colour_science():
    lam = np.arange(360.0, 781.0, 1.0)  # colour-science integrates on its CMFs' 1 nm grid
    mats = ["TiO2", "SiO2", "TiO2"]
    d = [70.0, 110.0, 140.0]
    cos = [1.0, math.cos(math.radians(50))]
    p = design.Problem([design.Layer(m, t) for m, t in zip(mats, d)],
                       [design.ColourTarget([[50.0, 0.0, 0.0]] * 2, cos_theta=cos, wavelength_step=1.0)],
                       n_substrate="glass")
    ev = Evaluator(p)
    lab = ev.colours(ev.thicknesses(torch.zeros(1, 0, dtype=F64)))[0][0].numpy()
    for a, c in enumerate(cos):
        R = [tmm_RT(w, c, _stack_indices([1.0, *mats, "glass"], w), d, "unpolarized")[0] for w in lam]
        np.testing.assert_allclose(lab[a], colour_lab(lam, R), atol=2e-3)  # trapezoid vs rectangle rule


def test_gradients_equal_finite_differences():
    lam = np.linspace(420, 680, 9)
    p = design.Problem([design.Layer(m, (0, 300)) for m in ("TiO2", "SiO2", "TiO2")],
                       [design.SpectralTarget("R", lam, value=0.2, cos_theta=[1.0, 0.6], p=2),
                        design.ColourTarget([[60.0, 20.0, -30.0], [55.0, 10.0, 5.0]], cos_theta=[1.0, 0.5])],
                       n_substrate="glass")
    ev = Evaluator(p)
    x = torch.tensor([[83.0, 141.0, 57.0]], dtype=F64, requires_grad=True)
    ev.merit(x).sum().backward()
    h = 1e-5
    for j in range(3):
        e = torch.zeros_like(x)
        e[0, j] = h
        with torch.no_grad():
            fd = (ev.merit(x + e) - ev.merit(x - e)).item() / (2 * h)
        assert x.grad[0, j].item() == pytest.approx(fd, rel=1e-6, abs=1e-9)


def test_robust_merit_mean_and_cvar():
    lam = [600.0]
    layers = [design.Layer(m, (0, 214)) for m in (1.8, 1.4, 1.8, 1.4)]
    t = [design.SpectralTarget("R", lam, p=1)]
    mean = Evaluator(design.Problem(layers, t, n_substrate=1.8, robust=design.Robust(2.0, samples=40, seed=3)))
    cvar = Evaluator(design.Problem(layers, t, n_substrate=1.8,
                                    robust=design.Robust(2.0, samples=40, objective="cvar", alpha=0.1, seed=3)))
    x = torch.tensor([[83.3, 107.1, 83.3, 107.1]], dtype=F64)
    draws = (x + mean.errors).clamp_min(0)
    each = mean.plain_merit(draws)
    assert mean.merit(x).item() == pytest.approx(each.mean().item(), rel=1e-14)
    assert cvar.merit(x).item() == pytest.approx(each.sort().values[-4:].mean().item(), rel=1e-14)
    assert cvar.merit(x).item() > mean.merit(x).item() > mean.merit(x, robust=False).item()


def test_thickness_penalty():
    p = design.Problem([design.Layer(1.5, (0, 500))], [design.SpectralTarget("R", [500.0], value=0.0)],
                       n_substrate=1.52, max_total_thickness=300.0)
    ev = Evaluator(p)
    inside, outside = ev.merit(torch.tensor([[250.0], [330.0]], dtype=F64)).tolist()
    plain = ev.plain_merit(torch.tensor([[330.0]], dtype=F64)).item() - 100 * 30 / 300
    assert outside - plain == pytest.approx(10.0) and inside < 1


def test_absorptance_of_a_named_layer_equals_tmm():
    import tmm

    lam = [450.0, 550.0, 650.0]
    p = design.Problem([design.Layer(2.0 + 0.3j, (0, 200), name="absorber"), design.Layer(1.46, (0, 200)),
                        design.Layer(0.15 + 3.5j, 15.0)],
                       [design.SpectralTarget("A", lam, value=0.0, cos_theta=[1.0, 0.5], layer="absorber", p=1),
                        design.SpectralTarget("A", lam, value=0.0, layer=2, p=1)], n_substrate=1.52)
    ev = Evaluator(p)
    m = ev.target_merits(ev.thicknesses(torch.tensor([[80.0, 120.0]], dtype=F64)))[0]
    for t, (layer, cosines) in enumerate(((1, [1.0, 0.5]), (3, [1.0]))):
        ref = np.mean([sum(tmm.absorp_in_each_layer(tmm.coh_tmm(
            pol, [1.0, 2.0 + 0.3j, 1.46, 0.15 + 3.5j, 1.52], [np.inf, 80, 120, 15, np.inf], math.acos(c), w))[layer]
            for pol in "sp") / 2 for w in lam for c in cosines])
        assert m[t].item() == pytest.approx(ref, abs=1e-13)
    with pytest.raises(ValueError, match="targets\\[0\\].layer: no layer named 'film'"):
        design.Problem(p.layers, [design.SpectralTarget("A", lam, layer="film")])
    with pytest.raises(ValueError, match="targets\\[0\\].layer: only an absorptance"):
        design.Problem(p.layers, [design.SpectralTarget("R", lam, layer=0)])
