r"""A design problem written as TOML (what ``torchirid design SPEC.toml`` reads).

Units: nm for wavelengths and thicknesses, degrees for angles (the file speaks like the command
line; the library takes cos θ). Every key is checked; an unknown key, a bound with min > max, a
thickness in metres, an unknown material raise ``SpecError``
naming the key (``layers[2].thickness``)::

    name = "dielectric mirror"
    incident = 1.0                 # a number, a name ("air", "water"), or a table
    exit = "glass"
    min_thickness = 5.0            # nm; thinner layers are removed from the result
    max_total_thickness = 3000.0   # nm (optional)
    max_layers = 30                # the needle stage stops here (optional)

    [optimiser]                    # all optional
    method = "auto"                # auto | global | gradient | needle
    seed = 0
    time_limit = 60.0              # s
    max_evaluations = 200000
    goal = 0.01                    # stop when the merit is at most this

    [[layers]]                     # incident side first
    name = "top"                   # optional: for an absorptance target's layer = "top"
    material = "TiO2"              # a number, a name, ["TiO2", "ZnS"] (a choice),
                                   # {wavelength = [...], n = [...], k = [...]}, {file = "nk.csv"}
                                   # (nm, n[, k] rows) or {page = ["main", "TiO2", "Devore-o"]}
    thickness = [10.0, 200.0]      # [min, max] (free) or a number (fixed), nm

    [[layers]]
    pattern = ["TiO2", "SiO2"]     # alternating materials ...
    repeat = 5                     # ... 5 times: 10 layers
    thickness = [10.0, 200.0]

    [[targets]]
    type = "spectral"              # spectral (default) | colour
    quantity = "R"                 # R | T | A (A: with layer = "name" or index, that layer's)
    wavelength = {start = 400.0, stop = 700.0, count = 61}   # or a list, or {start, stop, step}
    value = 1.0                    # or one per wavelength
    angle_deg = [0.0]
    polarization = "unpolarized"
    weight = 1.0                   # or a list, or "AM1.5G photon flux"
    p = 2
    importance = 1.0

    [[targets]]
    type = "colour"
    lab = [[60.0, 10.0, 60.0], [55.0, -40.0, 20.0]]   # one L*, a*, b* per angle
    angle_deg = [0.0, 60.0]
    illuminant = "D65"
    observer = "CIE 1931 2"

    [robust]                       # optional: design against thickness errors
    sigma = 1.0                    # nm (or a fraction with relative = true)
    objective = "cvar"             # mean | cvar
    alpha = 0.1
    samples = 64

    [tolerance]                    # optional: the analysis reported after the design
    sigma = 1.0
    samples = 2000
    merit_limit = 0.02
    delta_e_limit = 1.0
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

from .problem import ColourTarget, Layer, Problem, Robust, SpecError, SpectralTarget

__all__ = ["read_spec"]

_TOP = {"name", "incident", "exit", "min_thickness", "max_total_thickness", "max_layers", "optimiser", "layers",
        "targets", "robust", "tolerance"}
_OPTIMISER = {"method": str, "seed": int, "time_limit": float, "max_evaluations": int, "goal": float,
              "population": int}
_LAYER = {"material", "pattern", "repeat", "thickness", "name"}
_SPECTRAL = {"type", "quantity", "wavelength", "value", "angle_deg", "polarization", "weight", "p", "importance",
             "layer"}
_COLOUR = {"type", "lab", "angle_deg", "illuminant", "observer", "polarization", "p", "importance",
           "wavelength_step"}
_ROBUST = {"sigma", "relative", "samples", "objective", "alpha", "seed"}
_TOLERANCE = {"sigma", "relative", "samples", "seed", "merit_limit", "delta_e_limit"}


def _load_toml(path: Path) -> dict:
    if sys.version_info >= (3, 11):
        import tomllib
    else:  # pragma: no cover - Python 3.10
        import tomli as tomllib
    try:
        with open(path, "rb") as f:
            return tomllib.load(f)
    except FileNotFoundError:
        raise SpecError(str(path), "no such file") from None
    except tomllib.TOMLDecodeError as err:
        raise SpecError(str(path), f"not valid TOML ({err})") from None


def _known(table: dict, allowed: set, key: str) -> None:
    if not isinstance(table, dict):
        raise SpecError(key, f"a table; got {type(table).__name__}")
    for k in table:
        if k not in allowed:
            raise SpecError(f"{key}.{k}" if key else k, f"unknown key (known: {', '.join(sorted(allowed))})")


def _material(value, key: str):
    if isinstance(value, dict) and "page" in value:  # a database page: {page = [shelf, book, page]}
        _known(value, {"page"}, key)
        page = value["page"]
        if not (isinstance(page, list) and len(page) == 3 and all(isinstance(x, str) for x in page)):
            raise SpecError(f"{key}.page", "[shelf, book, page] of the refractiveindex.info database")
        return tuple(page)
    if isinstance(value, dict) and "file" in value:
        _known(value, {"file"}, key)
        try:
            data = np.loadtxt(value["file"], delimiter=",", comments="#", ndmin=2)
        except OSError as err:
            raise SpecError(f"{key}.file", str(err)) from None
        except ValueError as err:
            raise SpecError(f"{key}.file", f"a CSV of wavelength (nm), n[, k] rows: {err}") from None
        if data.shape[1] not in (2, 3):
            raise SpecError(f"{key}.file", "a CSV of wavelength (nm), n[, k] rows")
        return {"wavelength": data[:, 0], "n": data[:, 1], "k": data[:, 2] if data.shape[1] == 3 else 0 * data[:, 1]}
    return value


def _wavelength(value, key: str):
    if isinstance(value, dict):
        _known(value, {"start", "stop", "count", "step"}, key)
        try:
            start, stop = float(value["start"]), float(value["stop"])
        except KeyError as err:
            raise SpecError(f"{key}.{err.args[0]}", "missing (a range is {start, stop, count} or {start, stop, step})") \
                from None
        if stop < start:
            raise SpecError(key, f"start {start:g} > stop {stop:g}")
        if "count" in value and "step" in value:
            raise SpecError(key, "give count or step, not both")
        if "step" in value:
            step = float(value["step"])
            if not step > 0:
                raise SpecError(f"{key}.step", "a step > 0 nm")
            return np.arange(start, stop + step / 2, step)
        count = value.get("count", 1 if start == stop else None)
        if not isinstance(count, int) or count < 1:
            raise SpecError(f"{key}.count", "a whole number ≥ 1")
        return np.linspace(start, stop, count)
    return value


def _angles(value, key: str):
    a = np.atleast_1d(np.asarray(value, dtype=float))
    if a.ndim != 1 or not np.all((a >= 0) & (a < 90)):
        raise SpecError(key, "incidence angles in degrees, 0 ≤ θ < 90")
    if a.size and np.all(a <= 1.6) and np.any(a > 0):
        raise SpecError(key, f"{a.tolist()} look like radians; angles are in degrees")
    return np.cos(np.radians(a))


def _number(table, name, key, kind=float, default=None):
    if name not in table:
        return default
    v = table[name]
    if kind is int:
        if not isinstance(v, int) or isinstance(v, bool):
            raise SpecError(f"{key}{name}", f"a whole number; got {v!r}")
        return v
    if kind is float:
        if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v):
            raise SpecError(f"{key}{name}", f"a number; got {v!r}")
        return float(v)
    if not isinstance(v, kind):
        raise SpecError(f"{key}{name}", f"a {kind.__name__}; got {v!r}")
    return v


def _layers(entries) -> list[Layer]:
    if not isinstance(entries, list) or not entries:
        raise SpecError("layers", "a non-empty array of [[layers]] tables")
    out = []
    for i, e in enumerate(entries):
        key = f"layers[{i}]"
        _known(e, _LAYER, key)
        if "thickness" not in e:
            raise SpecError(f"{key}.thickness", "missing (nm, or [min, max])")
        t = e["thickness"]
        if isinstance(t, list):
            t = tuple(t)
        if "pattern" in e:
            if "material" in e:
                raise SpecError(key, "give material or pattern, not both")
            pattern = e["pattern"]
            if not isinstance(pattern, list) or not pattern:
                raise SpecError(f"{key}.pattern", "a non-empty list of materials")
            repeat = e.get("repeat", 1)
            if not isinstance(repeat, int) or isinstance(repeat, bool) or repeat < 1:
                raise SpecError(f"{key}.repeat", f"a whole number ≥ 1; got {repeat!r}")
            for r in range(repeat):
                for j, m in enumerate(pattern):
                    out.append(Layer(_material(m, f"{key}.pattern[{j}]"), t).check(key))
            continue
        if "material" not in e:
            raise SpecError(f"{key}.material", "missing (or give a pattern)")
        repeat = e.get("repeat", 1)
        if not isinstance(repeat, int) or isinstance(repeat, bool) or repeat < 1:
            raise SpecError(f"{key}.repeat", f"a whole number ≥ 1; got {repeat!r}")
        m = e["material"]
        m = [_material(v, f"{key}.material[{j}]") for j, v in enumerate(m)] if isinstance(m, list) else \
            _material(m, f"{key}.material")
        name = e.get("name", "")
        if name and repeat > 1:
            raise SpecError(f"{key}.name", "a named layer is one layer (repeat = 1)")
        out.extend([Layer(m, t, name).check(key)] * repeat)
    return out


def _targets(entries) -> list:
    if not isinstance(entries, list) or not entries:
        raise SpecError("targets", "a non-empty array of [[targets]] tables")
    out = []
    for i, e in enumerate(entries):
        key = f"targets[{i}]"
        if not isinstance(e, dict):
            raise SpecError(key, "a table")
        kind = e.get("type", "spectral")
        if kind not in ("spectral", "colour", "color"):
            raise SpecError(f"{key}.type", f"'spectral' or 'colour'; got {kind!r}")
        if kind == "spectral":
            _known(e, _SPECTRAL, key)
            for need in ("quantity", "wavelength"):
                if need not in e:
                    raise SpecError(f"{key}.{need}", "missing")
            t = SpectralTarget(e["quantity"], _wavelength(e["wavelength"], f"{key}.wavelength"), e.get("value", 1.0),
                               _angles(e.get("angle_deg", 0.0), f"{key}.angle_deg"),
                               e.get("polarization", "unpolarized"), e.get("weight", 1.0), e.get("p", 2.0),
                               e.get("importance", 1.0), e.get("layer"))
        else:
            _known(e, _COLOUR, key)
            if "lab" not in e:
                raise SpecError(f"{key}.lab", "missing (L*, a*, b* per angle)")
            t = ColourTarget(e["lab"], _angles(e.get("angle_deg", 0.0), f"{key}.angle_deg"),
                             e.get("illuminant", "D65"), e.get("observer", "CIE 1931 2"),
                             e.get("polarization", "unpolarized"), e.get("p", 2.0), e.get("importance", 1.0),
                             e.get("wavelength_step", 5.0))
        out.append(t.check(key))
    return out


def read_spec(source) -> tuple[Problem, dict, dict | None]:
    """Read a design problem from a TOML file (or an already parsed ``dict``).

    Returns:
        ``(problem, optimiser, tolerance)``: the checked :class:`~torchirid.design.Problem`,
        the ``[optimiser]`` options as keyword arguments of :func:`~torchirid.design.optimise`,
        and the ``[tolerance]`` options of :func:`~torchirid.design.tolerance` (None without
        that table).

    Raises:
        ValueError: (``SpecError``) whose message starts with the key at fault
            (``layers[2].thickness: ...``).

    Example:
        >>> from torchirid.design import read_spec
        >>> p, opts, tol = read_spec({"exit": 1.8, "layers": [{"pattern": [1.8, 1.4], "repeat": 2,
        ...     "thickness": [0, 214]}], "targets": [{"quantity": "R", "wavelength": [600.0], "p": 1}]})
        >>> len(p.layers), opts, tol
        (4, {}, None)
    """
    spec = source if isinstance(source, dict) else _load_toml(Path(source))
    _known(spec, _TOP, "")
    for need in ("layers", "targets"):
        if need not in spec:
            raise SpecError(need, "missing")
    layers = _layers(spec["layers"])
    targets = _targets(spec["targets"])
    opt = spec.get("optimiser", {})
    _known(opt, set(_OPTIMISER), "optimiser")
    options = {name: _number(opt, name, "optimiser.", kind) for name, kind in _OPTIMISER.items() if name in opt}
    robust = None
    if "robust" in spec:
        r = spec["robust"]
        _known(r, _ROBUST, "robust")
        robust = Robust(**r)
    tolerance = None
    if "tolerance" in spec:
        tolerance = dict(spec["tolerance"])
        _known(tolerance, _TOLERANCE, "tolerance")
        for name in ("samples", "seed"):
            _number(tolerance, name, "tolerance.", int)
        for name in ("merit_limit", "delta_e_limit"):
            _number(tolerance, name, "tolerance.", float)
    incident = _material(spec.get("incident", 1.0), "incident")
    exit_ = _material(spec.get("exit", 1.52), "exit")
    kwargs = {}
    for name in ("min_thickness", "max_total_thickness"):
        if name in spec:
            kwargs[name] = _number(spec, name, "", float)
    if "max_layers" in spec:
        kwargs["max_layers"] = _number(spec, "max_layers", "", int)
    try:
        problem = Problem(layers, targets, n_incident=incident, n_substrate=exit_, robust=robust,
                          name=str(spec.get("name", "")), **kwargs)
    except SpecError as err:  # the file's names of the two media
        key = {"n_incident": "incident", "n_substrate": "exit"}.get(err.key, err.key)
        raise SpecError(key, str(err).split(": ", 1)[1]) from None
    return problem, options, tolerance
