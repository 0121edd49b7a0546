"""torchirid's materials as Mitsuba 3 BSDFs (optional: ``pip install torchirid[mitsuba]``).

:func:`register` adds three plugins to the active Mitsuba variant, usable from
``mi.load_dict`` and scene XML:

* ``torchirid_thin_film``: a film (``n_film`` [+ ``k_film``] or a material name,
  ``thickness`` in nm or a texture of nm) on a base (``n_substrate`` [+ ``k_substrate``] or a
  material name: ``"Au"``, ``"SiO2"``, ``"water"``, ...) in a medium ``n_incident``; smooth, or
  GGX-rough with ``alpha``.
* ``torchirid_multilayer``: any stack (``materials``, ``thicknesses``: comma-separated strings,
  ``"TiO2,SiO2"``, ``"60,95"`` — Mitsuba properties hold no lists; or ``design`` = the path of a
  design file written by ``torchirid design``).
* ``torchirid_bragg``: a Bragg mirror (``n1``, ``n2`` [+ ``k2``], ``d1``, ``d2``, ``cells``),
  smooth, or Fourneau et al.'s rough Bragg layer (``alpha``) over a Lambertian
  ``base_albedo``.

Parameters are named as in the library's functions. ``evaluator = "torch"`` computes the
optics with the library itself (the exact path; slow), the default ``"drjit"`` in Dr.Jit
float64 arithmetic traced into Mitsuba's kernels. The physics, sampling and the measured
errors are in ``docs/guide/mitsuba.md``.

Example:
    >>> import mitsuba as mi                                     # doctest: +SKIP
    >>> mi.set_variant("scalar_spectral")                        # doctest: +SKIP
    >>> import torchirid.mitsuba
    >>> torchirid.mitsuba.register()                             # doctest: +SKIP
    >>> bsdf = mi.load_dict({"type": "torchirid_thin_film", "n_film": 1.33,
    ...                      "thickness": 400.0, "n_substrate": 1.0})   # doctest: +SKIP
"""

from __future__ import annotations

__all__ = ["register"]

#: the plugin names :func:`register` adds
PLUGINS = ("torchirid_thin_film", "torchirid_multilayer", "torchirid_bragg")

_registered: dict[str, dict] = {}


def register(variant: str | None = None) -> tuple[str, ...]:
    """Register the torchirid BSDFs with Mitsuba for ``variant`` (default: the active one).

    A Python BSDF belongs to the variant that was active when it was defined: call this again
    after each ``mi.set_variant`` (registering a variant twice is harmless).

    Args:
        variant: a Mitsuba variant name (``"scalar_spectral"``, ``"scalar_rgb"``,
            ``"llvm_ad_spectral"``, ``"llvm_ad_rgb"``, ...) to activate first; ``None`` keeps
            the active variant. The polarized and mono variants are not supported.

    Returns:
        The plugin names (``PLUGINS``).

    Raises:
        ImportError: Mitsuba 3 is not installed (``pip install torchirid[mitsuba]``).
        ValueError: no variant is active, or a polarized or mono variant.
    """
    try:
        import drjit as dr
        import mitsuba as mi
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise ImportError("torchirid.mitsuba needs Mitsuba 3: pip install 'torchirid[mitsuba]'") from exc
    if variant is not None:
        mi.set_variant(variant)
    active = mi.variant()
    if active is None:
        raise ValueError("no Mitsuba variant is active: call mi.set_variant(...) or pass variant=")
    if "polarized" in active or "mono" in active:
        raise ValueError(f"variant {active!r} is not supported: use a *_spectral or *_rgb variant")
    if active not in _registered:
        from ._plugins import define

        _registered[active] = define(mi, dr)
    for name, cls in _registered[active].items():
        mi.register_bsdf(name, (lambda c: lambda props: c(props))(cls))
    return PLUGINS
