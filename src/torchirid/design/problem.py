r"""What a design problem is: a stack with free parameters and the targets it must meet.

A :class:`Problem` holds

* the stack, from the incident side down: the incident medium ``n_incident``, :class:`Layer`
  ``layers``, the exit medium ``n_substrate`` (what the layers sit on). A material is a number (a constant index ``n`` or ``n + iκ``), a named
  material of :mod:`torchirid.materials` (``"TiO2"``, ``"SiO2"``, ``"glass"``, ``"Ag"`` …, or a
  ``(shelf, book, page)`` of the refractiveindex.info database), a user table (a mapping with
  ``wavelength`` in nm, ``n`` and optionally ``k``, interpolated linearly, no extrapolation), or
  a list of those: the candidates among which the optimiser chooses one. A thickness is a
  number of nm (fixed) or a ``(min, max)`` pair in nm (free within the bounds);
* the targets: :class:`SpectralTarget` (R, T or A = 1 − R − T against wavelength, at
  given angles and polarization) and :class:`ColourTarget` (CIELAB of the reflected colour
  at given angles, scored by CIEDE2000);
* manufacturability: ``min_thickness`` (layers thinner than this are removed from the result),
  ``max_total_thickness`` (a penalty beyond it) and ``max_layers`` (the needle stage stops there).

The merit of a stack is :math:`M = \sum_t s_t M_t` over the targets (``s_t`` their
``importance``), plus the thickness penalty. A spectral target's merit is the weighted
p-mean of its deviations,

.. math:: M_t = \Bigl(\frac{\sum_{λ, θ} w(λ)\, |v(λ) − X(λ, θ)|^p}{\sum_{λ, θ} w(λ)}\Bigr)^{1/p},

so that ``p = 1`` with ``value = 1`` on R is the photonics benchmarks' ``1 − mean R``; a
colour target's is the p-mean over its angles of ΔE2000 between the target and the stack's
colour. Every check runs here, when the problem is built; the optimisers trust it.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

__all__ = ["ColourTarget", "Layer", "Problem", "Robust", "SpectralTarget"]

#: the quantities a spectral target can ask for
QUANTITIES = ("R", "T", "A")
#: named spectral weightings of a spectral target (resolved in torchirid.design.merit)
WEIGHTINGS = ("AM1.5G photon flux", "AM1.5G irradiance")


class SpecError(ValueError):
    """A problem that cannot be built; ``key`` names the offending entry (``layers[2].thickness``)."""

    def __init__(self, key: str, message: str):
        super().__init__(f"{key}: {message}")
        self.key = key


def _layer_index(layer, layers, key: str) -> int:
    if isinstance(layer, str):
        named = [i for i, x in enumerate(layers) if x.name == layer]
        if len(named) != 1:
            names = sorted({x.name for x in layers if x.name})
            raise SpecError(key, f"{'no' if not named else 'more than one'} layer named {layer!r} "
                            f"(named: {', '.join(names) or 'none'})")
        return named[0]
    if not 0 <= layer < len(layers):
        raise SpecError(key, f"a layer index in 0–{len(layers) - 1}; got {layer}")
    return layer


class Candidates(tuple):
    """The checked candidate materials of one layer (a tuple that is not itself a material)."""


def _is_number(x) -> bool:
    return isinstance(x, numbers.Number) and not isinstance(x, bool)


def check_material(material, key: str):
    """The material in a canonical, hashable form, or a ``SpecError`` naming ``key``.

    Numbers stay numbers (κ ≥ 0, n > 0), names and database tuples are looked up now (so that
    an unknown name fails before any work), tables become ``("table", λ, n, k)`` tuples.
    """
    if _is_number(material):
        z = complex(material)
        if not (math.isfinite(z.real) and math.isfinite(z.imag)) or z.real <= 0 or z.imag < 0:
            raise SpecError(key, f"an index must be finite with n > 0 and κ ≥ 0; got {material!r}")
        return material if z.imag else float(z.real)
    if isinstance(material, str) or (isinstance(material, tuple) and len(material) == 3
                                     and all(isinstance(s, str) for s in material)):
        from .. import materials

        try:
            materials.material_range(material)
        except ValueError as err:
            raise SpecError(key, str(err)) from None
        return material
    if isinstance(material, tuple) and len(material) == 4 and material[0] == "table":
        return material  # a table checked before
    if isinstance(material, dict):
        unknown = set(material) - {"wavelength", "n", "k"}
        if unknown:
            raise SpecError(f"{key}.{min(unknown)}", "unknown key of a material table "
                            "(a table has wavelength (nm), n and optionally k)")
        try:
            lam = np.asarray(material["wavelength"], dtype=float)
            n = np.asarray(material["n"], dtype=float)
            k = np.asarray(material.get("k", np.zeros_like(n)), dtype=float)
        except KeyError as err:
            raise SpecError(f"{key}.{err.args[0]}", "missing from the material table") from None
        if lam.ndim != 1 or lam.size < 2 or n.shape != lam.shape or k.shape != lam.shape:
            raise SpecError(key, "a material table needs wavelength, n (and k) as equal-length lists, ≥ 2 rows")
        if not np.all(np.diff(lam) > 0) or lam[0] <= 0:
            raise SpecError(f"{key}.wavelength", "must be positive and strictly increasing (nm)")
        if lam[-1] < 10:
            raise SpecError(f"{key}.wavelength", f"looks like µm or m ({lam[-1]:g}); give nm")
        if np.any(n <= 0) or np.any(k < 0):
            raise SpecError(key, "a table needs n > 0 and k ≥ 0")
        return ("table", tuple(lam), tuple(n), tuple(k))
    raise SpecError(key, f"a material is a number, a name, a (shelf, book, page) tuple, a table "
                    f"{{wavelength, n, k}} or a list of those; got {material!r}")


def material_range(material) -> tuple[float, float]:
    """Wavelength range (nm) of a canonical material."""
    if _is_number(material):
        return 0.0, math.inf
    if isinstance(material, tuple) and material[0] == "table":
        return material[1][0], material[1][-1]
    from .. import materials

    return materials.material_range(material)


def material_label(material) -> Any:
    """What ``design.json`` writes for a material: the number or the name."""
    if isinstance(material, tuple) and material and material[0] == "table":
        return "table"
    if isinstance(material, complex):
        return [material.real, material.imag]
    if isinstance(material, tuple):
        return list(material)
    return material


@dataclass(frozen=True)
class Layer:
    """One layer of the stack, incident side first.

    Args:
        material: a number (index), a name, a ``(shelf, book, page)`` tuple, a table
            ``{"wavelength": [nm], "n": [...], "k": [...]}``, or a list of those (the
            optimiser picks one).
        thickness: nm; a number (fixed) or ``(min, max)`` (free in ``[min, max]``).
        name: a name for a :class:`SpectralTarget` of its absorptance (``layer=``).
    """

    material: Any
    thickness: float | tuple[float, float]
    name: str = ""

    def check(self, key: str) -> Layer:
        if isinstance(self.material, list) or (isinstance(self.material, tuple) and not _is_material_tuple(self.material)):
            if len(self.material) == 0:
                raise SpecError(f"{key}.material", "an empty list of candidates")
            mats = tuple(check_material(m, f"{key}.material[{i}]") for i, m in enumerate(self.material))
            mat = Candidates(mats) if len(mats) > 1 else mats[0]
        else:
            mat = check_material(self.material, f"{key}.material")
        t = self.thickness
        if _is_number(t):
            t = float(t)
            _check_nm(t, f"{key}.thickness")
        elif isinstance(t, (list, tuple)) and len(t) == 2 and all(_is_number(v) for v in t):
            lo, hi = float(t[0]), float(t[1])
            _check_nm(lo, f"{key}.thickness")
            _check_nm(hi, f"{key}.thickness")
            if lo > hi:
                raise SpecError(f"{key}.thickness", f"min {lo:g} > max {hi:g}")
            t = (lo, hi) if lo < hi else lo
        else:
            raise SpecError(f"{key}.thickness", f"a thickness in nm or a [min, max] pair; got {t!r}")
        if not isinstance(self.name, str):
            raise SpecError(f"{key}.name", f"a string; got {self.name!r}")
        return Layer(mat, t, self.name)

    @property
    def candidates(self) -> tuple:
        """The materials to choose from (one for a fixed material)."""
        m = self.material
        return tuple(m) if isinstance(m, Candidates) else (m,)

    @property
    def free(self) -> bool:
        return isinstance(self.thickness, tuple)


def _is_material_tuple(m: tuple) -> bool:
    """A (shelf, book, page) of the database, or a checked ("table", λ, n, k) — not candidates."""
    if isinstance(m, Candidates):
        return False
    return (len(m) == 3 and all(isinstance(s, str) for s in m)) or (len(m) == 4 and m[0] == "table")


def _check_nm(t: float, key: str) -> None:
    if not math.isfinite(t) or t < 0:
        raise SpecError(key, f"a thickness is ≥ 0 nm; got {t!r}")
    if 0 < t < 1e-2:
        raise SpecError(key, f"{t:g} nm looks like metres or µm; thicknesses are in nm")


def _cosines(cos_theta, key: str) -> tuple[float, ...]:
    c = np.atleast_1d(np.asarray(cos_theta, dtype=float))
    if c.ndim != 1 or c.size == 0 or not np.all((c > 0) & (c <= 1)):
        raise SpecError(key, "cosines of the incidence angle in (0, 1] (0° ≤ θ < 90°)")
    return tuple(c.tolist())


def _wavelengths(wavelength, key: str) -> tuple[float, ...]:
    w = np.atleast_1d(np.asarray(wavelength, dtype=float))
    if w.ndim != 1 or w.size == 0 or not np.all(np.isfinite(w)) or np.any(w <= 0):
        raise SpecError(key, "wavelengths in nm, > 0")
    if w.max() < 10:
        raise SpecError(key, f"{w.max():g} looks like µm or m; wavelengths are in nm")
    return tuple(w.tolist())


def _polarization(p, key: str) -> str:
    if p not in ("s", "p", "unpolarized"):
        raise SpecError(key, f"'s', 'p' or 'unpolarized'; got {p!r}")
    return p


def _power(p, key: str) -> float:
    if not _is_number(p) or not p >= 1 or not math.isfinite(p):
        raise SpecError(key, f"a power p ≥ 1; got {p!r}")
    return float(p)


def _importance(s, key: str) -> float:
    if not _is_number(s) or not s > 0 or not math.isfinite(s):
        raise SpecError(key, f"a positive number; got {s!r}")
    return float(s)


@dataclass(frozen=True)
class SpectralTarget:
    """R, T or A against wavelength. A is the power absorbed in the films, 1 − R − T, or with
    ``layer`` the power absorbed in that one layer (with lossless films and an absorbing exit
    medium, T is what that medium absorbs).

    Args:
        quantity: ``"R"``, ``"T"`` or ``"A"``.
        wavelength: nm, ``(W,)``.
        value: the wanted value, a number or one per wavelength.
        cos_theta: cosines of the incidence angles (in the incident medium), ``(A,)``.
        polarization: ``"s"``, ``"p"`` or ``"unpolarized"``.
        weight: w(λ): a number, one per wavelength, or a named weighting of ``WEIGHTINGS``
            (``"AM1.5G photon flux"``: ASTM G173 global tilt, from pvlib, × λ/(hc)).
        p: the power of the merit's p-mean (1: mean absolute deviation; 2: RMS).
        importance: this target's factor in the total merit.
        layer: for ``"A"``: the index (0 = the first layer below the incident medium) or the
            ``name`` of the absorbing layer; None: all the films.
    """

    quantity: str
    wavelength: Any
    value: Any = 1.0
    cos_theta: Any = 1.0
    polarization: str = "unpolarized"
    weight: Any = 1.0
    p: float = 2.0
    importance: float = 1.0
    layer: int | str | None = None

    def check(self, key: str) -> SpectralTarget:
        if self.quantity not in QUANTITIES:
            raise SpecError(f"{key}.quantity", f"one of {', '.join(QUANTITIES)}; got {self.quantity!r}")
        lam = _wavelengths(self.wavelength, f"{key}.wavelength")
        value = _per_wavelength(self.value, len(lam), f"{key}.value", low=0.0, high=1.0)
        if isinstance(self.weight, str):
            if self.weight not in WEIGHTINGS:
                raise SpecError(f"{key}.weight", f"a number, a list or one of {', '.join(WEIGHTINGS)}; "
                                f"got {self.weight!r}")
            weight = self.weight
        else:
            weight = _per_wavelength(self.weight, len(lam), f"{key}.weight", low=0.0, high=math.inf)
            if not any(w > 0 for w in (weight if isinstance(weight, tuple) else (weight,))):
                raise SpecError(f"{key}.weight", "at least one weight must be > 0")
        layer = self.layer
        if layer is not None:
            if self.quantity != "A":
                raise SpecError(f"{key}.layer", "only an absorptance target (quantity 'A') names a layer")
            if not isinstance(layer, (int, str)) or isinstance(layer, bool):
                raise SpecError(f"{key}.layer", f"a layer index or name; got {layer!r}")
        return SpectralTarget(self.quantity, lam, value, _cosines(self.cos_theta, f"{key}.cos_theta"),
                              _polarization(self.polarization, f"{key}.polarization"), weight,
                              _power(self.p, f"{key}.p"), _importance(self.importance, f"{key}.importance"), layer)


def _per_wavelength(v, count: int, key: str, *, low: float, high: float):
    a = np.atleast_1d(np.asarray(v, dtype=float))
    if a.size == 1:
        a = np.full(count, float(a[0]))
    if a.shape != (count,):
        raise SpecError(key, f"a number or {count} values (one per wavelength); got {a.size}")
    if not np.all((a >= low) & (a <= high)):
        raise SpecError(key, f"values in [{low:g}, {high:g}]")
    return tuple(a.tolist())


@dataclass(frozen=True)
class ColourTarget:
    """CIELAB of the reflected colour at given angles, scored by CIEDE2000.

    Args:
        lab: ``(A, 3)`` L*, a*, b* per angle (or one ``(3,)`` for every angle), relative to the
            illuminant's white (Y = 100 for the perfect reflector).
        cos_theta: cosines of the incidence angles, ``(A,)``.
        illuminant, observer: as in :func:`torchirid.color.spectrum_to_xyz`.
        polarization: of the light (``"unpolarized"`` for daylight).
        p: the power of the p-mean over angles (a large p approaches the worst angle).
        importance: this target's factor in the total merit.
        wavelength_step: the integration grid over 360–780 nm, nm.
    """

    lab: Any
    cos_theta: Any = 1.0
    illuminant: str = "D65"
    observer: str = "CIE 1931 2"
    polarization: str = "unpolarized"
    p: float = 2.0
    importance: float = 1.0
    wavelength_step: float = 5.0

    def check(self, key: str) -> ColourTarget:
        from ..color import ILLUMINANTS, OBSERVERS

        c = _cosines(self.cos_theta, f"{key}.cos_theta")
        lab = np.asarray(self.lab, dtype=float)
        if lab.shape == (3,):
            lab = np.broadcast_to(lab, (len(c), 3))
        if lab.shape != (len(c), 3) or not np.all(np.isfinite(lab)):
            raise SpecError(f"{key}.lab", f"one L*, a*, b* triple, or one per angle ({len(c)}); got shape {lab.shape}")
        if np.any(lab[:, 0] < 0) or np.any(lab[:, 0] > 100):
            raise SpecError(f"{key}.lab", "L* is in [0, 100]")
        if self.illuminant not in ILLUMINANTS:
            raise SpecError(f"{key}.illuminant", f"one of {', '.join(ILLUMINANTS)}; got {self.illuminant!r}")
        if self.observer not in OBSERVERS:
            raise SpecError(f"{key}.observer", f"one of {', '.join(OBSERVERS)}; got {self.observer!r}")
        step = self.wavelength_step
        if not _is_number(step) or not 0.5 <= step <= 20:
            raise SpecError(f"{key}.wavelength_step", f"a step in nm in [0.5, 20]; got {step!r}")
        return ColourTarget(tuple(map(tuple, lab.tolist())), c, self.illuminant, self.observer,
                            _polarization(self.polarization, f"{key}.polarization"),
                            _power(self.p, f"{key}.p"), _importance(self.importance, f"{key}.importance"),
                            float(step))

    @property
    def wavelength(self) -> tuple[float, ...]:
        """The integration grid, nm."""
        count = round((780.0 - 360.0) / self.wavelength_step) + 1
        return tuple(np.linspace(360.0, 780.0, count).tolist())


@dataclass(frozen=True)
class Robust:
    r"""Thickness errors to design against (and to analyse a design under).

    Each layer's thickness becomes :math:`d + σ ε` (or :math:`d (1 + σ ε)` when ``relative``),
    ε standard normal, clipped at 0 nm; ``samples`` draws per candidate, fixed by ``seed``
    (common random numbers: every candidate meets the same errors).

    Args:
        sigma: σ in nm (or a fraction when ``relative``); one number, or one per layer.
        relative: σ relative to each thickness.
        samples: error draws per candidate.
        objective: ``"mean"`` (the expected merit) or ``"cvar"`` (the mean of the worst
            ``alpha`` fraction of draws: the conditional value at risk, as fabtwin optimises).
        alpha: the worst fraction for ``"cvar"``.
        seed: the draws' seed.
    """

    sigma: Any = 1.0
    relative: bool = False
    samples: int = 64
    objective: str = "mean"
    alpha: float = 0.1
    seed: int = 0

    def check(self, key: str, layers: int) -> Robust:
        s = np.atleast_1d(np.asarray(self.sigma, dtype=float))
        if s.size == 1:
            s = np.full(layers, float(s[0]))
        if s.shape != (layers,) or not np.all((s >= 0) & np.isfinite(s)):
            raise SpecError(f"{key}.sigma", f"σ ≥ 0, one number or one per layer ({layers})")
        if self.relative and np.any(s > 1):
            raise SpecError(f"{key}.sigma", "a relative σ is a fraction (0.01 = 1 %)")
        if not isinstance(self.samples, numbers.Integral) or self.samples < 1:
            raise SpecError(f"{key}.samples", f"a whole number ≥ 1; got {self.samples!r}")
        if self.objective not in ("mean", "cvar"):
            raise SpecError(f"{key}.objective", f"'mean' or 'cvar'; got {self.objective!r}")
        if not _is_number(self.alpha) or not 0 < self.alpha <= 1:
            raise SpecError(f"{key}.alpha", f"a fraction in (0, 1]; got {self.alpha!r}")
        return Robust(tuple(s.tolist()), bool(self.relative), int(self.samples), self.objective,
                      float(self.alpha), int(self.seed))


@dataclass(frozen=True)
class Problem:
    """A stack with free parameters and the targets it must meet (see the module docstring).

    Built checked: every entry is validated here (a ``SpecError``, a ``ValueError``,
    names the entry), materials are looked up, wavelength ranges compared with the materials'.

    Example (a quarter-wave mirror at 600 nm):
        >>> from torchirid import design
        >>> p = design.Problem(layers=[design.Layer(1.8, (0, 214)), design.Layer(1.4, (0, 214))],
        ...                    targets=[design.SpectralTarget("R", [600.0], value=1.0, p=1)],
        ...                    n_incident=1.0, n_substrate=1.8)
        >>> p.free_thicknesses
        2
    """

    layers: Sequence[Layer]
    targets: Sequence[SpectralTarget | ColourTarget]
    n_incident: Any = 1.0
    n_substrate: Any = 1.52
    min_thickness: float = 0.0
    max_total_thickness: float | None = None
    max_layers: int | None = None
    robust: Robust | None = None
    name: str = ""
    _checked: bool = field(default=False, repr=False, compare=False)

    def __post_init__(self):
        if self._checked:
            return
        layers = self.layers
        if isinstance(layers, (str, bytes)) or not isinstance(layers, Sequence) or len(layers) == 0:
            raise SpecError("layers", "a non-empty list of layers")
        checked = []
        for i, layer in enumerate(layers):
            if not isinstance(layer, Layer):
                raise SpecError(f"layers[{i}]", f"a design.Layer; got {type(layer).__name__}")
            checked.append(layer.check(f"layers[{i}]"))
        incident = check_material(self.n_incident, "n_incident")
        if _is_number(incident) and complex(incident).imag != 0:
            raise SpecError("n_incident", "the incident medium must be lossless (real index)")
        exit_ = check_material(self.n_substrate, "n_substrate")
        targets = self.targets
        if isinstance(targets, (SpectralTarget, ColourTarget)):
            targets = [targets]
        if not isinstance(targets, Sequence) or len(targets) == 0:
            raise SpecError("targets", "at least one SpectralTarget or ColourTarget")
        tchecked = []
        for i, t in enumerate(targets):
            if not isinstance(t, (SpectralTarget, ColourTarget)):
                raise SpecError(f"targets[{i}]", f"a SpectralTarget or ColourTarget; got {type(t).__name__}")
            tchecked.append(t.check(f"targets[{i}]"))
        for i, t in enumerate(tchecked):
            if isinstance(t, SpectralTarget) and t.layer is not None:
                tchecked[i] = replace(t, layer=_layer_index(t.layer, checked, f"targets[{i}].layer"))
        if not _is_number(self.min_thickness) or not self.min_thickness >= 0:
            raise SpecError("min_thickness", f"≥ 0 nm; got {self.min_thickness!r}")
        if self.max_total_thickness is not None and (not _is_number(self.max_total_thickness)
                                                     or not self.max_total_thickness > 0):
            raise SpecError("max_total_thickness", f"> 0 nm; got {self.max_total_thickness!r}")
        if self.max_layers is not None and (not isinstance(self.max_layers, numbers.Integral)
                                            or self.max_layers < len(checked)):
            raise SpecError("max_layers", f"a whole number ≥ the starting layer count ({len(checked)}); "
                            f"got {self.max_layers!r}")
        robust = None if self.robust is None else self.robust.check("robust", len(checked))
        # every wavelength a target asks for lies inside every material's range
        lam = [w for t in tchecked for w in t.wavelength]
        lo, hi = min(lam), max(lam)
        mats = [("n_incident", incident), ("n_substrate", exit_)] + [
            (f"layers[{i}].material", m) for i, layer in enumerate(checked) for m in layer.candidates]
        for key, m in mats:
            a, b = material_range(m)
            if lo < a or hi > b:
                raise SpecError(key, f"defined over {a:g}–{b:g} nm; the targets need {lo:g}–{hi:g} nm")
        for name, value in (("layers", tuple(checked)), ("targets", tuple(tchecked)), ("n_incident", incident),
                            ("n_substrate", exit_), ("robust", robust), ("min_thickness", float(self.min_thickness)),
                            ("_checked", True)):
            object.__setattr__(self, name, value)

    def with_layers(self, layers) -> Problem:
        """The same targets, media, limits and thickness errors on other ``layers`` (without
        ``max_layers``: a stack being grown may pass it on the way). One σ per layer cannot follow a
        change of the layer count (needles): that raises a ``ValueError``."""
        robust = self.robust
        if robust is not None and len(layers) != len(self.layers):
            if len(set(robust.sigma)) > 1:
                raise ValueError("robust.sigma: one σ per layer cannot follow a stack whose layer count changes "
                                 "(needles); give one σ for every layer")
            robust = replace(robust, sigma=robust.sigma[0])
        return Problem(list(layers), self.targets, n_incident=self.n_incident, n_substrate=self.n_substrate,
                       min_thickness=self.min_thickness, max_total_thickness=self.max_total_thickness,
                       robust=robust, name=self.name)

    @property
    def free_thicknesses(self) -> int:
        """How many thicknesses the optimiser varies."""
        return sum(layer.free for layer in self.layers)

    @property
    def choices(self) -> int:
        """How many layers choose their material among candidates."""
        return sum(len(layer.candidates) > 1 for layer in self.layers)
