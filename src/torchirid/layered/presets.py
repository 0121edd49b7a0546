r"""Named layered Bragg structures: the jewel-beetle cuticle of Fourneau et al. 2024 (§5, Fig. 9, Table 3).

The Japanese jewel beetle *Chrysochroa fulgidissima* has three cuticle areas with different
hues at normal incidence (green/blue, red, purple), each an epicuticle of alternating high and
low refractive indices (Schenck et al. 2013 [SWS13], Stavenga et al. 2011 [SDGT11]). Fourneau
et al. model each one as a **single rough Bragg layer of roughness α = 0.05 in air over an
absorbing base**; the host (air, n = 1) differs from both indices of the mirror, so the
mirror's reflectance is appendix D's :math:`r_{hN} = (r_N + r_{h1})/(1 + r_{h1} r_N)`.

Table 3 gives n1, n2, the period Λ, a ratio δ and the number of cells N, but does not define
δ. **Here δ is the fraction of Λ in the high-index (n2) layer**: ``d2 = δΛ``, ``d1 = (1 − δ)Λ``
(with δ = 0.51 the two layers differ by 2 % of Λ either way).

>>> from torchirid.layered import jewel_beetle
>>> layer = jewel_beetle("green").layers[0]
>>> round(layer.d1, 6), round(layer.d2, 6), layer.cells, layer.alpha, layer.n_incident
(78.4, 81.6, 8, 0.05, 1.0)
"""

from __future__ import annotations

from types import MappingProxyType

from .. import _checks
from .structure import LayeredBragg, RoughBraggLayer

__all__ = ["JEWEL_BEETLE_NAMES", "jewel_beetle"]

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
