"""Reading the plugins' Mitsuba properties (one ``ValueError`` naming the parameter each), the
``design.json`` of ``torchirid design``, and two small helpers the plugins share."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ._spectra import Index


def _index_arg(props, name: str, default=None, *, required: bool = False) -> Index:
    """An index parameter ``name`` (number or material name) with its optional ``k_<name>``
    (``n_film`` → ``k_film``)."""
    value = props.get(name, default)
    if value is None:
        if required:
            raise ValueError(f"{name} is required")
        return None
    kname = "k_" + name[2:] if name.startswith("n_") else "k_" + name
    k = props.get(kname, 0.0)
    return Index(value, k, name=name)


#: parameters that are lengths in nm (a value below 1e-3 nm was given in metres)
LENGTHS = ("thickness", "d1", "d2")


def _float_arg(props, name: str, default=None, *, low=None, positive=False):
    value = props.get(name, default)
    if value is None:
        raise ValueError(f"{name} is required")
    value = float(value)
    if not math.isfinite(value) or (positive and not value > 0) or (low is not None and value < low):
        bound = "> 0" if positive else f">= {low}"
        raise ValueError(f"{name} must be finite and {bound}, got {value}")
    if name in LENGTHS and 0 < value < 1e-3:
        raise ValueError(f"{name} = {value:g} nm looks like metres: give nanometres (e.g. {value * 1e9:g})")
    return value


def _choice(props, name, options, default):
    value = props.get(name, default)
    if value not in options:
        raise ValueError(f"{name} must be one of {', '.join(map(repr, options))}, got {value!r}")
    return value


def read_design(path) -> tuple[list, list, object, object]:
    """``(materials, thicknesses, incident, exit)`` of a ``design.json`` written by
    ``torchirid design`` (:meth:`torchirid.design.Design.to_dict`: layers top first, thicknesses
    in ``thickness_nm``)."""
    data = json.loads(Path(path).read_text())
    try:
        layers = data["layers"]
        materials = [layer["material"] for layer in layers]
        thicknesses = [float(layer["thickness_nm"]) for layer in layers]
        return materials, thicknesses, data["incident"], data["exit"]
    except (KeyError, TypeError) as exc:
        raise ValueError(f"{path}: not a design written by `torchirid design` (no {exc})") from None


def _real_constant(index: Index, name: str) -> float:
    """The value of an index that must be real and constant (the incident medium)."""
    if index.material is None and index.constant.imag == 0:
        return index.constant.real
    if index.material is not None and index.lossless and np.ptp(index.n_table) == 0:
        return float(index.n_table[0])
    raise ValueError(f"{name} must be a real constant index, got {index.describe()}")


_WARNED = []


def _warn_symbolic():
    if not _WARNED:
        import warnings

        _WARNED.append(True)
        warnings.warn("a torchirid BSDF with evaluator='torch' was traced symbolically and gives zeros there: "
                      "render with dr.set_flag(dr.JitFlag.SymbolicLoops, False) and "
                      "dr.set_flag(dr.JitFlag.SymbolicCalls, False)", RuntimeWarning, stacklevel=3)


def _gather(table, index):
    """``table[index]``: a Dr.Jit gather (JIT variants) or a list lookup (scalar variants)."""
    if isinstance(table, list):
        return table[int(index)]
    import drjit as dr

    return dr.gather(type(table), table, dr.uint32_array_t(type(table))(index))


def _number_or_name(x):
    """A material as a spec or ``design.json`` writes it: a number, ``[n, κ]``, a name, or a
    ``[shelf, book, page]`` of the database."""
    if isinstance(x, str):
        if x == "table":
            raise ValueError("a design with a tabulated material (n, k table): give materials and thicknesses")
        try:
            return float(x)
        except ValueError:
            return x
    if isinstance(x, (list, tuple)) and len(x) == 2:
        return complex(float(x[0]), float(x[1]))
    if isinstance(x, (list, tuple)) and len(x) == 3:
        return tuple(x)
    return x


def _list_arg(props, name):
    """A list parameter: a comma-separated string (Mitsuba properties hold no lists)."""
    value = props.get(name, None)
    if value is None:
        raise ValueError(f"{name} is required (or give design = 'design.json')")
    if isinstance(value, str):
        return [v.strip() for v in value.split(",") if v.strip()]
    return list(value)
