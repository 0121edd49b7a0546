"""Argument validation and dtype/device resolution: one place, errors name the parameter
(plus the few numerical guards and autograd/inference-mode helpers every module shares).

Every public function calls these *before* doing any work. Validation never uses
``assert`` (``python -O`` strips it) and never "fixes" NaN: NaN fails no comparison, so
it passes the checks and propagates through the physics.
"""

from __future__ import annotations

import functools
import math
import numbers
from typing import Sequence

import torch

POLARIZATIONS = ("s", "p", "unpolarized")


_VALUE_CHECKS = {"enabled": True}


def value_checks_enabled() -> bool:
    """Whether torchirid checks argument *values* (ranges, units, NaN-free counts).

    Off under ``torchirid.options(value_checks=False)``, and
    automatically while ``torch.compile`` traces (``torch.compiler.is_compiling()``).

    >>> import torchirid
    >>> torchirid._checks.value_checks_enabled()
    True
    >>> with torchirid.options(value_checks=False):
    ...     torchirid._checks.value_checks_enabled()
    False
    """
    return _VALUE_CHECKS["enabled"] and not torch.compiler.is_compiling()


def traceable() -> bool:
    """True when kernels must avoid data-dependent Python control flow: value checks off
    (``torchirid.options(value_checks=False)``) or ``torch.compile`` tracing. Guards that would branch on tensor
    values (``if bool(mask.any())``) then take their masked branch unconditionally."""
    return not value_checks_enabled()


def _value_check(fn):
    """Decorator: the check runs only while :func:`value_checks_enabled`."""

    @functools.wraps(fn)
    def run(*args, **kwargs):
        if value_checks_enabled():
            return fn(*args, **kwargs)
        return None

    return run


def _is_tensorlike(x) -> bool:
    return isinstance(x, torch.Tensor) or hasattr(x, "__array__")


def resolve_dtype_device(*args) -> tuple[torch.dtype, torch.device]:
    """The real floating dtype and the device shared by ``args``.

    float64/complex128 anywhere → float64; otherwise float32/complex64 → float32;
    only Python numbers and integer tensors → ``torch.get_default_dtype()``.
    The device is the first tensor's device (torch raises later if they differ).
    """
    dtype = None
    device = None
    for a in args:
        if a is None:
            continue
        if not isinstance(a, torch.Tensor):
            if hasattr(a, "__array__"):
                a = torch.as_tensor(a)
            else:
                continue
        if device is None:
            device = a.device
        if a.dtype in (torch.float64, torch.complex128):
            dtype = torch.float64
        elif a.dtype in (torch.float32, torch.complex64, torch.float16, torch.bfloat16):
            if dtype is None:
                dtype = torch.float32
    if dtype is None:
        dtype = torch.get_default_dtype()
    if device is None:
        device = torch.device("cpu")
    return dtype, device


def safe_sqrt(x: torch.Tensor) -> torch.Tensor:
    """√x, with value and gradient 0 for x ≤ 0 (a bare √0 sends 0·∞ = NaN back even through a
    ``where`` that does not use it); NaN propagates."""
    zero = x <= 0
    return torch.where(zero, torch.zeros_like(x), torch.sqrt(torch.where(zero, torch.ones_like(x), x)))


def complex_dtype(real_dtype: torch.dtype) -> torch.dtype:
    return torch.complex128 if real_dtype == torch.float64 else torch.complex64


def _number(x, dtype, device) -> torch.Tensor:
    """A Python float or complex as a 0-d tensor of ``dtype``: ``torch.scalar_tensor`` (half the cost of
    ``as_tensor``) in double precision, where every Python number fits; ``as_tensor`` otherwise (it
    rounds a float32 overflow to inf where ``scalar_tensor`` raises)."""
    if dtype == torch.float64 or dtype == torch.complex128:
        return torch.scalar_tensor(x, dtype=dtype, device=device)
    return torch.as_tensor(x, dtype=dtype, device=device)


def as_real(x, name: str, dtype, device) -> torch.Tensor:
    """``x`` as a real tensor of ``dtype`` on ``device``; complex input is an error.

    Python numbers are built directly in ``dtype`` (never via float32 and cast up).
    """
    if isinstance(x, complex):
        raise ValueError(f"{name} must be real, got a complex number")
    if isinstance(x, bool):
        raise ValueError(f"{name} must be a real number, got a bool")
    if isinstance(x, numbers.Real):
        return _number(float(x), dtype, device)
    if isinstance(x, torch.Tensor) and x.dtype == dtype and x.device == device:
        return x  # (already a real tensor of dtype where it belongs)
    try:
        t = torch.as_tensor(x, device=device)
        if isinstance(x, (list, tuple)) and not (t.is_complex() or t.dtype == torch.bool):
            t = torch.as_tensor(x, dtype=dtype, device=device)  # Python numbers built in dtype, not via float32
    except (TypeError, ValueError, RuntimeError) as exc:
        raise ValueError(f"{name} must be real numbers; got {x!r}") from exc
    if t.is_complex():
        raise ValueError(f"{name} must be real, got a complex tensor")
    if t.dtype == torch.bool:
        raise ValueError(f"{name} must be a real number, got a boolean tensor")
    return t.to(dtype)


def as_index(x, name: str, dtype, device) -> torch.Tensor:
    """A refractive index ``n + iκ`` as a real tensor (if real) or complex tensor."""
    if isinstance(x, bool):
        raise ValueError(f"{name} must be a refractive index, got a bool")
    if isinstance(x, complex):
        return _number(x, complex_dtype(dtype), device)
    if isinstance(x, numbers.Real):
        return _number(float(x), dtype, device)
    if isinstance(x, torch.Tensor) and (x.dtype == dtype or x.dtype == complex_dtype(dtype)) and x.device == device:
        return x  # (already a real or complex tensor of the precision where it belongs)
    try:
        t = torch.as_tensor(x, device=device)
    except (TypeError, ValueError, RuntimeError) as exc:
        raise ValueError(f"{name} must be a refractive index (real or complex numbers); got {x!r}") from exc
    if t.dtype == torch.bool:
        raise ValueError(f"{name} must be a refractive index, got a boolean tensor")
    if isinstance(x, (list, tuple)):  # Python numbers built in dtype, not via float32 / complex64
        return torch.as_tensor(x, dtype=complex_dtype(dtype) if t.is_complex() else dtype, device=device)
    if t.is_complex():
        return t.to(complex_dtype(dtype))
    return t.to(dtype)


def _scalar(t: torch.Tensor):
    """The Python value of a one-element real tensor (cheap checks for scalar arguments), else None."""
    if t.numel() == 1 and not t.is_complex():
        return t.item()
    return None


def reads_cheaply(t: torch.Tensor) -> bool:
    """Whether a guard may read ``t``'s values back to skip a masked pass that would change
    nothing (a critical-angle nudge, a 0/0 guard, a same-medium substitution): on the CPU, where
    reading a value costs less than one small op, and not under vmap / ``torch.compile``
    (:func:`traceable`). On an accelerator a read waits for every queued kernel: the masked pass
    runs instead."""
    return t.is_cpu and not traceable()


#: up to this many elements a guard reads a tensor's values into Python (``tolist``, ~0.3 µs)
#: rather than reducing it with ``all`` / ``any`` (2–8 µs on a few elements)
_READ_ELEMENTS = 64


def _flat_values(t: torch.Tensor) -> list:
    """The values of a small tensor as a flat Python list."""
    v = t.tolist()
    for _ in range(t.ndim - 1):
        v = [x for row in v for x in row]
    return v if t.ndim else [v]


def small_values(t: torch.Tensor) -> list | None:
    """The values of ``t`` as a flat Python list if it holds at most a few elements (read with one
    ``tolist``, where ``any`` / ``all`` / ``min`` would cost a reduction each), else None."""
    return _flat_values(t) if t.numel() <= _READ_ELEMENTS else None


def known_nonzero(t: torch.Tensor) -> bool:
    """True when ``t`` holds no zero, as read back where that is cheap (:func:`reads_cheaply`; a
    few elements are read into Python without a reduction); False where it holds a zero or cannot
    be read — the caller then takes its guarded (masked) branch. NaN is not zero."""
    if not t.is_cpu or traceable():
        return False
    if t.numel() <= _READ_ELEMENTS:
        return all(v != 0 for v in _flat_values(t))
    return bool(t.all())


def any_true(mask: torch.Tensor) -> bool:
    """``bool(mask.any())``, read on any device (for a guard that must know), a few elements without
    the reduction."""
    if mask.numel() <= _READ_ELEMENTS:
        return any(_flat_values(mask))
    return bool(mask.any())


def nonzero(t: torch.Tensor) -> bool:
    """Whether ``t`` holds no zero (``not bool((t == 0).any())``), read on any device, a few
    elements without a pass over them. NaN is not zero."""
    if t.numel() <= _READ_ELEMENTS:
        return all(v != 0 for v in _flat_values(t))
    return not bool((t == 0).any())


def known_false(mask: torch.Tensor) -> bool:
    """True when the boolean ``mask`` is False everywhere, as read back where that is cheap
    (:func:`reads_cheaply`); False where some element is True or it cannot be read."""
    if not mask.is_cpu or traceable():
        return False
    if mask.numel() <= _READ_ELEMENTS:
        return not any(_flat_values(mask))
    return not bool(mask.any())


#: √(smallest normal) per real dtype (:func:`flush_grazing`)
_TINY_ROOT = {dt: torch.finfo(dt).tiny ** 0.5 for dt in (torch.float64, torch.float32, torch.float16, torch.bfloat16)}


def flush_grazing(c: torch.Tensor) -> torch.Tensor:
    """Cosines below √(smallest normal) (≈1.5e-154 in float64, 1.1e-19 in float32) become 0.

    Such angles are grazing to every digit of R (which is smooth in cos θ), while their
    squares and admittances underflow to subnormals that complex division cannot scale
    (0/0 → NaN). NaN passes through unchanged.
    """
    tiny = _TINY_ROOT.get(c.dtype)
    if tiny is None:
        tiny = torch.finfo(c.dtype).tiny ** 0.5
    if traceable():  # no data-dependent branch (vmap, torch.compile)
        return torch.where(c.abs() < tiny, torch.zeros_like(c), c)
    if c.numel() == 1:  # one cosine: read it (no pass over the data; NaN is not < tiny)
        if not abs(c.item()) < tiny:
            return c
    else:
        with torch.no_grad():
            if not bool((c.abs() < tiny).any()):  # the common case: nothing to flush, no extra pass
                return c
    return torch.where(c.abs() < tiny, torch.zeros_like(c), c)


@_value_check
def check_positive(t: torch.Tensor, name: str, unit: str = "nm") -> None:
    v = _scalar(t)
    if v is not None:
        if v <= 0:
            raise ValueError(f"{name} must be > 0 {unit}; got {v:g}")
        return
    with torch.no_grad():
        if bool((t <= 0).any()):
            raise ValueError(f"{name} must be > 0 {unit}; got min {t.min().item():g}")


#: The wavelengths torchirid accepts, in nm: from soft X-rays to millimetre waves. Values outside
#: are almost always a unit mistake (5e-7 is 500 nm written in metres).
MIN_WAVELENGTH_NM = 1.0
MAX_WAVELENGTH_NM = 1.0e6


@_value_check
def check_wavelength(t: torch.Tensor, name: str = "wavelength") -> None:
    """ValueError unless every (non-NaN) value lies in [MIN_WAVELENGTH_NM, MAX_WAVELENGTH_NM] nm.

    >>> check_wavelength(torch.tensor([380.0, 780.0]))
    >>> check_wavelength(torch.tensor(5e-7))
    Traceback (most recent call last):
    ...
    ValueError: wavelength must be in nm, between 1 and 1e+06 nm; got 5e-07 (metres or micrometres? 500 nm is 500.0, not 5e-7 or 0.5)
    """
    v = _scalar(t)
    if v is not None:
        if not (v < MIN_WAVELENGTH_NM or v > MAX_WAVELENGTH_NM):  # (NaN passes: it propagates)
            return
        bad = v
    else:
        with torch.no_grad():
            outside = (t < MIN_WAVELENGTH_NM) | (t > MAX_WAVELENGTH_NM)  # one pass, NaN is False
            if not bool(outside.any()):
                return
            bad = t[outside].flatten()[0].item()
    raise ValueError(f"{name} must be in nm, between {MIN_WAVELENGTH_NM:g} and {MAX_WAVELENGTH_NM:g} nm; "
                     f"got {bad:g} (metres or micrometres? 500 nm is 500.0, not 5e-7 or 0.5)")


#: The shortest length (nm) taken at face value where a user gives lengths by hand (command-line
#: options, (min, max) ranges): anything shorter and > 0 is almost surely metres or micrometres
#: (a 300 nm film written 3e-7 or 0.3).
MIN_LENGTH_NM = 0.01


def check_length_unit(values, name: str, shown=None) -> None:
    """ValueError naming ``name`` if any of the lengths ``values`` (nm, floats) lies in
    (0, :data:`MIN_LENGTH_NM`): a unit mistake. ``shown``: what to quote (default the values)."""
    if any(0 < v < MIN_LENGTH_NM for v in values):
        raise ValueError(f"{name} must be in nm; got {values if shown is None else shown!r} "
                         "(metres or micrometres? 300 nm is 300, not 3e-7 or 0.3)")


def check_range(value, name: str, *, low: float = 0.0, high: float = math.inf, closed: bool = False,
                unit: str = "") -> tuple[float, float]:
    """The one check of a ``(low, high)`` pair of finite real numbers with ``low < high`` inside the
    bounds (open: ``low_bound < low``, ``high < high_bound``; ``closed``: ``≤``) → two floats, else
    the library's one message for it.

    >>> check_range((380, 780), "wavelength_range", low=1.0, high=1e6, closed=True, unit="nm")
    (380.0, 780.0)
    >>> check_range((2.0, 1.0), "period_range")
    Traceback (most recent call last):
        ...
    ValueError: period_range must be a pair (low, high) with 0 < low < high; got (2.0, 1.0)
    """
    ok = (isinstance(value, (tuple, list)) or (isinstance(value, torch.Tensor) and value.numel() == 2)) \
        and len(value) == 2
    if ok:
        try:
            a, b = (float(v) for v in value)
        except (TypeError, ValueError):
            ok = False
    if ok and not any(isinstance(v, bool) for v in value):
        ok = math.isfinite(a) and math.isfinite(b) and a < b and (
            (low <= a and b <= high) if closed else (low < a and b < high))
    else:
        ok = False
    if not ok:
        sign = "<=" if closed else "<"
        upper = "" if high == math.inf else f" {sign} {high:g}"
        units = f" in {unit}" if unit else ""
        raise ValueError(f"{name} must be a pair (low, high){units} with {low:g} {sign} low < high{upper}; "
                         f"got {value!r}")
    return a, b


def check_wavelength_range(wavelength_range, name: str = "wavelength_range") -> tuple[float, float]:
    """``(lo, hi)`` as floats with MIN_WAVELENGTH_NM ≤ lo < hi ≤ MAX_WAVELENGTH_NM nm, else ValueError.

    >>> check_wavelength_range((380, 780))
    (380.0, 780.0)
    """
    return check_range(wavelength_range, name, low=MIN_WAVELENGTH_NM, high=MAX_WAVELENGTH_NM, closed=True, unit="nm")


@_value_check
def check_nonnegative(t: torch.Tensor, name: str, unit: str = "nm") -> None:
    v = _scalar(t)
    if v is not None:
        if v < 0:
            raise ValueError(f"{name} must be >= 0 {unit}; got {v:g}")
        return
    with torch.no_grad():
        if bool((t < 0).any()):
            raise ValueError(f"{name} must be >= 0 {unit}; got min {t.min().item():g}")


@_value_check
def check_cosine(t: torch.Tensor, name: str = "cos_theta") -> None:
    v = _scalar(t)
    if v is not None:
        if v < 0 or v > 1:
            raise ValueError(f"{name} must lie in [0, 1] (cosine of the incidence angle); got {v:g}")
        return
    with torch.no_grad():
        if bool(((t < 0) | (t > 1)).any()):  # (NaN passes: it propagates)
            bad = t[(t < 0) | (t > 1)]
            raise ValueError(
                f"{name} must lie in [0, 1] (cosine of the incidence angle); got {bad.flatten()[0].item():g}"
            )


def check_numbers(**named) -> None:
    """ValueError naming the first argument that is not a number, a tensor or a (nested) sequence
    of numbers (e.g. a string), before any helper hands it to ``torch.as_tensor`` (TypeError)."""
    for name, x in named.items():
        if x is None or (isinstance(x, (torch.Tensor, numbers.Number)) and not isinstance(x, bool)):
            continue
        try:
            torch.as_tensor(x)
        except (TypeError, ValueError, RuntimeError) as exc:
            raise ValueError(f"{name} must be a number, a tensor or a sequence of numbers; got {x!r}") from exc


@_value_check
def check_signed_cosine(t: torch.Tensor, name: str = "cos_theta", slack: float = 1e-6) -> None:
    """A cosine whose sign carries meaning (or is ignored): in [-1, 1], up to ``slack`` (the z of a
    normalised direction may exceed 1 by rounding; the callers clamp); NaN passes (it propagates)."""
    lim = 1.0 + slack
    v = _scalar(t)
    if v is not None:
        if v < -lim or v > lim:
            raise ValueError(f"{name} must lie in [-1, 1] (a cosine); got {v:g}")
        return
    with torch.no_grad():
        bad = (t < -lim) | (t > lim)
        if bool(bad.any()):
            raise ValueError(f"{name} must lie in [-1, 1] (a cosine); got {t[bad].flatten()[0].item():g}")


@_value_check
def check_index(t: torch.Tensor, name: str) -> None:
    """Real part > 0 and extinction κ = Im ≥ 0 (κ > 0 means absorption)."""
    v = _scalar(t)
    if v is not None:
        if v <= 0:
            raise ValueError(f"{name} must have a real part > 0; got {v:g}")
        return
    with torch.no_grad():
        re = t.real if t.is_complex() else t
        if bool((re <= 0).any()):
            raise ValueError(f"{name} must have a real part > 0; got min {re.min().item():g}")
        if t.is_complex() and bool((t.imag < 0).any()):
            raise ValueError(
                f"{name} must have an extinction coefficient κ = Im({name}) >= 0 (absorption); "
                f"got min {t.imag.min().item():g}"
            )


@_value_check
def check_real_index(t: torch.Tensor, name: str) -> None:
    """An incident medium: real (lossless) with n > 0."""
    if not t.is_complex():
        check_index(t, name)
        return
    with torch.no_grad():
        if t.is_complex():
            if bool((t.imag != 0).any()):
                raise ValueError(f"{name} must be real (a lossless incident medium); got a complex index")
        check_index(t, name)


def as_cells(cells, device) -> torch.Tensor:
    """Number of Bragg cells as an int64 tensor; ValueError naming ``cells`` unless every
    value is a finite integer ≥ 1 (Python int, integer tensor/array, or integral floats)."""
    if isinstance(cells, bool):
        raise ValueError("cells must be an integer >= 1, got a bool")
    if isinstance(cells, numbers.Integral):
        if cells < 1:
            raise ValueError(f"cells must be an integer >= 1; got {cells}")
        if cells < 2**63:  # (scalar_tensor: half the cost of as_tensor, for any int64)
            return torch.scalar_tensor(int(cells), dtype=torch.int64, device=device)
        return torch.as_tensor(int(cells), dtype=torch.int64, device=device)
    if isinstance(cells, numbers.Real) and not _is_tensorlike(cells):
        if not math.isfinite(cells) or cells != int(cells) or cells < 1:
            raise ValueError(f"cells must be an integer >= 1; got {cells!r}")
        return torch.as_tensor(int(cells), dtype=torch.int64, device=device)
    if not (isinstance(cells, torch.Tensor) or hasattr(cells, "__array__")):
        raise ValueError(f"cells must be an integer >= 1 or an integer tensor; got {type(cells).__name__}")
    try:
        t = torch.as_tensor(cells, device=device)
    except (TypeError, ValueError, RuntimeError) as exc:
        raise ValueError(f"cells must be an integer >= 1 or an integer tensor; got {cells!r}") from exc
    if t.is_complex() or t.dtype == torch.bool:
        raise ValueError("cells must be an integer >= 1 (integer tensor)")
    if traceable():  # no value checks: no data-dependent branch (vmap, torch.compile)
        return t.to(torch.int64)
    if t.is_floating_point():
        with torch.no_grad():
            if not bool(torch.isfinite(t).all()):
                raise ValueError("cells must be finite integers >= 1; got inf or NaN")
            if bool((t != torch.round(t)).any()):
                raise ValueError("cells must be integers; got a non-integer value")
            if bool((t < 1).any()):
                raise ValueError(f"cells must be >= 1; got min {t.min().item():g}")
            if bool((t > 2**62).any()):
                raise ValueError(f"cells must be <= 2**62; got max {t.max().item():g}")
        t = t.to(torch.int64)
    if bool((t < 1).any()):
        raise ValueError(f"cells must be >= 1; got min {int(t.min())}")
    return t.to(torch.int64)


def check_polarization(polarization: str) -> None:
    if polarization not in POLARIZATIONS:
        raise ValueError(
            f"polarization must be one of {', '.join(repr(p) for p in POLARIZATIONS)}; got {polarization!r}"
        )


#: the pure polarizations averaged for each valid ``polarization`` (:func:`polarization_terms` without
#: the check, for kernels called after it)
POLARIZATION_TERMS = {"s": ("s",), "p": ("p",), "unpolarized": ("s", "p")}


def polarization_terms(polarization: str) -> tuple[str, ...]:
    """The pure polarizations whose results are averaged for ``polarization`` (validated):
    ``("s", "p")`` for ``"unpolarized"`` (the mean of the s and p quantities), else itself.

    >>> polarization_terms("unpolarized"), polarization_terms("p")
    (('s', 'p'), ('p',))
    """
    check_polarization(polarization)
    return POLARIZATION_TERMS[polarization]


def check_int(value, name: str, minimum: int = 1) -> int:
    """``value`` as a Python ``int`` if it is an integer (not a bool) ``>= minimum``; else a
    ValueError naming ``name``. NumPy integers are accepted.

    >>> check_int(3, "nodes", 2)
    3
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}; got {value!r}")
    return int(value)


def check_last_dim(t: torch.Tensor, name: str, size: int | None = None, at_least: int | None = None) -> None:
    if t.ndim == 0:
        raise ValueError(f"{name} must have a last axis (layers), got a scalar")
    if size is not None and t.shape[-1] != size:
        raise ValueError(f"{name} must have {size} entries on its last axis; got {t.shape[-1]}")
    if at_least is not None and t.shape[-1] < at_least:
        raise ValueError(f"{name} must have at least {at_least} entries on its last axis; got {t.shape[-1]}")


def names(seq: Sequence[str]) -> str:
    return ", ".join(repr(s) for s in seq)


def check_choice(value, name: str, choices):
    """``value`` if it is one of ``choices`` (a sequence, or a mapping's keys), else the one
    ValueError of the library for a bad option: ``<name> must be one of 'a', 'b'; got 'c'``."""
    try:
        ok = value in choices
    except TypeError:  # an unhashable value asked of a mapping
        ok = False
    if not ok:
        raise ValueError(f"{name} must be one of {names(choices)}; got {value!r}")
    return value


def broadcast_shapes(*shapes, names: Sequence[str] | None = None) -> torch.Size:
    """``torch.broadcast_shapes`` in plain Python.

    torch's version imports its symbolic-shape machinery (sympy) on first use, ~0.4 s once per
    process — more than a whole small call costs. Shapes that do not broadcast raise RuntimeError
    like torch does; with ``names`` (the arguments the shapes belong to), a ValueError naming the
    two that clash and how to make a table over both (:func:`_broadcast_error`).
    """
    if shapes and all(s == shapes[0] for s in shapes):  # (one-point calls: every shape ())
        return torch.Size(shapes[0])
    ndim = 0
    for s in shapes:  # (a loop, not max(..., default=0): torch.compile traces this)
        ndim = max(ndim, len(s))
    out = [1] * ndim
    for s in shapes:
        for i, size in enumerate(s, start=ndim - len(s)):
            size = int(size)
            if size == out[i] or size == 1:
                continue
            if out[i] == 1:
                out[i] = size
            else:
                if names is not None:
                    raise _broadcast_error(names, shapes)
                raise RuntimeError(f"Shape mismatch: objects cannot be broadcast to a single shape: {[tuple(x) for x in shapes]}")
    return torch.Size(out)


def _broadcast_error(names: Sequence[str], shapes) -> ValueError:
    """The ValueError for arguments ``names`` whose ``shapes`` do not broadcast: the first two
    that clash, and for two 1-D axes the ``[:, None]`` that makes a table over both."""
    shapes = [tuple(int(n) for n in s) for s in shapes]
    for j in range(1, len(shapes)):
        for i in range(j):
            try:
                broadcast_shapes(shapes[i], shapes[j])
            except RuntimeError:
                a, b, sa, sb = names[i], names[j], shapes[i], shapes[j]
                hint = ""
                if len(sa) == 1 and len(sb) == 1:
                    hint = (f"; for a table over both, give each its own axis: {a}[:, None] with {b} "
                            f"(shape ({sa[0]}, {sb[0]})), or {a} with {b}[:, None] (shape ({sb[0]}, {sa[0]}))")
                return ValueError(f"{a} (shape {sa}) and {b} (shape {sb}) do not broadcast together: "
                                  f"trailing axes must be equal or 1{hint}")
    return ValueError("the arguments do not broadcast together: " +
                      ", ".join(f"{n} {s}" for n, s in zip(names, shapes)))


def warn_caller(message: str, category=RuntimeWarning) -> None:
    """``warnings.warn`` attributed to the first stack frame outside the torchirid package (the
    user's call), however deep inside the library the warning is raised."""
    import os
    import sys
    import warnings

    root = os.path.dirname(os.path.abspath(__file__))
    level, frame = 2, sys._getframe(1)  # stacklevel 1 is this function, 2 its caller
    while frame is not None and os.path.abspath(frame.f_code.co_filename).startswith(root + os.sep):
        frame = frame.f_back
        level += 1
    warnings.warn(message, category, stacklevel=level)


# --- declarative argument specs ---------------------------------------------------------------
#
# A public function states what each argument is, once, beside its signature:
#
#     @_checks.arguments(wavelength=_checks.WAVELENGTH, cos_theta=_checks.COSINE,
#                        thickness=_checks.THICKNESS, polarization=_checks.POLARIZATION)
#     def f(wavelength, cos_theta, thickness, *, polarization="unpolarized"): ...
#
# and its body receives the converted, checked values under the same names (tensors of the
# arguments' shared real dtype on their shared device). Kernels below it trust their inputs.


class Arg:
    """What one argument is: how it is converted and how its values are checked.

    ``convert(value, name, dtype, device)`` returns the value the body receives. ``check(converted,
    name)`` raises ValueError; a ``values`` check reads tensor values and runs only while
    :func:`value_checks_enabled` (asked once per call), any other (a choice, a count) always runs.
    ``tensor``: the argument takes part in the dtype/device resolution. ``optional``: None passes
    through unconverted (``X | None``)."""

    __slots__ = ("convert", "check", "values", "tensor", "optional")

    def __init__(self, convert=None, check=None, *, values: bool = False, tensor: bool = False,
                 optional: bool = False):
        # (a values check is called unwrapped: the decorator asks value_checks_enabled once)
        self.convert, self.check = convert, getattr(check, "__wrapped__", check) if values else check
        self.values, self.tensor, self.optional = values, tensor, optional

    def __or__(self, other):  # ``X | None``: the same argument, None allowed (and left as None)
        if other is not None:
            return NotImplemented
        new = Arg(self.convert, None, tensor=self.tensor, optional=True)
        new.check, new.values = self.check, self.values
        return new


def real(check=None) -> Arg:
    """A real tensor (numbers, sequences, arrays, tensors), optionally value-checked by
    ``check(t, name)``."""
    return Arg(as_real, check, values=True, tensor=True)


def positive(unit: str = "nm") -> Arg:
    """A real tensor > 0 (``unit`` named in the message)."""
    check = check_positive.__wrapped__
    return real(lambda t, name: check(t, name, unit))


def nonnegative(unit: str = "nm") -> Arg:
    """A real tensor ≥ 0 (``unit`` named in the message)."""
    check = check_nonnegative.__wrapped__
    return real(lambda t, name: check(t, name, unit))


def choice(options) -> Arg:
    """One of ``options`` (strings; a sequence or a mapping's keys), unchanged."""
    return Arg(None, lambda v, name: check_choice(v, name, options))


def integer(minimum: int = 1) -> Arg:
    """A Python int ≥ ``minimum`` (NumPy integers accepted; not a bool)."""
    return Arg(lambda v, name, dtype, device: check_int(v, name, minimum))


def instance(cls, what: str | None = None) -> Arg:
    """An instance of ``cls`` (a class or a tuple of them), unchanged; ``what`` names it in the
    message (default the class name)."""
    what = what or (cls.__name__ if isinstance(cls, type) else " or ".join(c.__name__ for c in cls))

    def check(v, name):
        if not isinstance(v, cls):
            raise ValueError(f"{name} must be a {what}; got {type(v).__name__}")

    return Arg(None, check)


def check_float_dtype(dtype, name: str = "dtype") -> None:
    if dtype not in (torch.float16, torch.bfloat16, torch.float32, torch.float64):
        raise ValueError(f"{name} must be a floating torch dtype (torch.float32, torch.float64, ...); got {dtype!r}")


def number(*, low: float = -math.inf, high: float = math.inf, closed: bool = False, unit: str = "") -> Arg:
    """A Python real number (not a bool, not a tensor) inside the bounds — ``low < x`` (``≤`` when
    ``closed``) and ``x ≤ high`` — returned as a float: the scalar settings of a fit or a table."""
    sign = ">=" if closed else ">"
    bounds = f" {sign} {low:g}" if low > -math.inf else ""
    bounds += f" and <= {high:g}" if high < math.inf else ""
    units = f" ({unit})" if unit else ""

    def convert(v, name, dtype, device):
        ok = not isinstance(v, bool) and isinstance(v, numbers.Real) and (v >= low if closed else v > low) and v <= high
        if not ok:
            raise ValueError(f"{name} must be a number{bounds}{units}; got {v!r}")
        return float(v)

    return Arg(convert)


def pair(*, low: float = 0.0, high: float = math.inf, closed: bool = False, unit: str = "") -> Arg:
    """A ``(low, high)`` pair of floats within the bounds (:func:`check_range`)."""
    return Arg(lambda v, name, dtype, device: check_range(v, name, low=low, high=high, closed=closed, unit=unit))


#: vacuum wavelength in nm, in [1 nm, 1 mm]
WAVELENGTH = real(check_wavelength)
#: cosine of an incidence angle, in [0, 1]
COSINE = real(check_cosine)
#: a cosine whose sign matters, in [-1, 1]
SIGNED_COSINE = real(check_signed_cosine)
#: a length in nm, ≥ 0 (film and layer thicknesses)
THICKNESS = nonnegative("nm")
#: a real tensor, no value check
REAL = real()
#: refractive index n + iκ: Re n > 0, κ ≥ 0
INDEX = Arg(as_index, check_index, values=True, tensor=True)
#: index of the incident medium: real (lossless), > 0
INCIDENT_INDEX = Arg(as_index, check_real_index, values=True, tensor=True)
#: number of Bragg cells: int64 tensor of integers ≥ 1 (sets the device, not the dtype)
CELLS = Arg(lambda v, name, dtype, device: as_cells(v, device))
#: "s", "p" or "unpolarized"
POLARIZATION = choice(POLARIZATIONS)
def check_vectors(t: torch.Tensor, name: str) -> None:
    """ValueError unless ``t`` has 3 components (x, y, z) on its last axis."""
    if t.ndim == 0 or t.shape[-1] != 3:
        raise ValueError(f"{name} must have shape (*, 3) (last axis = x, y, z); got {tuple(t.shape)}")


def check_flag(value, name: str) -> None:
    if not isinstance(value, bool):
        raise ValueError(f"{name} must be a bool (True or False); got {value!r}")


def check_progress(value, name: str = "progress") -> None:
    if value is not None and not callable(value):
        raise ValueError(f"{name} must be None or a callable {name}(done, total); got {value!r}")


#: True or False (not 0/1, not a string)
FLAG = Arg(None, check_flag)
#: None or a callable ``progress(done, total)`` (docs/conventions.md, "Progress")
PROGRESS = Arg(None, check_progress)
#: direction-like vectors ``(*, 3)`` (x, y, z on the last axis)
VECTORS = Arg(as_real, check_vectors, tensor=True)
#: a floating torch dtype (of a table built from nothing)
FLOAT_DTYPE = Arg(None, check_float_dtype)
#: a ``(low, high)`` wavelength range in nm
WAVELENGTH_RANGE = pair(low=MIN_WAVELENGTH_NM, high=MAX_WAVELENGTH_NM, closed=True, unit="nm")

_MISSING = object()


def arguments(*, broadcast: Sequence[str] | bool = (), **specs: Arg):
    """Decorator: convert and check the named arguments of a public function once, before its body.

    ``specs`` maps parameter names to :class:`Arg` (``WAVELENGTH``, ``INDEX``, ``choice(...)``,
    ``X | None`` ...); unnamed parameters pass through. The tensor arguments' dtype and device are
    resolved together (:func:`resolve_dtype_device`), then each named argument is converted and
    checked in the order of ``specs``. ``broadcast``: names of arguments whose shapes must
    broadcast together (``True``: every tensor argument); a mismatch is a ValueError naming them (not torch's bare RuntimeError).
    A call that does not bind (missing or unknown arguments) raises Python's own TypeError.
    The wrapped function keeps its signature and docstring; its ``__wrapped__`` is the body on
    checked values — what an internal caller that has checked the same arguments calls (another
    public function's body, a kernel's block loop), so that nothing is checked twice."""
    import inspect

    def decorate(fn):
        sig = inspect.signature(fn)
        params = list(sig.parameters.values())
        if any(p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD) for p in params):
            raise TypeError(f"{fn.__qualname__}: arguments() needs named parameters only")
        names_ = [p.name for p in params]
        together = [n for n, a in specs.items() if a.tensor] if broadcast is True else list(broadcast)
        unknown = (set(specs) | set(together)) - set(names_)
        if unknown:
            raise TypeError(f"{fn.__qualname__}: no parameter {sorted(unknown)}")
        defaults = [p.default if p.default is not p.empty else _MISSING for p in params]
        n_pos = sum(p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD) for p in params)
        kw_names = names_[n_pos:]
        position = {n: i for i, n in enumerate(names_)}
        steps = tuple((position[n], n, a) for n, a in specs.items())
        tensors = tuple(position[n] for n, a in specs.items() if a.tensor)
        shaped = tuple((position[n], n) for n in together)
        shaped_names = tuple(together)
        n_all = len(params)

        @functools.wraps(fn)
        def checked(*args, **kwargs):
            n = len(args)
            if n > n_pos:
                return fn(*args, **kwargs)  # (Python's own TypeError)
            values = list(args)
            used = 0
            for i in range(n, n_all):
                v = kwargs.get(names_[i], _MISSING)
                if v is _MISSING:
                    v = defaults[i]
                    if v is _MISSING:
                        return fn(*args, **kwargs)  # a required argument is missing: Python's TypeError
                else:
                    used += 1
                values.append(v)
            if used != len(kwargs):
                return fn(*args, **kwargs)  # an unknown or repeated keyword: Python's TypeError
            dtype, device = resolve_dtype_device(*[values[i] for i in tensors])
            read = value_checks_enabled()
            for i, name, a in steps:
                v = values[i]
                if v is None and a.optional:
                    continue
                if a.convert is not None:
                    v = a.convert(v, name, dtype, device)
                    values[i] = v
                if a.check is not None and (read or not a.values):
                    a.check(v, name)
            if shaped:
                broadcast_shapes(*[_shape(values[i]) for i, _ in shaped], names=shaped_names)
            return fn(*values[:n_pos], **dict(zip(kw_names, values[n_pos:])))

        checked.__signature__ = sig
        return checked

    return decorate



def _shape(v) -> tuple:
    if isinstance(v, torch.Tensor):
        return v.shape
    if v is None or isinstance(v, numbers.Number):
        return ()
    return tuple(torch.as_tensor(v).shape)
