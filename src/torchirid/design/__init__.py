r"""Inverse design: the stack (thicknesses, and materials among candidates) that meets a target.

A :class:`Problem` is a stack — incident medium, :class:`Layer` s from the incident side down,
exit medium; each material a number, a named material, a table of n, k, or a list of candidates;
each thickness fixed or bounded, in nm — and its targets: :class:`SpectralTarget` (R, T or A
against wavelength at given angles and polarization, with weights and a p-norm) and
:class:`ColourTarget` (CIELAB at given angles, scored by CIEDE2000), plus manufacturability
(minimum layer thickness, maximum total thickness, maximum layer count) and optionally
:class:`Robust` thickness errors to design against (their mean merit, or its worst few percent).

:func:`optimise` finds the stack: differential evolution (SciPy) over whole populations in one
tensor call, exact-gradient refinement (L-BFGS-B through autograd), needle insertion
(Tikhonravov), material choice; seeded, with a time limit and a progress callback. It returns a
:class:`Design`. :func:`tolerance` gives the merit and colour distribution of a design under
random thickness errors and its yield. :func:`read_spec` reads a problem from TOML (the
``torchirid design`` command).

Example (a 10-layer quarter-wave mirror at 600 nm, PyMoosh's ``bragg`` problem):
    >>> from torchirid import design
    >>> p = design.Problem([design.Layer(m, (0, 214.3)) for m in (1.8, 1.4) * 5],
    ...                    [design.SpectralTarget("R", [600.0], value=1.0, polarization="s", p=1)],
    ...                    n_incident=1.0, n_substrate=1.8)
    >>> d = design.optimise(p, seed=0)
    >>> round(d.merit, 9)  # 1 − R of the quarter-wave stack
    0.164855772

Details: ``torchirid.design.problem`` (the merit), ``torchirid.design.merit`` (the
batched evaluation), :mod:`~torchirid.design.optimise`, ``torchirid.design.needle``,
:mod:`~torchirid.design.tolerance`, ``torchirid.design.spec`` (the TOML keys). Needs SciPy;
the AM1.5G weighting needs pvlib (``pip install 'torchirid[design]'``).
"""

from .problem import ColourTarget, Layer, Problem, Robust, SpectralTarget
from .search import Design, optimise
from .spec import read_spec
from .tolerancing import Tolerance, tolerance

__all__ = [
    "ColourTarget",
    "Design",
    "Layer",
    "Problem",
    "Robust",
    "SpectralTarget",
    "Tolerance",
    "optimise",
    "read_spec",
    "tolerance",
]
