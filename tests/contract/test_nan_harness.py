"""NaN propagation over the public API (docs/conventions.md: "NaN inputs propagate, they are not 'fixed'").

One table of calls: every function of the flat ``torchirid`` namespace that takes per-sample
tensor data (and the per-sample functions of the subpackages), called on a batch of two equal
samples (leading axis of size 2). For each of its per-sample arguments in turn, entry 0 of that
argument is set to NaN (every component of a vector) and the call must

* not raise (one bad sample must not take the batch down),
* return NaN in every output value of entry 0 (NaN is not replaced by a number),
* return for entry 1 what the clean batch returns (no cross-talk between samples),
* give entry 1 the gradient it has in the clean batch (no NaN leaking through backward).

The same table checks, on clean inputs: float32 in, float32 out, close to float64; broadcasting
(one argument with extra leading batch axes, the others not); empty batches (zero samples in, an
empty result out); gradients against finite differences; the hard cases grazing (cos θ = 0)
and normal incidence (cos θ = 1) of every cosine argument: finite values and gradients; Python
lists as arguments; in a fresh process, autograd after first calls in inference mode; and bad
input (a string, a cosine out of range) → ValueError naming the argument.

Arguments that are not per-sample data (wavelength grids shared by the batch, structures,
counts, option strings) are out of scope here: a NaN wavelength grid or a NaN setting is a
parameter error. Functions with a whole-scene output (``scatterogram``, ``montecarlo_brdf``,
``match_scatterogram``) have their own NaN tests. test_validation.py and test_nan_propagation.py
(next to this file) keep the targeted cases this table grew from.

Test ids start with the subpackage of the function under test (``optics.bragg_reflectance-n1``,
``api_cases.case_id``): ``pytest tests/contract -k spectral`` runs the cases of torchirid.spectral.
"""

from __future__ import annotations


import pytest
import torch

import torchirid as ti
from api_cases import CASES, NAN, case_id, pick  # the shared table of calls (tests/api_cases.py)

PARAMS = [(name, arg) for name, (_, _, args, _) in CASES.items() for arg in args]


def test_the_table_covers_the_per_sample_api():
    """Every public function that takes per-sample data is in the table or named as out of scope."""
    import inspect

    covered = {fn.__name__ for fn, *_ in CASES.values()}  # (the flat ones; subpackage ones are extra)
    elsewhere = {  # not per-sample data, or scene-level (own tests), or set-up
        "cmfs", "illuminant_spd", "white_point_xy", "white_point_xyz", "xyz_weights",
        "transmission_filter_lut", "transmissivity_lut", "read_scatterogram", "match_scatterogram",
        "scatterogram", "montecarlo_brdf", "sample_single_reflection", "shade_thin_film_environment",
        "hirayama_stacks", "film_reflectance_lut", "available_materials", "material_range", "delta_e",
        "clear_caches", "options",
        "export_lut",
        "read_cube", "read_environment",  # files and set-up
        "prefilter_environment", "estimate_film"}  # whole images: tests/ibl, tests/estimation
    public = {n for n in ti.__all__ if inspect.isfunction(getattr(ti, n))}
    assert public - covered - elsewhere == set()


def _poisoned(value):
    v = value.clone()
    v[0] = complex(NAN, 0.0) if v.is_complex() else NAN
    return v


_pick = pick


@pytest.mark.parametrize("name,arg", PARAMS, ids=[f"{case_id(n)}-{a}" for n, a in PARAMS])
def test_nan_in_one_sample_stays_in_that_sample(name, arg):
    fn, build, _, which = CASES[name]
    clean = _pick(fn(**build()), which)
    kw = build()
    kw[arg] = _poisoned(kw[arg])
    out = _pick(fn(**kw), which)
    assert out.shape == clean.shape and out.shape[0] == 2
    assert torch.isnan(out[0]).all(), f"{name}({arg}=NaN) entry 0: {out[0]}"
    assert torch.allclose(out[1], clean[1], rtol=1e-12, atol=1e-300), f"{name}({arg}=NaN) entry 1 changed"


def test_clean_table_is_finite():
    """A positive control: the clean calls are finite (a NaN out of every call would pass above)."""
    for name, (fn, build, _, which) in CASES.items():
        out = _pick(fn(**build()), which)
        assert torch.isfinite(out).all(), name
        assert out.shape[0] == 2 and torch.equal(out[0], out[1]) or torch.allclose(out[0], out[1], rtol=1e-13), name


def _grad_of_entry_1(fn, kw, arg, which):
    x = kw[arg].detach().clone().requires_grad_(True)
    kw = {**kw, arg: x}
    out = _pick(fn(**kw), which)
    if not out.requires_grad:
        return None
    y = torch.view_as_real(out[1]) if out.is_complex() else out[1]
    (g,) = torch.autograd.grad(y.sum(), x, allow_unused=True)
    return g


# the result does not depend smoothly on these (a sign test of m; the unused thickness)
NOT_DIFFERENTIABLE = {("smith_g", "m"), ("ibl.thin_film_xyz_gaussian_path", "thickness")}
GRAD_PARAMS = [p for p in PARAMS if p not in NOT_DIFFERENTIABLE]


@pytest.mark.parametrize("name,arg", GRAD_PARAMS, ids=[f"{case_id(n)}-{a}" for n, a in GRAD_PARAMS])
def test_nan_sample_leaves_the_other_gradients_alone(name, arg):
    """d(entry 1)/d(arg) is the same with entry 0 NaN: the NaN sample does not leak into the
    gradient of a good one through the backward pass (0 · NaN)."""
    fn, build, _, which = CASES[name]
    clean = _grad_of_entry_1(fn, build(), arg, which)
    assert clean is not None, f"{name} is not differentiable in {arg}"
    kw = build()
    kw[arg] = _poisoned(kw[arg])
    g = _grad_of_entry_1(fn, kw, arg, which)
    assert g is not None
    assert torch.isfinite(g[1]).all(), f"{name}: d(entry 1)/d{arg}[1] = {g[1]}"
    assert torch.allclose(g[1], clean[1], rtol=1e-10, atol=1e-300), (g[1], clean[1])


def _as_float32(kw):
    cast = {torch.float64: torch.float32, torch.complex128: torch.complex64}
    return {k: v.to(cast[v.dtype]) if torch.is_tensor(v) and v.dtype in cast else v for k, v in kw.items()}


# returns the table's dtype, not the query's (documented: the table carries its precision)
TABLE_DTYPE = {"lookup_film_reflectance k_r", "lookup_film_reflectance k_t"}


@pytest.mark.parametrize("name", list(CASES), ids=[case_id(n) for n in CASES])
def test_float32_inputs_give_float32_close_to_float64(name):
    """docs/conventions.md: dtype from the inputs; float32 stays finite and in range. Over the same table:
    float32 in → float32 (complex64) out, finite, within 1e-3 (relative, absolute below 1e-3) of
    float64 (measured worst 2.2e-4, ibl.light_mixture; most cases ~1e-7)."""
    fn, build, _, which = CASES[name]
    ref = _pick(fn(**build()), which)
    out = _pick(fn(**_as_float32(build())), which)
    want = ref.dtype if name in TABLE_DTYPE else {torch.float64: torch.float32,
                                                    torch.complex128: torch.complex64}[ref.dtype]
    assert out.dtype == want
    assert torch.isfinite(out).all()
    err = (out.to(ref.dtype) - ref).abs() / ref.abs().clamp(min=1e-3)
    assert float(err.max()) < 1e-3, float(err.max())


# cos_theta and alpha may not have more axes than tau's batch shape: a documented guard against a
# per-wavelength cos_theta (*, W), which would otherwise broadcast against tau's wavelength axis
NARROWER_BY_DESIGN = {(f, a) for f in ("transmission_probability", "transmission_weight")
                      for a in ("cos_theta", "alpha")}
BROADCAST_PARAMS = [p for p in PARAMS if p not in NARROWER_BY_DESIGN]


@pytest.mark.parametrize("name,arg", BROADCAST_PARAMS, ids=[f"{case_id(n)}-{a}" for n, a in BROADCAST_PARAMS])
def test_one_argument_with_extra_batch_axes_broadcasts(name, arg):
    """docs/conventions.md: every tensor argument broadcasts with the others. One per-sample argument
    gets two extra leading axes (3, 1, 2, …) while the others keep (2, …): the result is the
    clean batch's, repeated over the new axes."""
    fn, build, _, which = CASES[name]
    clean = _pick(fn(**build()), which)
    kw = build()
    v = kw[arg]
    kw[arg] = torch.stack([v, 1 * v, v + 0]).unsqueeze(1)  # (3, 1, 2, …)
    out = _pick(fn(**kw), which)
    assert out.shape == (3, 1) + clean.shape, (out.shape, clean.shape)
    for k in range(3):
        assert torch.allclose(out[k, 0], clean, rtol=1e-12, atol=1e-300), (name, arg, k)


@pytest.mark.parametrize("name", list(CASES), ids=[case_id(n) for n in CASES])
def test_empty_batch_gives_an_empty_result(name):
    """A batch of zero samples (every per-sample argument sliced to [:0]) returns an empty
    result of the right trailing shape instead of raising (e.g. on ``min()`` of an empty tensor)."""
    fn, build, args, which = CASES[name]
    clean = _pick(fn(**build()), which)
    kw = build()
    for a, v in kw.items():  # every per-sample tensor (leading axis 2), also those not poisoned above
        if torch.is_tensor(v) and v.dim() and v.shape[0] == 2:
            kw[a] = v[:0]
    out = _pick(fn(**kw), which)
    assert out.shape == (0,) + clean.shape[1:], (out.shape, clean.shape)


# finite differences would step an index off its domain: the lossless media of these stacks have
# κ = 0 exactly (on the boundary κ ≥ 0; their κ may not be perturbed below 0)
ON_THE_DOMAIN_EDGE = {("multilayer absorbing", "indices"), ("rough_multilayer_reflectance absorbing", "indices")}
FD_PARAMS = [p for p in GRAD_PARAMS if p not in ON_THE_DOMAIN_EDGE]


@pytest.mark.parametrize("name,arg", FD_PARAMS, ids=[f"{case_id(n)}-{a}" for n, a in FD_PARAMS])
def test_gradients_match_finite_differences(name, arg):
    """Autograd through every case of the table against central differences (float64,
    ``torch.autograd.gradcheck``, eps 1e-6, atol 1e-6, rtol 1e-4), one argument at a time; the
    sample points sit off the nodes of the tables that are interpolated (kinks there)."""
    fn, build, _, which = CASES[name]
    kw = build()

    def f(x):
        out = _pick(fn(**{**kw, arg: x}), which)
        return torch.view_as_real(out) if out.is_complex() else out

    x = kw[arg].detach().clone().requires_grad_(True)
    assert torch.autograd.gradcheck(f, (x,), eps=1e-6, atol=1e-6, rtol=1e-4, check_batched_grad=False)


# cosine arguments, entry 0 at grazing (0) and entry 1 at normal incidence (1)
COSINE_PARAMS = [(n, a) for n, a in PARAMS if a.startswith("cos")]
# domains that exclude grazing by design (documented ValueError), and Λ(θ → 90°) = ∞ (G1 = 1/(1 + Λ) = 0)
NO_GRAZING = {n for n, _ in COSINE_PARAMS if n.split()[0] in (
    "thin_film_xyz_uniform", "ibl.path_difference_moments", "ibl.uniform_light_moments", "ibl.light_mixture",
    "ibl.uniform.cos_theta1_distribution")}
INFINITE_AT_GRAZING = {"microfacet.smith_lambda"}


@pytest.mark.parametrize("name,arg", COSINE_PARAMS, ids=[f"{case_id(n)}-{a}" for n, a in COSINE_PARAMS])
def test_grazing_and_normal_incidence_are_finite_with_finite_gradients(name, arg):
    """docs/conventions.md's hard cases: cos θ = 0 and cos θ = 1 give finite values and finite gradients
    (the √(1 − cos²θ) and cot θ singularities guarded; a one-sided or 0 slope is reported where
    the exact one is infinite)."""
    fn, build, _, which = CASES[name]
    kw = build()
    v = kw[arg].detach().clone()
    v[0], v[1] = 0.0, 1.0
    if name in NO_GRAZING:
        with pytest.raises(ValueError, match=arg):
            fn(**{**kw, arg: v})
        v[0] = 1e-6
    x = v.requires_grad_(True)
    out = _pick(fn(**{**kw, arg: x}), which)
    if name in INFINITE_AT_GRAZING:
        assert torch.isposinf(out[0]).all()
        out = out[1:]
    assert torch.isfinite(out).all(), out
    y = torch.view_as_real(out) if out.is_complex() else out
    (g,) = torch.autograd.grad(y.sum(), x, allow_unused=True)
    assert g is not None and torch.isfinite(g[-1]).all() and (name in INFINITE_AT_GRAZING or torch.isfinite(g).all()), g


@pytest.mark.parametrize("name", list(CASES), ids=[case_id(n) for n in CASES])
def test_python_lists_take_the_working_dtype(name):
    """Per-sample arguments given as nested Python lists: with a float64 tensor among the other
    arguments the result is the all-tensor one (the lists are built in float64, not via float32);
    with lists only it is in torch's default dtype (as ``torch.tensor`` would do)."""
    fn, build, args, which = CASES[name]
    ref = _pick(fn(**build()), which)
    kw = build()
    for a in args:
        kw[a] = kw[a].tolist()
    out = _pick(fn(**kw), which)
    others = [v for k, v in kw.items() if torch.is_tensor(v) and v.dtype in (torch.float64, torch.complex128)]
    if name in DATA_DTYPE:  # documented: the dtype of the data argument, the others are grids
        assert out.dtype == torch.get_default_dtype()
    elif others or name in TABLE_DTYPE:
        assert out.dtype == ref.dtype and torch.allclose(out, ref, rtol=1e-13, atol=1e-300), float((out - ref).abs().max())
    else:
        assert out.dtype in (torch.get_default_dtype(), complex_of[torch.get_default_dtype()]), out.dtype


complex_of = {torch.float32: torch.complex64, torch.float64: torch.complex128}
# spectrum_to_xyz returns the spectrum's dtype (documented; the wavelengths are the sampling grid)
DATA_DTYPE = {"spectrum_to_xyz"}


_INFERENCE_FIRST = """
import sys, torch
sys.path[:0] = {paths!r}
import test_nan_harness as h  # (the table lives in api_cases.py)
for name, (fn, build, _, which) in h.CASES.items():  # the first call of everything, in inference mode
    with torch.inference_mode():
        h._pick(fn(**build()), which)
failed = []
for name, arg in h.GRAD_PARAMS:  # then autograd through the same calls (the caches filled above)
    fn, build, _, which = h.CASES[name]
    kw = build()
    x = kw[arg].clone().requires_grad_(True)
    try:
        out = h._pick(fn(**{{**kw, arg: x}}), which)
        torch.autograd.grad((torch.view_as_real(out) if out.is_complex() else out).sum(), x)
    except RuntimeError as exc:
        failed.append(f"{{name}}/{{arg}}: {{str(exc)[:80]}}")
print("failed:", len(failed))
print("\\n".join(failed))
"""


@pytest.mark.slow
def test_caches_filled_in_inference_mode_serve_autograd():
    """A fresh process whose first calls run in ``torch.inference_mode()`` (tables, quadratures and
    colour data get cached then) must still differentiate every case afterwards: cached tensors
    are built outside inference mode (``_autograd.normal_tensors``)."""
    import pathlib
    import subprocess
    import sys

    here = pathlib.Path(__file__).resolve().parent  # tests/contract, then tests/ (api_cases, tensors)
    paths = [str(here), str(here.parent)]
    run = subprocess.run([sys.executable, "-c", _INFERENCE_FIRST.format(paths=paths)], capture_output=True,
                         text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    assert "failed: 0" in run.stdout, run.stdout[-3000:]


def test_inputs_are_not_modified():
    """No call writes into its arguments (in-place ops on user tensors)."""
    for name, (fn, build, _, which) in CASES.items():
        kw = build()
        before = {k: v.clone() for k, v in kw.items() if torch.is_tensor(v)}
        fn(**kw)
        for k, v in before.items():
            assert torch.equal(kw[k], v), f"{name} modified {k}"


@pytest.mark.parametrize("name,arg", PARAMS, ids=[f"{case_id(n)}-{a}" for n, a in PARAMS])
def test_a_string_argument_raises_value_error_naming_it(name, arg):
    """docs/conventions.md: bad input → ValueError naming the parameter (not a TypeError from deep inside)."""
    fn, build, _, _ = CASES[name]
    with pytest.raises(ValueError, match=arg):
        fn(**{**build(), arg: "abc"})


SIGNED_COSINES = {("ggx_d", "cos_theta_m"), ("smith_g1", "cos_theta"), ("microfacet.smith_lambda", "cos_theta"),
                  ("optics.he_directional_diffuse", "cos_phi"), ("rough_multilayer_diffuse", "cos_phi")}


@pytest.mark.parametrize("name,arg", COSINE_PARAMS, ids=[f"{case_id(n)}-{a}" for n, a in COSINE_PARAMS])
def test_a_cosine_out_of_range_raises_value_error_naming_it(name, arg):
    """A cosine above 1 (and, where the sign has no meaning, below 0) in one sample → ValueError
    naming the argument, before any work."""
    fn, build, _, _ = CASES[name]
    for bad in (1.5, -0.1) if (name, arg) not in SIGNED_COSINES else (1.5, -1.5):
        kw = build()
        v = kw[arg].clone()
        v[1] = bad
        with pytest.raises(ValueError, match=arg):
            fn(**{**kw, arg: v})
