"""Argument validation of every public function (docs/conventions.md: "Validation raises ValueError
naming the parameter and the allowed range before any work; never assert. NaN inputs
propagate, they are not 'fixed'.").

"Before any work" is checked with a TorchFunctionMode that records the torch operations
a call performs: a rejected call may convert and compare its arguments, but must not reach
the physics (sqrt, exp, trigonometry, products, stacking ...). A positive control checks
that the recorder does see those operations in valid calls.
"""

from __future__ import annotations

import pathlib
import re

import numpy as np
import pytest
import torch
from torch.overrides import TorchFunctionMode

import torchirid

from tensors import F64, t64

NAN = float("nan")

# operations that only the physics performs (never the validation)
_WORK = {"sqrt", "exp", "sin", "cos", "asin", "atan2", "log1p", "expm1", "mul", "__mul__",
         "__rmul__", "div", "__truediv__", "__rtruediv__", "__rdiv__", "pow", "__pow__",
         "stack", "cat", "matmul", "addcmul", "minimum", "clamp", "where"}


class _Recorder(TorchFunctionMode):
    def __init__(self):
        super().__init__()
        self.names: list[str] = []

    def __torch_function__(self, func, types, args=(), kwargs=None):
        self.names.append(getattr(func, "__name__", str(func)))
        return func(*args, **(kwargs or {}))


# ----------------------------------------------------------------------------------------
# a valid call of every public function, as keyword arguments
# ----------------------------------------------------------------------------------------
GOOD = {
    "thin_film_reflectance": dict(wavelength=t64([450.0, 550.0]), cos_theta=t64(0.8), n_film=t64(1.4),
                                  thickness=t64(300.0), n_substrate=t64(1.5), n_incident=1.0),
    "multilayer": dict(wavelength=t64([450.0, 550.0]), cos_theta=t64(0.8), indices=t64([1.0, 1.4, 2.0, 1.5]),
                       thicknesses=t64([100.0, 50.0])),
    "bragg_reflectance": dict(wavelength=t64([450.0, 550.0]), cos_theta=t64(0.8), n1=t64(1.0), n2=t64(1.5),
                              d1=t64(125.0), d2=t64(375.0), cells=5),
    "bragg_dispersion": dict(wavelength=t64([450.0, 550.0]), cos_theta=t64(0.8), n1=t64(1.0), n2=t64(1.5),
                             d1=t64(125.0), d2=t64(375.0)),
    "bragg_envelope": dict(wavelength=t64([450.0, 550.0]), cos_theta=t64(0.8), n1=t64(1.0), n2=t64(1.5),
                           d1=t64(125.0), d2=t64(375.0)),
    "fresnel_reflectance": dict(cos_theta=t64([0.3, 0.8]), n_incident=1.0, n_substrate=t64(1.5)),
}
BRAGG = ("bragg_reflectance", "bragg_dispersion", "bragg_envelope")
WITH_WAVELENGTH = tuple(f for f in GOOD if f != "fresnel_reflectance")


def call(fname, **override):
    kw = dict(GOOD[fname])
    kw.update(override)
    return getattr(torchirid.optics, fname)(**kw)


# (function, {argument: bad value}, regex that the message must contain)
BAD = []
for f in WITH_WAVELENGTH:
    for v in (-500.0, 0.0, t64([500.0, -1.0]), t64([0.0, 500.0]), -1e-300):
        BAD.append((f, {"wavelength": v}, r"wavelength"))
for f in GOOD:
    for v in (-0.1, 1.0000001, t64([0.5, 1.5]), t64([-1e-300, 0.5]), 2):
        BAD.append((f, {"cos_theta": v}, r"cos_theta"))
# negative thickness
for v in (-1.0, t64([100.0, -1e-9])):
    BAD.append(("thin_film_reflectance", {"thickness": v}, r"\bthickness\b"))
for v in (t64([100.0, -1.0]), t64([[100.0, 5.0], [-3.0, 5.0]])):
    BAD.append(("multilayer", {"thicknesses": v}, r"thicknesses"))
for f in BRAGG:
    BAD.append((f, {"d1": -1.0}, r"\bd1\b"))
    BAD.append((f, {"d2": t64([375.0, -0.5])}, r"\bd2\b"))
# real index <= 0
for v in (0.0, -1.4, t64([1.4, 0.0])):
    BAD.append(("thin_film_reflectance", {"n_film": v}, r"n_film"))
for v in (0.0, -1.0, -1.0 + 0.5j):
    BAD.append(("thin_film_reflectance", {"n_substrate": v}, r"n_substrate"))
for v in (0.0, -1.0):
    BAD.append(("thin_film_reflectance", {"n_incident": v}, r"n_incident"))
for v in (t64([1.0, -1.0, 2.0, 1.5]), t64([0.0, 1.4, 2.0, 1.5]), t64([1.0, 1.4, 2.0, 0.0]),
          torch.tensor([1.0, 1.4, -2.0 + 0.1j, 1.5], dtype=torch.complex128)):
    BAD.append(("multilayer", {"indices": v}, r"indices"))
for f in BRAGG:
    BAD.append((f, {"n1": 0.0}, r"\bn1\b"))
    BAD.append((f, {"n2": -1.5}, r"\bn2\b"))
    BAD.append((f, {"n_incident": 0.0}, r"n_incident"))
    BAD.append((f, {"n_incident": t64([1.0, -1.2])}, r"n_incident"))
for v in (0.0, -1.0):
    BAD.append(("fresnel_reflectance", {"n_incident": v}, r"n_incident"))
    BAD.append(("fresnel_reflectance", {"n_substrate": v}, r"n_substrate"))
# extinction κ < 0
BAD.append(("thin_film_reflectance", {"n_film": 1.5 - 0.1j}, r"n_film"))
BAD.append(("thin_film_reflectance", {"n_substrate": torch.tensor([1.5 + 0.1j, 0.2 - 3.0j])}, r"n_substrate"))
BAD.append(("multilayer", {"indices": torch.tensor([1.0, 1.5 - 0.1j, 2.0, 1.5])}, r"indices"))
BAD.append(("multilayer", {"indices": torch.tensor([1.0, 1.5, 2.0, 1.5 - 1e-12j], dtype=torch.complex128)},
            r"indices"))
for f in BRAGG:
    BAD.append((f, {"n2": 1.5 - 0.1j}, r"\bn2\b"))
    BAD.append((f, {"n1": 1.5 - 0.1j, "n_incident": 1.0}, r"\bn1\b"))
BAD.append(("fresnel_reflectance", {"n_substrate": 1.5 - 0.1j}, r"n_substrate"))
# complex (absorbing) incident medium
BAD.append(("thin_film_reflectance", {"n_incident": 1.0 + 0.1j}, r"n_incident"))
BAD.append(("multilayer", {"indices": torch.tensor([1.0 + 0.1j, 1.4, 2.0, 1.5])}, r"indices"))
BAD.append(("fresnel_reflectance", {"n_incident": 1.0 + 0.1j}, r"n_incident"))
for f in BRAGG:
    BAD.append((f, {"n_incident": 1.0 + 0.1j}, r"n_incident"))
    BAD.append((f, {"n1": 1.0 + 0.1j}, r"\bn1\b"))  # n1 is the incident medium without n_incident
# cells
for v in (0, -3, 2.5, t64(2.5), torch.tensor([2.5, 3.0]), torch.tensor([1, 0]), torch.tensor([[3], [-1]]),
          True, np.float64(2.5), 1.0 + 0j, torch.tensor(3 + 0j)):
    BAD.append(("bragg_reflectance", {"cells": v}, r"cells"))
# polarization
for f in GOOD:
    for v in ("x", "S", "", "unpolarised", "P "):
        if f == "bragg_dispersion":
            BAD.append((f, {"polarization": v}, r"polarization.*'s'.*'p'"))
        else:
            BAD.append((f, {"polarization": v}, r"polarization.*'s'.*'p'.*'unpolarized'"))
BAD.append(("bragg_dispersion", {"polarization": "unpolarized"}, r"polarization.*'s'.*'p'"))
# bragg_envelope is defined for lossless, propagating layers only
BAD.append(("bragg_envelope", {"n2": 1.5 + 0.1j}, r"n1 and n2"))
# (deciding "TIR or not" needs n_incident² sin²θ: products allowed, nothing heavier)
BAD.append(("bragg_envelope", {"n1": 1.5, "n2": 1.2, "n_incident": 2.0, "cos_theta": 0.2}, r"n1 and n2"))
_DERIVED_CHECK = {"mul", "__mul__", "__rmul__", "pow", "__pow__", "minimum", "clamp", "where"}


def _qualified(fname):
    """``<subpackage>.<function>`` (ids start with the subpackage: ``pytest -k optics`` selects them)."""
    return getattr(torchirid.optics, fname).__module__.split(".")[1] + "." + fname


def _id(case):
    f, kw, _ = case
    return _qualified(f) + ":" + ",".join(f"{k}={v!r}" for k, v in kw.items()).replace("\n", "")[:60]


@pytest.mark.parametrize("case", BAD, ids=[_id(c) for c in BAD])
def test_bad_input_raises_valueerror_naming_parameter_before_work(case):
    fname, override, pattern = case
    rec = _Recorder()
    with rec:
        with pytest.raises(ValueError, match=pattern):
            call(fname, **override)
    work = set(rec.names) & _WORK
    if "n_incident" in override and "cos_theta" in override:  # the envelope's TIR check
        work -= _DERIVED_CHECK
    work = sorted(work)
    assert not work, f"{fname} did physics ({work}) before rejecting {override}"


@pytest.mark.parametrize("fname", list(GOOD), ids=[_qualified(f) for f in GOOD])
def test_recorder_sees_work_in_valid_calls(fname):
    """Positive control for the 'before any work' check above."""
    rec = _Recorder()
    with rec:
        out = call(fname)
    assert set(rec.names) & _WORK
    for o in out if isinstance(out, tuple) else (out,):
        assert torch.isfinite(o).all()


def _finite(out):
    return all(bool(torch.isfinite(o).all()) for o in (out if isinstance(out, tuple) else (out,)))


def test_valid_edge_values_are_accepted():
    # the closed ends of the allowed ranges, and the spellings that must be accepted
    for f in GOOD:
        for c in (0.0, 1.0):
            assert _finite(call(f, cos_theta=t64(c))), (f, c)
        for pol in ("s", "p") + (("unpolarized",) if f != "bragg_dispersion" else ()):
            assert _finite(call(f, polarization=pol)), (f, pol)
    assert _finite(call("thin_film_reflectance", thickness=0.0))
    assert _finite(call("multilayer", thicknesses=t64([0.0, 0.0])))
    assert _finite(call("bragg_reflectance", d1=0.0, cells=1))
    R3 = call("bragg_reflectance", cells=3)
    assert (call("bragg_reflectance", cells=3.0) == R3).all()  # an integral float is an integer
    assert (call("bragg_reflectance", cells=np.int64(3)) == R3).all()
    assert (call("bragg_reflectance", cells=torch.tensor(3)) == R3).all()
    assert _finite(call("thin_film_reflectance", n_incident=torch.tensor(1.2 + 0j)))  # complex dtype, κ = 0
    assert _finite(call("multilayer", indices=torch.tensor([1.0 + 0j, 1.4, 2.0 + 0.5j, 1.5 + 3j])))
    assert _finite(call("fresnel_reflectance", n_substrate=1.5 + 0j))


def test_cells_int_tensor_broadcasts():
    wl = t64([[450.0], [520.0], [610.0]])  # (3, 1)
    cells = torch.tensor([1, 5, 20, 1000])  # (4,)
    R = call("bragg_reflectance", wavelength=wl, cells=cells)
    assert R.shape == (3, 4)
    for i in range(3):
        for j, n in enumerate((1, 5, 20, 1000)):
            r = call("bragg_reflectance", wavelength=wl[i, 0], cells=n)
            assert abs(R[i, j].item() - r.item()) <= 1e-15
    # integral float tensors are accepted too and give the same values
    R2 = call("bragg_reflectance", wavelength=wl, cells=cells.to(F64))
    assert (R2 - R).abs().max().item() <= 1e-15


@pytest.mark.parametrize("cells", ["3", None, float("nan"), float("inf")], ids=["str", "None", "nan", "inf"])
def test_cells_not_a_number_raises_valueerror_naming_cells(cells):
    with pytest.raises(ValueError, match="cells"):
        call("bragg_reflectance", cells=cells)


@pytest.mark.parametrize("cells", [torch.tensor(float("inf")), torch.tensor(1e30)], ids=["inf", "1e30"])
def test_cells_huge_float_tensor_message(cells):
    with pytest.raises(ValueError, match="cells") as info:
        call("bragg_reflectance", cells=cells)
    assert "-9223372036854775808" not in str(info.value)


# ----------------------------------------------------------------------------------------
# NaN propagates (no exception, no 'fix')
# ----------------------------------------------------------------------------------------
NAN_CASES = [
    ("thin_film_reflectance", "wavelength"), ("thin_film_reflectance", "cos_theta"),
    ("thin_film_reflectance", "n_film"), ("thin_film_reflectance", "thickness"),
    ("thin_film_reflectance", "n_substrate"), ("thin_film_reflectance", "n_incident"),
    ("multilayer", "wavelength"), ("multilayer", "thicknesses"),
    ("bragg_dispersion", "wavelength"), ("bragg_dispersion", "cos_theta"), ("bragg_dispersion", "n2"),
    ("bragg_dispersion", "d1"), ("bragg_envelope", "wavelength"), ("bragg_envelope", "d2"),
    ("fresnel_reflectance", "cos_theta"), ("fresnel_reflectance", "n_substrate"), ("fresnel_reflectance", "n_incident"),
]


def _with_nan(fname, arg):
    """The GOOD value of ``arg`` as a batch of 2 (a fresh tensor) with a NaN in entry 0."""
    base = torch.as_tensor(GOOD[fname][arg], dtype=F64)
    if arg in ("indices", "thicknesses"):
        base = base.expand(2, *base.shape)
    elif base.ndim == 0:
        base = base.expand(2)
    base = base.clone()  # never write into GOOD's tensors
    base[0] = NAN
    return base


@pytest.mark.parametrize("fname,arg", NAN_CASES, ids=[f"{_qualified(f)}-{a}" for f, a in NAN_CASES])
def test_nan_propagates(fname, arg):
    out = call(fname, **{arg: _with_nan(fname, arg)})
    R = out[0] if isinstance(out, tuple) else out
    assert torch.isnan(R.reshape(2, -1)[0]).all()
    assert torch.isfinite(R.reshape(2, -1)[1]).all()


def test_nan_propagates_bragg_absorbing_path():
    R = call("bragg_reflectance", wavelength=t64([NAN, 500.0]), n2=1.5 + 0.01j)
    assert torch.isnan(R[0]) and torch.isfinite(R[1])


@pytest.mark.parametrize("arg", ["wavelength", "cos_theta", "n1", "n2", "d1", "d2"])
def test_nan_propagates_bragg_reflectance(arg):
    v = torch.as_tensor(GOOD["bragg_reflectance"][arg], dtype=F64).expand(2).clone()
    v[0] = NAN
    R = call("bragg_reflectance", **{arg: v})
    assert torch.isnan(R[0]) and torch.isfinite(R[1])


@pytest.mark.parametrize("case", ["n_incident", "wavelength with n_incident", "batch with grazing"])
def test_nan_propagates_bragg_reflectance_guarded(case):
    kw = dict(n1=1.33, n2=1.5, cos_theta=t64([0.8, 0.8]), wavelength=t64([450.0, 550.0]))
    if case == "n_incident":
        kw["n_incident"] = t64([NAN, 1.0])
    elif case == "wavelength with n_incident":
        kw.update(n_incident=1.0, wavelength=t64([NAN, 550.0]))
    else:
        kw.update(wavelength=t64([NAN, 550.0]), cos_theta=t64([0.8, 0.0]))
    R = call("bragg_reflectance", **kw)
    assert torch.isnan(R[0]) and torch.isfinite(R[1])


# ----------------------------------------------------------------------------------------
# no `assert` in the package (python -O strips it)
# ----------------------------------------------------------------------------------------
def test_no_assert_statements_in_src():
    pattern = r"\s*assert[\s(]"
    assert re.match(pattern, "        assert x > 0") and re.match(pattern, "assert(x)")
    assert not re.match(pattern, "    ``assert`` (python -O strips it)")
    src = pathlib.Path(torchirid.__file__).resolve().parent
    files = sorted(src.rglob("*.py"))
    assert files, src
    offenders = []
    for path in files:
        for lineno, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if re.match(pattern, line):
                offenders.append(f"{path.relative_to(src)}:{lineno}: {line.strip()}")
    assert not offenders, "validation must raise ValueError, not assert:\n" + "\n".join(offenders)


def test_python_sequences_are_built_in_the_working_dtype():
    """Lists/tuples of Python floats become float64 directly, not float32 cast up (0.1 stays 0.1)."""
    from torchirid import _checks

    t = _checks.as_real([0.1, 0.7], "x", torch.float64, "cpu")
    assert t.dtype == torch.float64 and t.tolist() == [0.1, 0.7]
    with pytest.raises(ValueError, match="x must be real"):
        _checks.as_real([1 + 2j], "x", torch.float64, "cpu")
    # refractive indices too (a list of n, or of n + iκ): 1.4 stays 1.4, 0.1j stays 0.1j
    n = _checks.as_index([1.4, 1.33], "n", torch.float64, "cpu")
    assert n.dtype == torch.float64 and n.tolist() == [1.4, 1.33]
    k = _checks.as_index([1.4 + 0.1j, 1.5], "n", torch.float64, "cpu")
    assert k.dtype == torch.complex128 and k.tolist() == [1.4 + 0.1j, 1.5 + 0j]
    assert _checks.as_index([1.4], "n", torch.float32, "cpu").dtype == torch.float32
    # through a public function: a list index gives what the tensor gives
    lam, c = torch.tensor([450.0, 550.0], dtype=torch.float64), torch.tensor(0.8, dtype=torch.float64)
    listed = torchirid.thin_film_reflectance(lam, c, [1.4, 1.4], 300.0, 1.5)
    tensor = torchirid.thin_film_reflectance(lam, c, torch.tensor([1.4, 1.4], dtype=torch.float64), 300.0, 1.5)
    assert torch.equal(listed, tensor)
