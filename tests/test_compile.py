"""The optional torch.compile kernels agree with the eager ones (values and gradients)."""

import math
import shutil

import pytest
import torch

import torchirid as ti


@pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None, reason="no C compiler")
@pytest.mark.slow
def test_compiled_bragg_matches_eager():
    lam = torch.linspace(380, 780, 101, dtype=torch.float64, requires_grad=True)
    c = torch.cos(torch.linspace(0, math.pi / 2, 50, dtype=torch.float64))[:, None].clamp(0, 1)
    R0 = ti.bragg_reflectance(lam, c, 1.0, 1.5, 125.0, 375.0, 20, polarization="s")
    (g0,) = torch.autograd.grad(R0.sum(), lam)
    assert not ti.options("compile")
    ti.options(compile=True)
    try:
        with _no_warning():
            R1 = ti.bragg_reflectance(lam, c, 1.0, 1.5, 125.0, 375.0, 20, polarization="s")
            (g1,) = torch.autograd.grad(R1.sum(), lam)
    finally:
        ti.options(compile=False)
    assert (R1 - R0).abs().max() <= 1e-11
    assert (g1 - g0).abs().max() <= 1e-8 * g0.abs().max()


class _no_warning:
    """Fail if the compiled path fell back to eager (it warns then)."""

    def __enter__(self):
        import warnings

        self._cm = warnings.catch_warnings(record=True)
        self._log = self._cm.__enter__()
        warnings.simplefilter("always")
        return self

    def __exit__(self, *exc):
        self._cm.__exit__(*exc)
        fallbacks = [w for w in self._log if "torchirid: torch.compile" in str(w.message)]
        assert not fallbacks, fallbacks[0].message
        return False


def test_set_compile_validates():
    with pytest.raises(ValueError, match="compile must be True or False"):
        ti.options(compile="yes")


@pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None, reason="no C compiler")
@pytest.mark.slow
def test_compiled_piecewise_matches_eager(monkeypatch):
    # both compiled stages (landmarks + box layout, sub-boxes + table lookup), no eager fallback
    from torchirid import _compile

    monkeypatch.setattr(_compile, "MIN_POINTS", 0)  # a small batch, compiled all the same
    c = torch.cos(torch.deg2rad(torch.linspace(0, 89, 12, dtype=torch.float64)))
    d1 = torch.tensor([50.0, 250.0, 450.0], dtype=torch.float64)[:, None]
    x0 = ti.bragg_xyz(c, 1.0, 1.5, d1, 500.0 - d1, 20, method="piecewise")
    ti.options(compile=True)
    try:
        with _no_warning():
            x1 = ti.bragg_xyz(c, 1.0, 1.5, d1, 500.0 - d1, 20, method="piecewise")
    finally:
        ti.options(compile=False)
    assert (x1 - x0).abs().max() <= 1e-12
