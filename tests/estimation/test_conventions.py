"""torchirid.estimation follows the library's dialect: dtype and device come from the inputs
(nothing is created in the default dtype or on the default device), one polarization default,
literal ``__all__`` lists, no import cycle, validation before any work."""

from __future__ import annotations

import ast
import contextlib
import inspect
import pathlib

import pytest
import torch
from torch.utils._python_dispatch import TorchDispatchMode

import torchirid.estimation as E

F64 = torch.float64
PACKAGE = pathlib.Path(E.__file__).parent
KW = dict(sample=36, iterations=2, final_iterations=1, polarization="s")


@pytest.fixture(scope="module")
def cube():
    return E.synthetic_cube("mgf2_400", height=6, width=6, seed=0, polarization="s")


@contextlib.contextmanager
def default_dtype(dtype):
    old = torch.get_default_dtype()
    torch.set_default_dtype(dtype)
    try:
        yield
    finally:
        torch.set_default_dtype(old)


class DoubleOps(TorchDispatchMode):
    """Records every op that returns a float64 or complex128 tensor — not counting the zero tangents
    forward-mode autograd gives Python scalar constants (PyTorch wraps those numbers as float64)
    nor its shape checks on them (meta tensors, which hold no values)."""

    def __init__(self):
        super().__init__()
        self.ops = set()

    def __torch_dispatch__(self, func, types, args=(), kwargs=None):
        out = func(*args, **(kwargs or {}))
        for o in out if isinstance(out, (tuple, list)) else (out,):
            if (isinstance(o, torch.Tensor) and o.dtype in (torch.float64, torch.complex128)
                    and not o._is_zerotensor() and o.device.type != "meta"):
                self.ops.add(str(func))
        return out


def estimate(c, dtype=F64, device="cpu"):
    return E.estimate_film(c.cube.to(device, dtype), c.wavelength.to(device, dtype), c.cos_theta.to(device, dtype),
                           1.64, **KW)


def test_float32_inputs_compute_in_float32_whatever_the_default_dtype(cube):
    ref = estimate(cube, torch.float32)
    with default_dtype(F64), DoubleOps() as rec:
        est = estimate(cube, torch.float32)
    assert not rec.ops, f"float64 tensors made inside a float32 estimate: {sorted(rec.ops)}"
    assert {t.dtype for t in (est.params, est.thickness, est.rms, est.thickness_peak)} == {torch.float32}
    assert est.n == ref.n and torch.equal(est.thickness, ref.thickness) and torch.equal(est.params, ref.params)


def test_float64_results_do_not_depend_on_the_default_dtype(cube):
    ref = estimate(cube)
    with default_dtype(torch.float32):
        est32 = estimate(cube)
    with default_dtype(F64):
        est64 = estimate(cube)
    for est in (est32, est64):
        assert est.params.dtype == F64 and est.thickness.dtype == F64
        assert est.n == ref.n and torch.equal(est.thickness, ref.thickness) and torch.equal(est.rms, ref.rms)


def test_nothing_is_allocated_on_the_default_device(cube):
    """With the default device set to ``meta`` (no data), a tensor created without ``device=``
    would break the run (meta tensors have no values); CPU inputs must give the CPU result."""
    ref = estimate(cube)
    with torch.device("meta"):
        est = estimate(cube)
        again = E.synthetic_cube("mgf2_400", height=6, width=6, seed=0, polarization="s")
    assert est.thickness.device.type == "cpu" and torch.equal(est.thickness, ref.thickness) and est.n == ref.n
    assert again.cube.device.type == "cpu" and torch.equal(again.cube, cube.cube)


@pytest.mark.skipif(not torch.cuda.is_available(), reason="no CUDA device")
def test_cuda_inputs_stay_on_cuda_and_agree_with_cpu(cube):
    dev = torch.device("cuda")
    est = estimate(cube, device=dev)
    ref = estimate(cube)
    assert {t.device.type for t in (est.params, est.thickness, est.rms, est.thickness_peak)} == {"cuda"}
    assert abs(est.n - ref.n) < 1e-9 and torch.allclose(est.thickness.cpu(), ref.thickness, rtol=0, atol=1e-6)
    on_gpu = E.synthetic_cube("mgf2_400", height=6, width=6, seed=0, polarization="s",
                              wavelength=E.synthetic.default_wavelengths().to(dev))
    assert on_gpu.cube.device.type == "cuda" and torch.allclose(on_gpu.cube.cpu(), cube.cube, rtol=0, atol=1e-12)


def _polarization_defaults():
    for name in E.__all__:
        obj = getattr(E, name)
        if callable(obj) and not inspect.isclass(obj):
            p = inspect.signature(obj).parameters.get("polarization")
            if p is not None:
                yield name, p.default


def test_one_polarization_default_and_the_cube_matches_the_fit():
    defaults = dict(_polarization_defaults())
    assert {"estimate_film", "refine_film", "peak_method", "synthetic_cube"} <= set(defaults)
    assert set(defaults.values()) == {"unpolarized"}, defaults
    c = E.synthetic_cube("mgf2_600", height=8, width=8, seed=2)  # both defaults: a consistent pair
    est = E.estimate_film(c.cube, c.wavelength, c.cos_theta, 1.64, sample=64)
    assert est.settings["polarization"] == c.polarization == "unpolarized"
    assert abs(est.n - 1.37) < 0.01 and float((est.thickness - c.thickness).abs().mean()) < 5.0


def _modules():
    return sorted(p for p in PACKAGE.glob("*.py") if p.name != "__init__.py")


@pytest.mark.parametrize("path", [*_modules(), PACKAGE / "__init__.py"], ids=lambda p: p.name)
def test_every_module_has_a_literal_all(path):
    tree = ast.parse(path.read_text())
    lists = [n.value for n in tree.body if isinstance(n, ast.Assign)
             and any(isinstance(t, ast.Name) and t.id == "__all__" for t in n.targets)]
    assert len(lists) == 1 and isinstance(lists[0], ast.List), f"{path.name}: __all__ must be one literal list"
    names = [ast.literal_eval(e) for e in lists[0].elts]
    module = E if path.name == "__init__.py" else __import__(f"torchirid.estimation.{path.stem}", fromlist=["_"])
    assert len(set(names)) == len(names) and all(hasattr(module, n) for n in names)


def test_no_import_cycle_inside_the_package():
    graph = {}
    for path in _modules():
        deps = set()
        for node in ast.walk(ast.parse(path.read_text())):  # module-level and function-level imports alike
            if isinstance(node, ast.ImportFrom) and node.level == 1 and node.module:
                deps.add(node.module.split(".")[0])
        graph[path.stem] = deps & {p.stem for p in _modules()}
    assert "refine" not in graph["peaks"] and "peaks" not in graph["residuals"]
    done, active = set(), []

    def visit(m):
        assert m not in active, f"import cycle: {' -> '.join(active + [m])}"
        if m in done:
            return
        active.append(m)
        for d in graph[m]:
            visit(d)
        active.pop()
        done.add(m)

    for m in graph:
        visit(m)


@pytest.mark.parametrize("call,match", [
    (lambda c: E.estimate_film(c.cube, c.wavelength, c.cos_theta, 1.64, sample=0), "sample must be an integer >= 1"),
    (lambda c: E.estimate_film(c.cube, c.wavelength, c.cos_theta, 1.64, final_iterations=1.5), "final_iterations"),
    (lambda c: E.estimate_film(c.cube, c.wavelength, c.cos_theta, 1.64, polarization="x"), "polarization"),
    (lambda c: E.estimate_film(c.cube, c.wavelength, c.cos_theta, 2 + 1j), "n_substrate"),
    (lambda c: E.estimate_film(c.cube, c.wavelength, c.cos_theta, 1.64, n_range=(2.0, 1.5)), "n_range"),
    (lambda c: E.estimate_film(c.cube, c.wavelength, c.cos_theta, 1.64, thickness_range=(2e-8, 2e-6)),
     r"thickness_range must be in nm"),  # metres
    (lambda c: E.peak_method(c.cube, c.wavelength, c.cos_theta, 1.64, thickness_range=(0.0, 0.002)), "in nm"),
    (lambda c: E.estimate_film(c.cube, c.wavelength, c.cos_theta, 1.64, bandwidth=-1.0), "bandwidth"),
    (lambda c: E.estimate_film(c.cube, c.wavelength, c.cos_theta.flip(0), 1.64), "sorted"),
    (lambda c: E.estimate_film(c.cube, c.wavelength, c.cos_theta + 1, 1.64), "cos_theta"),
    (lambda c: E.peak_method(c.cube, c.wavelength, c.cos_theta, 1.64, score_stride=0), "score_stride"),
    (lambda c: E.peak_method(c.cube, c.wavelength, c.cos_theta, 1.64, window=2.5), "window"),
    (lambda c: E.refine_film(c.cube, c.wavelength, c.cos_theta, 1.64, c.thickness, 1.4, iterations=-1), "iterations"),
    (lambda c: E.peaks.detect_extrema(c.cube, c.wavelength, max_extrema=0), "max_extrema"),
    (lambda c: E.measurement.band_nodes(4.0, 2.0), "nodes"),
    (lambda c: E.synthetic_cube(height=2.0), "height"),
])
def test_bad_arguments_are_named_before_any_work(cube, call, match):
    with pytest.raises(ValueError, match=match):
        call(cube)
