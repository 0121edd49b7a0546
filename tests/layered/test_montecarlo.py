"""Monte Carlo reference of a layered rough Bragg structure (Fourneau et al. 2024 §4.2):
closed forms where the transport can be summed by hand, eq. 17 / eq. 34 for the
single-reflection paths, the two transmission strategies against each other, reciprocity."""

import math

import numpy as np
import pytest
import torch

from torchirid.layered import sample_single_reflection, single_reflection_pdf
from torchirid.layered.montecarlo import montecarlo_brdf
from torchirid.layered.single_reflection import single_reflection_brdf
from torchirid.layered.structure import LayeredBragg, RoughBraggLayer
from torchirid.layered.transmission import integrated_transmissivity
from torchirid.optics import bragg_reflectance, fresnel_reflectance
from torchirid.presets import fourneau_fig7

F64 = torch.float64
LAM = torch.tensor([430.0, 520.0, 610.0], dtype=F64)
Z = 4.5  # |z| bound of a test against a reference (several correlated entries per test)


@pytest.fixture(autouse=True, scope="module")
def _one_thread():
    # thousands of small elementwise ops per call: intra-op threads only add synchronisation
    # (and stall badly on a busy 2-core runner); the estimates do not depend on it
    n = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(n)


def _dir(theta_deg, phi_deg):
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return torch.tensor([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)], dtype=F64)


WI = torch.stack([_dir(25.0, 0.0), _dir(62.0, 30.0)])
WO = torch.stack([_dir(40.0, 160.0), _dir(15.0, 250.0)])


# independent references -------------------------------------------------------------------
def _g1(c, alpha):
    # eq. 19 with tan (not the library's tan-free form)
    c = torch.as_tensor(c, dtype=F64)
    return 2 / (1 + torch.sqrt(1 + alpha**2 * (1 - c**2) / c**2))


def _eq17(layer, wi, wo, lam):
    h = wi + wo
    h = h / h.norm(dim=-1, keepdim=True)
    ci, co, cm = wi[..., 2], wo[..., 2], h[..., 2]
    tan2 = (1 - cm**2) / cm**2
    D = layer.alpha**2 / (math.pi * cm**4 * (layer.alpha**2 + tan2) ** 2)
    R = bragg_reflectance(lam, (wi * h).sum(-1, keepdim=True), layer.n1, layer.n2, layer.d1, layer.d2, layer.cells)
    return (D * _g1(ci, layer.alpha) * _g1(co, layer.alpha) / (4 * ci * co)).unsqueeze(-1) * R


def _refract(w, n1):
    t = w[..., :2] / n1
    return torch.cat([t, torch.sqrt(1 - (t * t).sum(-1, keepdim=True))], -1)


def _coat_t(w, n1):
    return 1 - fresnel_reflectance(w[..., 2], 1.0, n1)


def _eq34(structure, wi, wo, lam):
    """Single-reflection BRDF (eq. 34) with the base as the last 'layer' ρd/π."""
    n1 = structure.n_coating
    i, o = _refract(wi, n1), _refract(wo, n1)
    total, chain = 0.0, 1.0
    for layer in structure.layers:
        total = total + chain * _eq17(layer, i, o, lam)
        tau_i = integrated_transmissivity(lam, i[..., 2:], layer, nodes=512)
        chain = chain * tau_i * integrated_transmissivity(lam, o[..., 2:], layer, nodes=512)
    total = total + chain * structure.base_albedo / math.pi
    return (_coat_t(wi, n1) * _coat_t(wo, n1) / n1**2).unsqueeze(-1) * total


def _z(a, b):
    (fa, ea), (fb, eb) = a, b
    return ((fa - fb) / torch.sqrt(ea**2 + eb**2)).abs().max().item()


# structures ---------------------------------------------------------------------------------
A = RoughBraggLayer(1.0, 1.5, 110.0, 90.0, 6, 0.15)
B = RoughBraggLayer(1.0, 1.7, 140.0, 80.0, 4, 0.3)
CA = RoughBraggLayer(1.33, 1.6, 120.0, 90.0, 6, 0.15)
CB = RoughBraggLayer(1.33, 1.9, 150.0, 80.0, 4, 0.3)
COATED = LayeredBragg([CA, CB], base_albedo=0.4)


def test_single_layer_over_black_base_is_eq17_exactly():
    # n1 = 1, one layer, black base: the only path to o is one reflection on the layer, and
    # NEE evaluates it deterministically at the first vertex (zero variance)
    ref = _eq17(A, WI, WO, LAM)
    for mode in ("filter", "microfacet"):
        for single in (False, True):
            f, err = montecarlo_brdf(LAM, WI, WO, LayeredBragg([A]), samples=64, transmission=mode,
                                     single_reflection=single)
            torch.testing.assert_close(f, ref, rtol=1e-12, atol=0)
            assert err.max().item() <= 1e-12 * ref.max().item()


def test_transparent_layers_over_a_base():
    # n2 = n1: R = 0, T = 1, τ = G1 (appendix C); no coating: f = Π_k G1(i) G1(o) · ρd/π
    clear1 = RoughBraggLayer(1.0, 1.0, 100.0, 100.0, 3, 0.3)
    clear2 = RoughBraggLayer(1.0, 1.0, 100.0, 100.0, 3, 0.1)
    s = LayeredBragg([clear1, clear2], base_albedo=0.7)
    g = _g1(WI[:, 2], 0.3) * _g1(WO[:, 2], 0.3) * _g1(WI[:, 2], 0.1) * _g1(WO[:, 2], 0.1)
    ref = (0.7 / math.pi * g).unsqueeze(-1).expand(2, 3)
    # microfacet mode: T = 1 for every m, so every path carries exactly G1 per crossing
    f, err = montecarlo_brdf(LAM, WI, WO, s, samples=256, transmission="microfacet")
    torch.testing.assert_close(f, ref, rtol=1e-10, atol=0)
    # filter mode: Bernoulli transmission with eq. 31/32
    f, err = montecarlo_brdf(LAM, WI, WO, s, samples=4000, transmission="filter")
    assert (err > 0).all()
    assert ((f - ref) / err).abs().max() < Z


def _coated_clear_reference(n1, alpha, rho, wi, wo):
    """Transparent layer under a coating over a Lambertian base: base ↔ coating inter-reflections
    sum to a geometric series, f = T_c(i)T_c(o)/n1² · G1(i')G1(o') · (ρ/π)/(1 − ρK),
    K = ∫ G1² F_int cos dω/π = 2∫₀¹ G1(c)² F(c; n1 → 1) c dc (TIR included)."""
    cc = math.sqrt(1 - 1 / n1**2)  # critical cosine: F has a kink there, split the quadrature
    x, w = np.polynomial.legendre.leggauss(200)
    K = 0.0
    for a, b in ((0.0, cc), (cc, 1.0)):
        c = torch.tensor((x + 1) / 2 * (b - a) + a, dtype=F64)
        K += float((2 * _g1(c, alpha) ** 2 * fresnel_reflectance(c, n1, 1.0) * c * torch.tensor(w * (b - a) / 2)).sum())
    i, o = _refract(wi, n1), _refract(wo, n1)
    t = _coat_t(wi, n1) * _coat_t(wo, n1) / n1**2
    return t * _g1(i[:, 2], alpha) * _g1(o[:, 2], alpha) * rho / math.pi / (1 - rho * K), K


@pytest.mark.parametrize("mode", ["filter", "microfacet"])
def test_coating_inter_reflections_closed_form(mode):
    n1, alpha, rho = 1.5, 0.3, 0.8
    s = LayeredBragg([RoughBraggLayer(n1, n1, 100.0, 100.0, 3, alpha)], base_albedo=rho)
    ref, K = _coated_clear_reference(n1, alpha, rho, WI, WO)
    ref = ref.unsqueeze(-1).expand(2, 3)
    f, err = montecarlo_brdf(LAM, WI, WO, s, samples=10000, transmission=mode)
    assert ((f - ref) / err).abs().max() < Z
    # the inter-reflections matter: the single-bounce term alone is off by many σ
    assert ((f - ref * (1 - rho * K)) / err).abs().max() > 8


@pytest.mark.parametrize("mode", ["filter", "microfacet"])
def test_single_reflection_estimator_converges_to_eq34(mode):
    ref = _eq34(COATED, WI, WO, LAM)
    f, err = montecarlo_brdf(LAM, WI, WO, COATED, samples=20000, single_reflection=True, transmission=mode)
    assert (err > 0).all()
    assert ((f - ref) / err).abs().max() < Z


def test_single_reflection_estimator_matches_single_reflection_brdf():
    # the library's eq. 34 (τ tables, exact R) against the quadrature-free SR estimator
    ref = single_reflection_brdf(LAM, WI, WO, COATED)
    f, err = montecarlo_brdf(LAM, WI, WO, COATED, samples=20000, single_reflection=True,
                             transmission="microfacet", seed=11)
    assert ((f - ref) / err).abs().max() < Z


def test_hard_directions_and_a_host_below_one():
    # normal incidence exactly, near-grazing, and a host n1 < 1: directions beyond its
    # critical angle cannot enter (T_c = 0), so f = 0 there; everything stays finite
    wi = torch.stack([_dir(0.0, 0.0), _dir(89.0, 0.0), _dir(60.0, 0.0)])
    wo = torch.stack([_dir(0.0, 0.0), _dir(88.0, 180.0), _dir(20.0, 90.0)])
    low = LayeredBragg([RoughBraggLayer(0.8, 1.6, 120.0, 90.0, 6, 0.15)], base_albedo=0.5)
    for structure in (COATED, low):
        for mode in ("filter", "microfacet"):
            f, err = montecarlo_brdf(LAM, wi, wo, structure, samples=200, transmission=mode)
            assert torch.isfinite(f).all() and torch.isfinite(err).all() and (f >= 0).all()
            if structure is COATED:
                assert (f > 0).all()
            else:  # sin 60°, sin 89° > 0.8: no way in
                assert (f[1:] == 0).all() and (f[0] > 0).all()


def test_two_transmission_modes_agree():
    # τ = G1 · E_{m~VNDF}[T(d·m)]: sampling p_trans with τ (eq. 31–33) and sampling m first
    # must have the same expectation, also for all the multiple-scattering paths
    a = montecarlo_brdf(LAM, WI, WO, COATED, samples=20000, transmission="filter")
    b = montecarlo_brdf(LAM, WI, WO, COATED, samples=20000, transmission="microfacet", seed=1)
    assert _z(a, b) < Z


def test_fringe_rich_layer_modes_agree():
    # N = 20, Λ = 500 nm, α = 0.05: R(θd) has fringes finer than the filter F_α, where a
    # plain Gauss quadrature of eq. 28 errs by ~1e-2 in τ; the filter mode's τ tables must
    # still match the quadrature-free microfacet mode (0.3 % noise here)
    hard = RoughBraggLayer(1.0, 1.5, 250.0, 250.0, 20, 0.05)
    s = LayeredBragg([hard, B], base_albedo=0.5)
    lam = torch.tensor([400.0, 430.0, 520.0], dtype=F64)
    wi, wo = _dir(56.5, 0.0), _dir(56.5, 120.0)  # where 256 Gauss nodes err by 1.4 % in τ(400 nm)
    a = montecarlo_brdf(lam, wi, wo, s, samples=80000, single_reflection=True, transmission="filter")
    b = montecarlo_brdf(lam, wi, wo, s, samples=80000, single_reflection=True, transmission="microfacet", seed=1)
    assert (a[1] / a[0]).max() < 0.004
    assert _z(a, b) < Z


def test_full_transport_adds_multiple_reflections():
    s = LayeredBragg([A, B])  # two layers in air, black base: inter-reflections between layers
    sr = montecarlo_brdf(LAM, WI, WO, s, samples=2000, single_reflection=True)
    full = montecarlo_brdf(LAM, WI, WO, s, samples=2000, seed=1)
    diff = full[0] - sr[0]
    sigma = torch.sqrt(full[1] ** 2 + sr[1] ** 2)
    assert (diff > -Z * sigma).all()
    assert (diff > 3 * sigma).any()


def test_reciprocity():
    a = montecarlo_brdf(LAM, WI, WO, COATED, samples=10000, transmission="microfacet")
    b = montecarlo_brdf(LAM, WO, WI, COATED, samples=10000, transmission="microfacet", seed=7)
    assert _z(a, b) < Z


def test_albedo_at_most_one():
    # bright base, reflective layers, coating: ∫ f cos dω_o + F_coat(i) ≤ 1 (energy is only
    # lost: 1 − G1 per crossing, absorption in the base)
    s = LayeredBragg([RoughBraggLayer(1.33, 2.2, 60.0, 60.0, 8, 0.2)], base_albedo=1.0)
    g = torch.Generator().manual_seed(3)
    u = torch.rand(256, 2, generator=g, dtype=F64)
    r, phi = torch.sqrt(u[:, 0]), 2 * math.pi * u[:, 1]  # cosine-weighted wo: albedo = E[π f]
    wo = torch.stack([r * torch.cos(phi), r * torch.sin(phi), torch.sqrt(1 - u[:, 0])], -1)
    wi = _dir(30.0, 0.0)
    f, _ = montecarlo_brdf(LAM, wi, wo, s, samples=16, transmission="microfacet")
    albedo = math.pi * f.mean(0)
    spread = math.pi * f.std(0) / math.sqrt(f.shape[0])
    total = albedo + fresnel_reflectance(wi[2], 1.0, 1.33)
    assert (total < 1 + Z * spread).all()
    assert (albedo > 0.1).all()


def test_reproducible_with_a_seed():
    a = montecarlo_brdf(LAM, WI, WO, COATED, samples=64, seed=5)
    b = montecarlo_brdf(LAM, WI, WO, COATED, samples=64, seed=5)
    c = montecarlo_brdf(LAM, WI, WO, COATED, samples=64, seed=6)
    assert torch.equal(a[0], b[0]) and torch.equal(a[1], b[1])
    assert not torch.equal(a[0], c[0])


def test_stderr_shrinks_as_inverse_sqrt_samples():
    s = LayeredBragg([A, B], base_albedo=0.5)
    _, e1 = montecarlo_brdf(LAM, WI, WO, s, samples=500, transmission="microfacet")
    _, e4 = montecarlo_brdf(LAM, WI, WO, s, samples=2000, transmission="microfacet", seed=1)
    ratio = (e4 / e1).median().item()
    assert 0.38 < ratio < 0.66  # 1/2; excludes 1/√2 (∝ samples^-1/4) and 1/4 (∝ 1/samples)


def test_shapes_broadcast_and_float32():
    wi = WI[:, None, :]  # (2, 1, 3)
    wo = torch.stack([WO[0], WO[1], _dir(0.0, 0.0)])[None]  # (1, 3, 3)
    f, err = montecarlo_brdf(LAM, wi, wo, COATED, samples=8)
    assert f.shape == err.shape == (2, 3, 3) and f.dtype == F64
    f32, err32 = montecarlo_brdf(LAM.float(), WI.float(), WO.float(), COATED, samples=4000, seed=3)
    assert f32.dtype == torch.float32 and torch.isfinite(f32).all() and torch.isfinite(err32).all()
    f64 = montecarlo_brdf(LAM, WI, WO, COATED, samples=4000)
    assert _z(f64, (f32.double(), err32.double())) < Z
    # a single layer is accepted as a structure; a (3,) direction gives (W,)
    done = []  # progress(done, total): the paths traced so far out of samples × pairs, per batch
    f1, _ = montecarlo_brdf(LAM, WI[0], WO[0], A, samples=4, batch_size=3,
                            progress=lambda d, t: done.append((d, t)))
    assert f1.shape == (3,)
    assert done == [(3, 4), (4, 4)] and all(type(d) is int and type(t) is int for d, t in done)
    done.clear()  # two pairs, 3 samples, batches of 4 paths
    montecarlo_brdf(LAM, WI, WO, A, samples=3, batch_size=4, progress=lambda d, t: done.append((d, t)))
    assert done == [(4, 6), (6, 6)]


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(transmission="nope"), "transmission"),
        (dict(samples=1), "samples"),
        (dict(samples=2.5), "samples"),
        (dict(max_depth=0), "max_depth"),
        (dict(seed=-1), "seed"),
        (dict(single_reflection=1), "single_reflection"),
        (dict(progress=True), "progress"),  # a callback, not a flag
        (dict(wi=torch.tensor([0.0, 1.0, 0.0], dtype=F64)), "wi"),
        (dict(wo=torch.tensor([0.0, 0.0, -1.0], dtype=F64)), "wo"),
        (dict(wi=torch.tensor([0.0, 0.0, 2.0], dtype=F64)), "unit"),
        (dict(wi=torch.ones(2, dtype=F64)), r"\(\*, 3\)"),
        (dict(wavelength=torch.ones(2, 2, dtype=F64)), "wavelength"),
        (dict(wavelength=torch.tensor([-1.0], dtype=F64)), "wavelength"),
        (dict(structure="glass"), "structure"),
    ],
)
def test_bad_input(kwargs, match):
    args = dict(structure=COATED, wi=WI, wo=WO, wavelength=LAM)
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        montecarlo_brdf(args.pop("wavelength"), args.pop("wi"), args.pop("wo"), args.pop("structure"), **args)


def test_full_is_single_plus_multiple():
    # same seed: the multiple-reflection paths are a subset of the full estimator's events
    s = LayeredBragg([RoughBraggLayer(1.35, 1.5, 250.0, 250.0, 10, 0.2)] * 2, base_albedo=0.5)
    wi = torch.tensor([[0.3, 0.0, math.sqrt(1 - 0.09)]], dtype=torch.float64)
    wo = torch.tensor([[-0.5, 0.1, math.sqrt(1 - 0.26)]], dtype=torch.float64)
    lam = torch.tensor([450.0, 550.0, 650.0], dtype=torch.float64)
    full, _ = montecarlo_brdf(lam, wi, wo, s, samples=4096, seed=5)
    single, _ = montecarlo_brdf(lam, wi, wo, s, samples=4096, seed=5, single_reflection=True)
    multi, se = montecarlo_brdf(lam, wi, wo, s, samples=4096, seed=5, multiple_reflection=True)
    assert bool((multi > 0).all())
    from torchirid.layered.single_reflection import single_reflection_brdf

    exact_single = single_reflection_brdf(lam, wi, wo, s)
    # full ≈ exact single + multiple, within the two estimates' noise
    _, se_full = montecarlo_brdf(lam, wi, wo, s, samples=4096, seed=5)
    z = (full - exact_single - multi).abs() / (se_full + se)
    assert bool((z < 4.5).all()), z
    with pytest.raises(ValueError, match="exclude"):
        montecarlo_brdf(lam, wi, wo, s, samples=4, single_reflection=True, multiple_reflection=True)


# white furnace ------------------------------------------------------------------------------
def _vndf(w, alpha, u1, u2):
    """GGX visible normals of ``w`` (Heitz 2018), written out here (not the library's sampler)."""
    vh = torch.stack([alpha * w[:, 0], alpha * w[:, 1], w[:, 2]], -1)
    vh = vh / vh.norm(dim=-1, keepdim=True)
    lensq = vh[:, 0] ** 2 + vh[:, 1] ** 2
    t1 = torch.stack([-vh[:, 1], vh[:, 0], torch.zeros_like(lensq)], -1) / lensq.clamp_min(1e-300).sqrt()[:, None]
    t1 = torch.where((lensq > 0)[:, None], t1, torch.tensor([1.0, 0.0, 0.0], dtype=F64))
    t2 = torch.cross(vh, t1, dim=-1)
    r, phi = u1.sqrt(), 2 * math.pi * u2
    p1, p2 = r * phi.cos(), r * phi.sin()
    s = 0.5 * (1 + vh[:, 2])
    p2 = (1 - s) * (1 - p1**2).clamp_min(0).sqrt() + s * p2
    nh = p1[:, None] * t1 + p2[:, None] * t2 + (1 - p1**2 - p2**2).clamp_min(0).sqrt()[:, None] * vh
    m = torch.stack([alpha * nh[:, 0], alpha * nh[:, 1], nh[:, 2].clamp_min(0)], -1)
    return m / m.norm(dim=-1, keepdim=True)


def _analog_albedo(structure, lam, wi, walkers, seed=0):
    """Directional albedo by an analog random walk (no next-event estimation): each walker carries
    one wavelength and is either alive with weight 1 or gone; the fraction that leaves through
    the top is the albedo (without the coating's own mirror reflection). At a layer: a visible
    normal m, reflection with probability R(m) and survival G1(o) (eq. 17: ∫ f_r cos = E[R G1(o)]),
    else ballistic transmission with survival G1(d) (eq. 22: τ = G1 E[T]); at the base, survival
    ρd and a cosine direction; at the top, the coating's Fresnel reflection or escape."""
    g = torch.Generator().manual_seed(seed)
    n1, L, rho = structure.n_coating, len(structure.layers), structure.base_albedo
    which = torch.arange(lam.numel()).repeat_interleave(walkers)
    t = wi[:2] / n1
    d = torch.cat([-t, -torch.sqrt(1 - (t * t).sum()).reshape(1)]).expand(which.numel(), 3).clone()
    gap = torch.zeros(which.numel(), dtype=torch.long)
    escaped = torch.zeros(lam.numel(), dtype=F64)
    while which.numel():
        u = torch.rand(which.numel(), 4, generator=g, dtype=F64)
        down = d[:, 2] < 0
        alive = torch.ones_like(down)
        new_d, new_gap = d.clone(), gap.clone()
        base, top = down & (gap == L), ~down & (gap == 0)
        b = base.nonzero().squeeze(-1)
        alive[b] = u[b, 0] < rho
        r, ph = u[b, 1].sqrt(), 2 * math.pi * u[b, 2]
        new_d[b] = torch.stack([r * ph.cos(), r * ph.sin(), (1 - u[b, 1]).sqrt()], -1)
        k = top.nonzero().squeeze(-1)
        back = u[k, 0] < (fresnel_reflectance(d[k, 2], n1, 1.0) if n1 != 1.0 else 0.0)
        escaped.index_add_(0, which[k[~back]], torch.ones(int((~back).sum()), dtype=F64))
        alive[k[~back]] = False
        new_d[k[back], 2] = -d[k[back], 2]
        for l, layer in enumerate(structure.layers):
            j = (~base & ~top & (torch.where(down, gap, gap - 1) == l)).nonzero().squeeze(-1)
            if not j.numel():
                continue
            c = d[j, 2].abs()
            w = torch.stack([-d[j, 0], -d[j, 1], c], -1)  # towards the light, the layer's normal facing it
            m = _vndf(w, layer.alpha, u[j, 1], u[j, 2])
            cos_d = (w * m).sum(-1).clamp(0, 1)
            refl = u[j, 0] < layer.reflectance(lam[which[j]], cos_d)
            survive = torch.rand(j.numel(), generator=g, dtype=F64)
            jt = j[~refl]
            alive[jt] = survive[~refl] < _g1(c[~refl], layer.alpha)
            new_gap[jt] = torch.where(down[jt], gap[jt] + 1, gap[jt] - 1)
            jr = j[refl]
            o = 2 * cos_d[refl, None] * m[refl] - w[refl]
            alive[jr] = (o[:, 2] > 0) & (survive[refl] < _g1(o[:, 2].clamp_min(1e-300), layer.alpha))
            new_d[jr] = torch.cat([o[:, :2], (o[:, 2] * torch.where(down[jr], 1.0, -1.0)).unsqueeze(-1)], -1)
        d, gap, which = new_d[alive], new_gap[alive], which[alive]
        d = d / d.norm(dim=-1, keepdim=True)
    t_in = 1 - fresnel_reflectance(wi[2], 1.0, n1) if n1 != 1.0 else torch.tensor(1.0, dtype=F64)
    a = escaped / walkers * t_in
    return a, torch.sqrt(a * (t_in - a) / walkers)


def _nee_albedo(structure, lam, wi, directions, samples, seed=0, brdf=None):
    """∫ f cos θo dωo of montecarlo_brdf (or of ``brdf(wo)``) by multiple importance sampling of
    wo (balance heuristic, half of the directions from the single-reflection lobes of eq. 35,
    half cosine-weighted): ``(albedo, stderr)`` per wavelength."""
    g = torch.Generator().manual_seed(seed)
    wo_sr, _ = sample_single_reflection(lam, wi, structure, torch.rand(directions, 3, generator=g, dtype=F64))
    u = torch.rand(directions, 2, generator=g, dtype=F64)
    r, phi = u[:, 0].sqrt(), 2 * math.pi * u[:, 1]
    wo_cos = torch.stack([r * phi.cos(), r * phi.sin(), (1 - u[:, 0]).sqrt()], -1)
    valid = torch.cat([wo_sr[:, 2] > 1e-9, torch.ones(directions, dtype=torch.bool)])  # 0: below the horizon
    wo = torch.where(valid[:, None], torch.cat([wo_sr, wo_cos]), torch.tensor([0.0, 0.0, 1.0], dtype=F64))
    f = brdf(wo) if brdf is not None else montecarlo_brdf(lam, wi, wo, structure, samples=samples, seed=seed)[0]
    pdf = 0.5 * single_reflection_pdf(lam, wi, wo, structure) + 0.5 * wo[:, 2] / math.pi
    x = torch.where(valid[:, None], f * (wo[:, 2] / pdf)[:, None], 0.0)
    sr, cos = x[:directions], x[directions:]
    return 0.5 * (sr.mean(0) + cos.mean(0)), 0.5 * torch.sqrt((sr.var(0) + cos.var(0)) / directions)


FURNACE_WI = _dir(30.0, 0.0)


@pytest.mark.parametrize("structure", [
    fourneau_fig7("a", base_albedo=1.0),                    # in air: layer ↔ base
    fourneau_fig7("a_coated", layers=2, base_albedo=1.0),   # + between the layers, total internal reflection
], ids=["fig7_a", "fig7_a_coated_x2"])
def test_white_furnace_matches_an_analog_walk(structure):
    # Lossless mirrors (R + T = 1) over a white base: energy leaves only through the top or is
    # lost by the microfacet shadowing of eq. 30 (A = 1 − G1 per layer event: no scattering
    # between the microfacets of a layer). Next-event estimation, integrated over wo, must give
    # the albedo that an analog walk counts, walker by walker, escaping the structure.
    lam = torch.tensor([450.0, 550.0, 650.0], dtype=F64)
    ref, ref_err = _analog_albedo(structure, lam, FURNACE_WI, 40000)
    a, err = _nee_albedo(structure, lam, FURNACE_WI, 8192, 4)
    assert ((a - ref) / torch.sqrt(err**2 + ref_err**2)).abs().max() < Z
    mirror = fresnel_reflectance(FURNACE_WI[2], 1.0, structure.n_coating) if structure.coated else 0.0
    assert (ref + mirror < 1).all() and (ref + mirror > 0.8).all()  # a few % lost by eq. 30 only
    assert (err < 0.015).all()


def test_white_furnace_conserves_energy_in_the_smooth_limit():
    # At α = 0.02 eq. 30's loss is < 0.5 % (the analog walk): a white base under reflective,
    # lossless layers reflects all the light, multiple scattering included; eq. 34 alone falls short
    layers = [RoughBraggLayer(1.0, 1.5, 250.0, 250.0, 3, 0.02)] * 2
    s = LayeredBragg(layers, base_albedo=1.0)
    lam = torch.tensor([450.0, 550.0, 650.0], dtype=F64)
    ref, _ = _analog_albedo(s, lam, FURNACE_WI, 20000)
    assert (ref > 0.995).all()
    a, err = _nee_albedo(s, lam, FURNACE_WI, 8192, 4)
    assert ((a - 1) / err).abs().max() < Z and (err < 0.02).all()
    # eq. 34 alone (the single reflections) reflects far less: the rest is multiple scattering
    single, single_err = _nee_albedo(s, lam, FURNACE_WI, 8192, 1, brdf=lambda wo: single_reflection_brdf(
        lam, FURNACE_WI, wo, s))
    assert (single + Z * single_err < 0.9).all()


def test_single_reflection_paths_converge_to_eq34_as_inverse_sqrt_samples():
    # Fig. 7's A′, two layers over its diffuse base: the paths that reflect once converge to
    # eq. 34 (exact for them) with a standard error ∝ 1/√samples; all paths lie above it
    s = fourneau_fig7("a_coated", layers=2, base_albedo=0.5)
    ref = single_reflection_brdf(LAM, WI, WO, s)
    errors = []
    for samples, seed in ((1000, 1), (4000, 2)):
        f, err = montecarlo_brdf(LAM, WI, WO, s, samples=samples, seed=seed, single_reflection=True)
        assert (err > 0).all() and ((f - ref) / err).abs().max() < Z
        errors.append(err)
    ratio = (errors[1] / errors[0]).median().item()
    assert 0.4 <= ratio <= 0.6, ratio
    full, err = montecarlo_brdf(LAM, WI, WO, s, samples=4000, seed=3)
    assert ((full - ref) / err).min() > -Z and ((full - ref) / err).max() > 5
